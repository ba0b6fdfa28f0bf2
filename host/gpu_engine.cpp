// meshcvt: the GPU engine for the boundary-testing iteration of Fan et al., Section 3.1 (Vulkan
// compute). It takes exactly the decisions of the CPU engine (BoundaryIteration, src/cluster_iterate.cpp):
// same labels face for face, same moves per iteration, same energy history bit for bit.
//
// One iteration, two submissions:
//  1. cluster_boundary (per face): the active-set test and the four-case rule (shaders/boundary_rule.glsl,
//     the twin of src/boundary_rule.h); proposals are appended to a list. cluster_flags clears the
//     last iteration's changed-cluster flags once the boundary kernel has read them.
//     The host reads the proposal count (nothing else) to size the next dispatches exactly.
//  2. With proposals: cluster_disk (tests (a), (b)) and cluster_rank (test (c)) in preserving mode,
//     cluster_apply (labels, 64-bit fixed-point sums by atomics, changed clusters, dirty faces), and
//     cluster_flags gathering the sums of the changed clusters. The host downloads only those,
//     recomputes their generators with compute_generator (so they are bit-identical to the CPU's;
//     ccvt's closest-point step needs the BVH on the host anyway) and uploads them for the next
//     iteration. The energy is cluster_energy summed over clusters 0..n-1, as the CPU engine does.
//
// Labels stay on the GPU; they come down only when asked for (labels()), i.e. around the driver's
// connectivity repair and at the end. The count of evaluated faces may be larger than the CPU's: the
// GPU's active set (see cluster_boundary.comp) is a superset of the CPU's, which is exact either way.
//
// Every array is reached through its buffer device address, so none is limited by
// maxStorageBufferRange; Buffer checks the memory budget before each allocation.
#include <algorithm>
#include <atomic>
#include <cassert>
#include <cstring>
#include <map>
#include <mutex>
#include <numeric>
#include <string>
#include <vector>

#include "cluster_apply.spv.h"
#include "cluster_boundary.spv.h"
#include "cluster_disk.spv.h"
#include "cluster_engine.h"
#include "cluster_flags.spv.h"
#include "cluster_rank.spv.h"
#include "meshcvt/error.h"
#include "vk_buffer.h"
#include "vk_context.h"
#include "vk_pipeline.h"
#include "vk_rule_check.h"
#include "vk_sequence.h"

namespace meshcvt {

namespace {

// Must match `Table` in shaders/cluster_buffers.glsl: one device address per array.
struct GpuTable {
  uint64_t labels, adjacent, points, weights, generators, face_sums, sums, destination, state, dirty, proposals,
      accepted, counters, changed_flags, changed_list, changed_sums, indices, vertex_offsets, vertex_faces;
};

// Must match `Push` in shaders/cluster_buffers.glsl.
struct GpuPush {
  uint64_t table = 0;
  uint32_t face_count = 0;
  uint32_t cluster_count = 0;
  uint32_t flags = 0;
  uint32_t count = 0;
};
static_assert(sizeof(GpuPush) == 24);

constexpr uint32_t kFlagAccelerate = 1;   // FLAG_ACCELERATE
constexpr uint32_t kFlagAllAccepted = 2;  // cluster_apply.comp: paper mode
constexpr uint32_t kFlagClear = 4;        // cluster_flags.comp: clear, else gather
enum Counter : uint32_t { kProposals = 0, kMoves, kEvaluated, kChanged, kOverflow, kCounterCount };

constexpr uint32_t kWorkgroup = 64;
// The boundary test runs over every face each iteration, most of them leaving after a chain of
// dependent loads (label, changed flag, neighbours' labels): bigger groups keep more of those in
// flight. On an H200 (4.8M faces): 32 -> 109 us, 64 -> 75, 128 -> 67, 256 -> 67, 512 -> 68 per
// dispatch (bench/gpu_kernel_bench.cpp); lavapipe does not care.
constexpr uint32_t kBoundaryWorkgroup = 128;
// Largest vertex ring the disk kernel holds in its private member array. Larger rings (a vertex of
// valence beyond ~1000) are refused with a DeviceError naming the numbers.
constexpr uint32_t kMaxRingMembers = 1024;

// An upper bound of the vertex-ring size over all faces: the valences of a face's distinct vertices
// summed, minus the face itself once per vertex.
uint32_t max_ring_bound(const Mesh& mesh, const Topology& topology) {
  const uint32_t* offsets = topology.vertex_face_offsets.data();
  uint64_t best = 0;
  for (size_t f = 0; f < mesh.face_count(); ++f) {
    const uint32_t* v = &mesh.indices[3 * f];
    uint64_t sum = 0;
    for (int j = 0; j < 3; ++j) {
      bool repeated = false;
      for (int k = 0; k < j; ++k) repeated |= v[k] == v[j];
      if (!repeated) sum += offsets[v[j] + 1] - offsets[v[j]] - 1;
    }
    best = std::max(best, sum);
  }
  return uint32_t(std::min<uint64_t>(best, UINT32_MAX));
}

// A device with the clustering pipelines built. Making one costs tens of milliseconds (device
// creation, shader compilation), so engines borrow kits from a process-wide pool and give them back:
// a program (or a test) that clusters many meshes pays once. A kit serves one engine at a time,
// since a Context is used from one thread; a failed context (device lost, timeout) is never reused.
struct DeviceKit {
  int device_index = 0;
  bool validation = false;
  std::unique_ptr<vk::Context> context;
  std::unique_ptr<vk::ComputePipeline> boundary, rank, apply, flags;
  std::map<uint32_t, std::unique_ptr<vk::ComputePipeline>> disk;  // by member-array size

  const vk::ComputePipeline& disk_pipeline(uint32_t max_members);
};

std::mutex kit_pool_mutex;
// Never destroyed (like vk::shared_instance): destroying devices from static destructors at exit
// could run after the driver's own statics are gone. Still reachable, so not a leak to LSan.
std::vector<std::unique_ptr<DeviceKit>>& kit_pool() {
  static auto* pool = new std::vector<std::unique_ptr<DeviceKit>>();
  return *pool;
}

std::unique_ptr<DeviceKit> borrow_kit(int device_index) {
  const bool validation = vk::validation_requested();
  {
    std::lock_guard<std::mutex> lock(kit_pool_mutex);
    auto& pool = kit_pool();
    for (size_t i = 0; i < pool.size(); ++i)
      if (pool[i]->device_index == device_index && pool[i]->validation == validation) {
        std::unique_ptr<DeviceKit> kit = std::move(pool[i]);
        pool.erase(pool.begin() + std::ptrdiff_t(i));
        return kit;
      }
  }
  auto kit = std::make_unique<DeviceKit>();
  kit->device_index = device_index;
  kit->validation = validation;
  kit->context = std::make_unique<vk::Context>(uint32_t(device_index));
  vk::Context& ctx = *kit->context;
  kit->boundary = std::make_unique<vk::ComputePipeline>(ctx, MESHCVT_SPIRV(cluster_boundary), "cluster_boundary",
                                                        sizeof(GpuPush), kBoundaryWorkgroup);
  kit->rank = std::make_unique<vk::ComputePipeline>(ctx, MESHCVT_SPIRV(cluster_rank), "cluster_rank", sizeof(GpuPush),
                                                    kWorkgroup);
  kit->apply = std::make_unique<vk::ComputePipeline>(ctx, MESHCVT_SPIRV(cluster_apply), "cluster_apply",
                                                     sizeof(GpuPush), kWorkgroup);
  kit->flags = std::make_unique<vk::ComputePipeline>(ctx, MESHCVT_SPIRV(cluster_flags), "cluster_flags",
                                                     sizeof(GpuPush), kWorkgroup);
  // The engine gives the CPU engine's labels only where the device computes the boundary rule as
  // the CPU does. Checked once per device and process (the kit is kept), before any clustering:
  // a driver that fuses or reorders despite `precise` would otherwise change labels silently.
  vk::check_boundary_rule(ctx);
  return kit;
}

void return_kit(std::unique_ptr<DeviceKit> kit) {
  if (!kit || kit->context->failed() || kit->context->work_pending()) {
    // Possibly still in use by the GPU: leak rather than destroy (see vk::Context).
    if (kit && kit->context->work_pending()) (void)kit.release();
    return;
  }
  std::lock_guard<std::mutex> lock(kit_pool_mutex);
  kit_pool().push_back(std::move(kit));
}

const vk::ComputePipeline& DeviceKit::disk_pipeline(uint32_t max_members) {
  auto& pipeline = disk[max_members];
  if (!pipeline) {
    const uint32_t constants[2] = {max_members, max_members / 32};
    pipeline = std::make_unique<vk::ComputePipeline>(*context, MESHCVT_SPIRV(cluster_disk), "cluster_disk",
                                                     sizeof(GpuPush), kWorkgroup, constants);
  }
  return *pipeline;
}

// Holds a borrowed kit and gives it back when the engine is destroyed (after its buffers).
struct KitLease {
  std::unique_ptr<DeviceKit> kit;
  ~KitLease() { return_kit(std::move(kit)); }
};

template <typename T>
vk::Buffer make_filled(vk::Context& context, const std::vector<T>& data, const char* name) {
  vk::Buffer buffer(context, std::max<uint64_t>(4, data.size() * sizeof(T)), vk::MemoryUse::device, name);
  if (!data.empty()) vk::upload(context, buffer, data.data(), data.size() * sizeof(T));
  return buffer;
}

class GpuIteration final : public IterationEngine {
 public:
  GpuIteration(const ClusterProblem& problem, const Mesh& mesh, const Topology& topology, TopologyMode mode,
               bool accelerate, int device_index);
  void reset(std::vector<uint32_t> labels) override;
  IterationRecord step() override;
  double energy() const override;
  const std::vector<uint32_t>& labels() const override;
  const std::vector<float>& generators() const override { return generators_; }
  std::string description() const override { return context_->info().name + " (Vulkan)"; }
  bool start_kernel_timing() override {
    timing_ = true;
    return true;
  }
  KernelTimes kernel_times() const override { return kernel_times_; }

 private:
  void record_generator_upload(vk::Sequence& seq);
  GpuPush push(uint32_t flags, uint32_t count) const;

  const ClusterProblem& problem_;
  TopologyMode mode_;
  bool accelerate_;
  uint32_t face_count_, cluster_count_;

  KitLease lease_;  // first member: destroyed last, after every buffer made from its context
  vk::Context* context_ = nullptr;
  const vk::ComputePipeline* disk_ = nullptr;
  vk::Buffer labels_gpu_, adjacent_, points_, weights_, generators_gpu_, face_sums_, sums_gpu_, destination_, state_,
      dirty_, proposals_, accepted_, counters_, changed_flags_, changed_list_, changed_sums_, indices_,
      vertex_offsets_, vertex_faces_, table_, readback_;
  // Host-visible twins, written or read by copies inside the iteration's own submissions: an
  // iteration moves its data without a submission (and a staging allocation) of its own.
  vk::Buffer generators_upload_, changed_list_readback_, changed_sums_readback_;
  std::vector<VkBufferCopy> generator_regions_;
  std::unique_ptr<vk::Sequence> sequence_;

  mutable std::vector<uint32_t> labels_;  // host copy, downloaded when asked for
  mutable bool labels_stale_ = false;
  std::vector<int64_t> sums_;             // host copy of every cluster's sums
  std::vector<float> generators_;         // 3 per cluster, computed here
  std::vector<uint32_t> changed_;         // clusters changed by the last iteration (their flags are set on the GPU)
  bool all_generators_stale_ = true;      // upload every generator (after reset)
  bool timing_ = false;                   // timestamps around the kernels (benchmarks)
  KernelTimes kernel_times_;
};

GpuIteration::GpuIteration(const ClusterProblem& problem, const Mesh& mesh, const Topology& topology,
                           TopologyMode mode, bool accelerate, int device_index)
    : problem_(problem), mode_(mode), accelerate_(accelerate), face_count_(problem.face_count),
      cluster_count_(problem.clusters) {
  if (device_index < 0) throw DeviceError("gpu engine: invalid device index " + std::to_string(device_index));
  // The kernels index 5 int64 per face with 32-bit arithmetic.
  if (uint64_t(face_count_) * kSumComponents > UINT32_MAX || uint64_t(cluster_count_) * kSumComponents > UINT32_MAX)
    throw DeviceError("gpu engine: " + std::to_string(face_count_) + " faces; the GPU kernels support at most " +
                      std::to_string(UINT32_MAX / kSumComponents));
  assert(topology.face_adjacent.size() == 3 * size_t(face_count_));
  const uint32_t ring_bound = max_ring_bound(mesh, topology);
  if (ring_bound > kMaxRingMembers)
    throw DeviceError("gpu engine: the mesh has a vertex ring of up to " + std::to_string(ring_bound) +
                      " faces; the GPU disk filter supports at most " + std::to_string(kMaxRingMembers),
                      "use --device cpu, or --topology paper");
  const uint32_t max_members = std::max<uint32_t>(64, (ring_bound + 31) / 32 * 32);

  lease_.kit = borrow_kit(device_index);
  context_ = lease_.kit->context.get();
  vk::Context& ctx = *context_;
  vk::arm_faults_from_environment(ctx);  // $MESHCVT_GPU_FAULT: faults on demand, for tests
  disk_ = &lease_.kit->disk_pipeline(max_members);
  const uint64_t nf = face_count_, nc = std::max<uint32_t>(cluster_count_, 1);
  using vk::MemoryUse;

  std::vector<int64_t> face_sums(nf * kSumComponents);
  for (uint32_t f = 0; f < face_count_; ++f) problem.face_fixed(f, &face_sums[size_t(f) * kSumComponents]);
  labels_gpu_ = vk::Buffer(ctx, nf * 4, MemoryUse::device, "face labels");
  adjacent_ = make_filled(ctx, topology.face_adjacent, "face adjacency");
  points_ = make_filled(ctx, problem.point, "face points");
  weights_ = make_filled(ctx, problem.weight, "face weights");
  generators_gpu_ = vk::Buffer(ctx, nc * 12, MemoryUse::device, "cluster generators");
  face_sums_ = make_filled(ctx, face_sums, "face fixed-point sums");
  face_sums = {};
  sums_gpu_ = vk::Buffer(ctx, nc * 8 * kSumComponents, MemoryUse::device, "cluster sums");
  destination_ = vk::Buffer(ctx, nf * 4, MemoryUse::device, "proposed destinations");
  state_ = vk::Buffer(ctx, nf * 4, MemoryUse::device, "proposal states");
  dirty_ = vk::Buffer(ctx, nf * 4, MemoryUse::device, "dirty faces");
  proposals_ = vk::Buffer(ctx, nf * 4, MemoryUse::device, "proposal list");
  accepted_ = vk::Buffer(ctx, nf * 4, MemoryUse::device, "accepted proposals");
  counters_ = vk::Buffer(ctx, kCounterCount * 4, MemoryUse::device, "iteration counters");
  changed_flags_ = vk::Buffer(ctx, nc * 4, MemoryUse::device, "changed-cluster flags");
  changed_list_ = vk::Buffer(ctx, nc * 4, MemoryUse::device, "changed-cluster list");
  changed_sums_ = vk::Buffer(ctx, nc * 8 * kSumComponents, MemoryUse::device, "changed-cluster sums");
  indices_ = make_filled(ctx, mesh.indices, "face indices");
  vertex_offsets_ = make_filled(ctx, topology.vertex_face_offsets, "vertex face offsets");
  vertex_faces_ = make_filled(ctx, topology.vertex_faces, "vertex faces");
  readback_ = vk::Buffer(ctx, kCounterCount * 4, MemoryUse::readback, "counter readback");
  generators_upload_ = vk::Buffer(ctx, nc * 12, MemoryUse::staging, "generator uploads");
  changed_list_readback_ = vk::Buffer(ctx, nc * 4, MemoryUse::readback, "changed-cluster list readback");
  changed_sums_readback_ =
      vk::Buffer(ctx, nc * 8 * kSumComponents, MemoryUse::readback, "changed-cluster sums readback");

  GpuTable table{labels_gpu_.address(),    adjacent_.address(),      points_.address(),       weights_.address(),
                 generators_gpu_.address(), face_sums_.address(),    sums_gpu_.address(),     destination_.address(),
                 state_.address(),          dirty_.address(),        proposals_.address(),    accepted_.address(),
                 counters_.address(),       changed_flags_.address(), changed_list_.address(), changed_sums_.address(),
                 indices_.address(),        vertex_offsets_.address(), vertex_faces_.address()};
  table_ = vk::Buffer(ctx, sizeof(table), MemoryUse::device, "buffer address table");
  vk::upload(ctx, table_, &table, sizeof(table));

  sequence_ = std::make_unique<vk::Sequence>(ctx);
}

GpuPush GpuIteration::push(uint32_t flags, uint32_t count) const {
  GpuPush p;
  p.table = table_.address();
  p.face_count = face_count_;
  p.cluster_count = cluster_count_;
  p.flags = flags;
  p.count = count;
  return p;
}

void GpuIteration::reset(std::vector<uint32_t> labels) {
  const uint32_t nf = face_count_, nc = cluster_count_;
  labels_ = std::move(labels);
  assert(labels_.size() == nf);
  labels_stale_ = false;
  sums_ = compute_cluster_sums(problem_, labels_, nc);
  generators_.assign(3 * size_t(nc), 0.0f);
  for (uint32_t c = 0; c < nc; ++c) compute_generator(problem_, &sums_[size_t(c) * kSumComponents], &generators_[3 * c]);
  vk::Context& ctx = *context_;
  if (nf) vk::upload(ctx, labels_gpu_, labels_.data(), uint64_t(nf) * 4);
  if (nc) vk::upload(ctx, sums_gpu_, sums_.data(), sums_.size() * sizeof(int64_t));
  // Every cluster counts as changed: the first iteration tests every border face.
  changed_.resize(nc);
  std::iota(changed_.begin(), changed_.end(), 0u);
  if (nc) vk::upload(ctx, changed_list_, changed_.data(), uint64_t(nc) * 4);
  all_generators_stale_ = true;
  vk::Sequence& seq = *sequence_;
  seq.fill(dirty_, 0).fill(state_, 0).fill(changed_flags_, 1).run();
}

// The generators the last iteration changed (all after reset) go up before the next boundary test:
// written to the mapped upload buffer and copied, in runs, at the head of the boundary test's
// submission. (On a discrete GPU a separate upload would cost a staging buffer and
// a submission each iteration: 4-5 ms per iteration on an H200, against tens of microseconds of
// kernels.)
void GpuIteration::record_generator_upload(vk::Sequence& seq) {
  float* staging = generators_upload_.mapped_as<float>();
  generator_regions_.clear();
  if (all_generators_stale_) {
    if (!generators_.empty()) {
      std::memcpy(staging, generators_.data(), generators_.size() * sizeof(float));
      generator_regions_.push_back({0, 0, generators_.size() * sizeof(float)});
    }
  } else {
    // The staging copy always mirrors generators_, so runs of changed clusters may be merged across
    // small gaps: copying a few unchanged generators costs less than one more region (10k regions
    // of 12 bytes each took milliseconds per iteration on an H200).
    std::sort(changed_.begin(), changed_.end());
    constexpr uint32_t kMergeGap = 64;  // clusters (768 bytes)
    for (size_t i = 0; i < changed_.size();) {
      const uint32_t first = changed_[i];
      uint32_t last = first;
      for (; i < changed_.size() && changed_[i] <= last + kMergeGap; ++i) last = changed_[i];
      std::memcpy(staging + 3 * size_t(first), &generators_[3 * size_t(first)], 12 * size_t(last - first + 1));
      const VkDeviceSize at = 12 * VkDeviceSize(first);
      generator_regions_.push_back({at, at, 12 * VkDeviceSize(last - first + 1)});
    }
  }
  seq.copy_regions(generators_upload_, generators_gpu_, generator_regions_);
  all_generators_stale_ = false;
}

IterationRecord GpuIteration::step() {
  IterationRecord record;
  vk::Sequence& seq = *sequence_;
  record_generator_upload(seq);
  const uint32_t* counters = readback_.mapped_as<const uint32_t>();
  const uint32_t flags = accelerate_ ? kFlagAccelerate : 0;

  // 1. boundary test; then the last iteration's changed flags are cleared (the test read them)
  seq.fill(counters_, 0).barrier();
  const uint32_t boundary_begin = timing_ ? seq.timestamp() : 0;
  seq.dispatch_1d(*lease_.kit->boundary, face_count_, push(flags, 0)).barrier();
  const uint32_t boundary_end = timing_ ? seq.timestamp() : 0;
  if (!changed_.empty()) seq.dispatch_1d(*lease_.kit->flags, changed_.size(), push(kFlagClear, uint32_t(changed_.size())));
  seq.barrier().copy(counters_, readback_, counters_.size()).run();
  if (timing_) {
    kernel_times_.boundary_s += seq.timestamp_seconds(boundary_begin, boundary_end);
    ++kernel_times_.boundary_dispatches;
  }
  const uint32_t proposals = counters[kProposals];
  record.evaluated_faces = counters[kEvaluated];
  changed_.clear();
  if (proposals > 0) {
    // 2. disk filter, apply, gather the changed clusters' sums
    const uint32_t update_begin = timing_ ? seq.timestamp() : 0;
    if (mode_ == TopologyMode::preserving) {
      seq.dispatch_1d(*disk_, proposals, push(flags, proposals)).barrier();
      seq.dispatch_1d(*lease_.kit->rank, proposals, push(flags, proposals)).barrier();
    }
    const uint32_t apply_flags = flags | (mode_ == TopologyMode::paper ? kFlagAllAccepted : 0);
    seq.dispatch_1d(*lease_.kit->apply, proposals, push(apply_flags, proposals)).barrier();
    const uint64_t most_changed = std::min<uint64_t>(cluster_count_, 2ull * proposals);
    seq.dispatch_1d(*lease_.kit->flags, most_changed, push(0, 0)).barrier();
    const uint32_t update_end = timing_ ? seq.timestamp() : 0;
    seq.copy(changed_list_, changed_list_readback_, most_changed * 4)
        .copy(changed_sums_, changed_sums_readback_, most_changed * 8 * kSumComponents)
        .copy(counters_, readback_, counters_.size())
        .run();
    if (timing_) kernel_times_.update_s += seq.timestamp_seconds(update_begin, update_end);
    if (counters[kOverflow] != 0)
      throw DeviceError("gpu engine: a vertex ring exceeded the disk kernel's member array (internal error)");
    record.moves = counters[kMoves];
    const uint32_t changed = counters[kChanged];
    assert(changed <= most_changed);
    const uint32_t* changed_list = changed_list_readback_.mapped_as<const uint32_t>();
    const int64_t* changed_sums = changed_sums_readback_.mapped_as<const int64_t>();
    changed_.assign(changed_list, changed_list + changed);
    for (uint32_t i = 0; i < changed; ++i) {
      const uint32_t c = changed_[i];
      assert(c < cluster_count_);
      std::memcpy(&sums_[size_t(c) * kSumComponents], &changed_sums[size_t(i) * kSumComponents],
                  kSumComponents * sizeof(int64_t));
      compute_generator(problem_, &sums_[size_t(c) * kSumComponents], &generators_[3 * size_t(c)]);
    }
    if (record.moves) labels_stale_ = true;
  }
  record.energy = energy();
  return record;
}

double GpuIteration::energy() const {
  double e = 0;
  for (uint32_t c = 0; c < cluster_count_; ++c)
    e += cluster_energy(problem_, &sums_[size_t(c) * kSumComponents], &generators_[3 * size_t(c)]);
  return e;
}

const std::vector<uint32_t>& GpuIteration::labels() const {
  if (labels_stale_) {
    vk::download(*context_, labels_gpu_, labels_.data(), uint64_t(face_count_) * 4);
    labels_stale_ = false;
  }
  return labels_;
}

}  // namespace

static std::atomic<uint64_t> g_gpu_engine_setups{0};

std::unique_ptr<IterationEngine> make_gpu_iteration(const ClusterProblem& problem, const Mesh& mesh,
                                                    const Topology& topology, TopologyMode mode, bool accelerate,
                                                    int device_index) {
  g_gpu_engine_setups.fetch_add(1, std::memory_order_relaxed);
  return std::make_unique<GpuIteration>(problem, mesh, topology, mode, accelerate, device_index);
}

uint64_t gpu_engine_setups() { return g_gpu_engine_setups.load(std::memory_order_relaxed); }

}  // namespace meshcvt
