// Tests of the Vulkan host layer (host/) and the device model (meshcvt/device.h): VkResult
// reporting, --device resolution, the self-test (int64 atomics through buffer device addresses),
// buffers beyond maxStorageBufferRange, the memory-budget check, staging copies, markers, timeouts,
// and that the validation layer stays silent.
//
// GPU tests need a Vulkan device (lavapipe from mesa-vulkan-drivers is enough); without one they
// fail with a message saying so, unless MESHCVT_SKIP_GPU_TESTS=1 skips them.
#include <doctest/doctest.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <numeric>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "meshcvt/cluster.h"
#include "meshcvt/device.h"
#include "meshcvt/error.h"
#include "meshcvt/topology.h"
#include "test_meshes.h"
#include "gpu_test_device.h"
#include "vk_buffer.h"
#include "vk_context.h"
#include "vk_errors.h"
#include "vk_pipeline.h"
#include "vk_selftest.h"
#include "vk_sequence.h"

using namespace meshcvt;

using test::ScopedEnv;

namespace {

DeviceInfo fake_device(uint32_t index, const char* type, bool usable, const char* missing = "") {
  DeviceInfo d;
  d.index = index;
  d.name = std::string("fake ") + type;
  d.type = type;
  d.usable = usable;
  d.missing_features = missing;
  return d;
}

// Busy work for selftest.comp: `count` invocations of `spin` LCG steps each, into `results`.
vk::SelfTestPush spin_push(const vk::Buffer& results, uint32_t count, uint32_t spin) {
  vk::SelfTestPush push;
  push.results = results.address();
  push.mode = vk::self_test_spin;
  push.count = count;
  push.spin = spin;
  return push;
}

std::string error_text(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

}  // namespace

// ---- no device needed

TEST_CASE("vk: VkResult names and DeviceError messages") {
  CHECK(vk::result_name(VK_ERROR_OUT_OF_DEVICE_MEMORY) == "VK_ERROR_OUT_OF_DEVICE_MEMORY");
  CHECK(vk::result_name(VK_ERROR_DEVICE_LOST) == "VK_ERROR_DEVICE_LOST");
  CHECK(vk::result_name(VK_TIMEOUT) == "VK_TIMEOUT");
  CHECK(vk::result_name(static_cast<VkResult>(-424242)) == "VkResult(-424242)");
  CHECK_NOTHROW(vk::check(VK_SUCCESS, "vkQueueSubmit"));
  CHECK_THROWS_AS(vk::check(VK_ERROR_DEVICE_LOST, "vkQueueSubmit"), DeviceError);
  const std::string message = error_text([] { vk::check(VK_ERROR_DEVICE_LOST, "vkQueueSubmit"); });
  CHECK(message.find("vkQueueSubmit failed: VK_ERROR_DEVICE_LOST") == 0);
  CHECK(message.find("--device cpu") != std::string::npos);
  try {
    vk::check(VK_ERROR_DEVICE_LOST, "vkQueueSubmit");
  } catch (const DeviceError& e) {  // the advice apart from the reason: cluster()'s fallback reports the reason
    CHECK(e.reason().find("vkQueueSubmit failed: VK_ERROR_DEVICE_LOST") == 0);
    CHECK(e.reason().find("--device cpu") == std::string::npos);
    CHECK(e.advice().find("--device cpu") != std::string::npos);
    CHECK(std::string(e.what()) == e.reason() + "; " + e.advice());
  }
  CHECK(std::string(DeviceError("no device").what()) == "no device");
  CHECK(error_text([] { vk::check(VK_ERROR_OUT_OF_DEVICE_MEMORY, "vkAllocateMemory"); })
            .find("vkAllocateMemory failed: VK_ERROR_OUT_OF_DEVICE_MEMORY") == 0);
}

TEST_CASE("resolve_device: syntax") {
  ScopedEnv no_default("MESHCVT_DEVICE", nullptr);
  const std::vector<DeviceInfo> one{fake_device(0, "cpu", true)};
  for (const char* bad : {"bogus", "GPU", "gpu:", "gpu:-1", "gpu:1x", "gpu:0:1", " gpu", "cpu ", "gpu:99999999999"}) {
    CAPTURE(bad);
    CHECK_THROWS_AS(resolve_device(bad, one), OptionError);
  }
  const std::string message = error_text([&] { resolve_device("bogus", one); });
  CHECK(message.find("\"bogus\"") != std::string::npos);
  for (const char* form : {"auto", "cpu", "gpu", "gpu:N"}) CHECK(message.find(form) != std::string::npos);

  DeviceChoice cpu = resolve_device("cpu", one);
  CHECK_FALSE(cpu.use_gpu);
  CHECK(cpu.device_index == -1);
  CHECK(cpu.description == "cpu");
  CHECK(cpu.notice.empty());
  // "cpu" never touches Vulkan, so it works on any machine.
  CHECK_FALSE(resolve_device("cpu").use_gpu);
  CHECK_THROWS_AS(resolve_device("bogus"), OptionError);

  DeviceChoice zero = resolve_device("gpu:0", one);
  CHECK(zero.use_gpu);
  CHECK(zero.device_index == 0);
  CHECK(zero.description.find("fake cpu") != std::string::npos);

  CHECK_THROWS_AS(resolve_device("gpu:99", one), DeviceError);
  const std::string out_of_range = error_text([&] { resolve_device("gpu:99", one); });
  CHECK(out_of_range.find("gpu:99") != std::string::npos);
  CHECK(out_of_range.find("gpu:0 fake cpu") != std::string::npos);  // names what there is
}

TEST_CASE("resolve_device: empty request reads MESHCVT_DEVICE") {
  const std::vector<DeviceInfo> devices{fake_device(0, "cpu", true), fake_device(1, "discrete", true)};
  {
    ScopedEnv env("MESHCVT_DEVICE", "cpu");
    CHECK_FALSE(resolve_device("", devices).use_gpu);
    CHECK(resolve_device("gpu:0", devices).device_index == 0);  // an explicit request wins
  }
  {
    ScopedEnv env("MESHCVT_DEVICE", "gpu:0");
    CHECK(resolve_device("", devices).device_index == 0);
  }
  {
    ScopedEnv env("MESHCVT_DEVICE", nullptr);
    CHECK(resolve_device("", devices).device_index == 1);  // auto
  }
  {
    ScopedEnv env("MESHCVT_DEVICE", "");
    CHECK(resolve_device("", devices).device_index == 1);  // empty counts as unset
  }
  {
    ScopedEnv env("MESHCVT_DEVICE", "nonsense");
    CHECK_THROWS_AS(resolve_device("", devices), OptionError);
    CHECK(error_text([&] { resolve_device("", devices); }).find("MESHCVT_DEVICE") != std::string::npos);
  }
}

TEST_CASE("resolve_device_for_mesh: auto keeps meshes below a million faces per two threads on the CPU, unprobed") {
  // A probe here would fail loudly: Vulkan is forced to be probed and its loader does not exist.
  // (ctest runs each case in a process of its own, so the loader is not already loaded.)
  ScopedEnv probe("MESHCVT_PROBE_VULKAN", "1");
  ScopedEnv loader("MESHCVT_VULKAN_LIBRARY", "/nonexistent/libvulkan.so.1");
  ScopedEnv no_default("MESHCVT_DEVICE", nullptr);
  CHECK(auto_gpu_min_faces(1) == kAutoGpuMinFaces);
  CHECK(auto_gpu_min_faces(2) == kAutoGpuMinFaces);
  CHECK(auto_gpu_min_faces(3) == kAutoGpuMinFaces);
  CHECK(auto_gpu_min_faces(4) == 2 * kAutoGpuMinFaces);
  CHECK(auto_gpu_min_faces(16) == 8 * kAutoGpuMinFaces);
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  CHECK(auto_gpu_min_faces(0) == auto_gpu_min_faces(cores));
  for (const char* request : {"auto", ""}) {
    CAPTURE(request);
    for (unsigned threads : {0u, 1u, 2u, 16u}) {
      CAPTURE(threads);
      const DeviceChoice small = resolve_device_for_mesh(request, auto_gpu_min_faces(threads) - 1, threads);
      CHECK_FALSE(small.use_gpu);
      CHECK(small.notice.empty());
      CHECK(small.description == "cpu");
    }
    // 4M faces: a GPU's size at two threads, not at sixteen.
    CHECK(resolve_device_for_mesh(request, 4 * kAutoGpuMinFaces, 16).notice.empty());
  }
  {
    ScopedEnv from_environment("MESHCVT_DEVICE", "auto");
    CHECK(resolve_device_for_mesh("", 10).notice.empty());
  }
  CHECK(resolve_device_for_mesh("cpu", kAutoGpuMinFaces).description == "cpu");
  // An explicit GPU request is not second-guessed by size: it probes, and fails without a loader
  // (unless an earlier case in this process loaded one).
  if (!vk::vulkan_loaded()) {
    CHECK_THROWS_AS(resolve_device_for_mesh("gpu", 10), DeviceError);
    CHECK_THROWS_AS(resolve_device_for_mesh("gpu", 10, 16), DeviceError);
    // Large meshes under auto do probe: the failure becomes the fallback's notice.
    CHECK_FALSE(resolve_device_for_mesh("auto", kAutoGpuMinFaces, 2).notice.empty());
    CHECK_FALSE(resolve_device_for_mesh("auto", 4 * kAutoGpuMinFaces, 2).notice.empty());
    CHECK_FALSE(resolve_device_for_mesh("auto", auto_gpu_min_faces(0)).notice.empty());
  }
}

TEST_CASE("cluster: auto weighs the mesh against the thread count it is given") {
  // cluster() must pass ClusterOptions::threads to the device choice: a mesh of a million faces
  // is a GPU's size at two threads and not at four. Probing is forced and the loader does not
  // exist, so a probe shows as the CPU fallback's notice and no GPU is needed; the clustering
  // runs on the CPU either way (no iterations: only the choice is under test).
  ScopedEnv probe("MESHCVT_PROBE_VULKAN", "1");
  ScopedEnv loader("MESHCVT_VULKAN_LIBRARY", "/nonexistent/libvulkan.so.1");
  ScopedEnv no_default("MESHCVT_DEVICE", nullptr);
  if (vk::vulkan_loaded()) {  // a loader already in this process would make the probe succeed
    MESSAGE("skipped: a Vulkan loader is loaded in this process (ctest runs each case alone)");
    return;
  }
  const Mesh mesh = test::grid(708, 708);
  REQUIRE(mesh.face_count() >= auto_gpu_min_faces(2));
  REQUIRE(mesh.face_count() < auto_gpu_min_faces(4));
  const Topology topology = build_topology(mesh);
  ClusterOptions options;
  options.clusters = 8;
  options.max_iterations = 0;
  options.device = "auto";
  options.threads = 4;
  const Clustering four = cluster(mesh, topology, options);
  CHECK(four.device_notice.empty());  // below four threads' size: not probed
  CHECK(four.device.rfind("cpu", 0) == 0);
  options.threads = 2;
  const Clustering two = cluster(mesh, topology, options);
  CHECK(two.device_notice.find("CPU engine") != std::string::npos);  // probed, and no loader
  CHECK(two.device.rfind("cpu", 0) == 0);
  CHECK(two.labels == four.labels);
}

TEST_CASE("resolve_device: ranking and auto fallback") {
  ScopedEnv no_default("MESHCVT_DEVICE", nullptr);
  const std::vector<DeviceInfo> mixed{
      fake_device(0, "cpu", true),          fake_device(1, "integrated", true),
      fake_device(2, "discrete", false, "shaderBufferInt64Atomics"), fake_device(3, "discrete", true),
      fake_device(4, "virtual", true),      fake_device(5, "discrete", true)};
  CHECK(resolve_device("gpu", mixed).device_index == 3);   // discrete, usable, lowest index
  CHECK(resolve_device("auto", mixed).device_index == 3);
  CHECK(resolve_device("gpu:1", mixed).device_index == 1);
  CHECK(resolve_device("gpu:0", mixed).use_gpu);            // lavapipe when asked for by index
  // Only a GPU that auto chose may hand a failing job to the CPU engine (cluster()'s fallback).
  CHECK(resolve_device("auto", mixed).automatic);
  CHECK_FALSE(resolve_device("gpu", mixed).automatic);
  CHECK_FALSE(resolve_device("gpu:3", mixed).automatic);
  CHECK_FALSE(resolve_device("cpu", mixed).automatic);

  const std::string unusable = error_text([&] { resolve_device("gpu:2", mixed); });
  CHECK(unusable.find("gpu:2") != std::string::npos);
  CHECK(unusable.find("shaderBufferInt64Atomics") != std::string::npos);

  const std::vector<DeviceInfo> integrated_and_virtual{fake_device(0, "virtual", true), fake_device(1, "integrated", true)};
  CHECK(resolve_device("gpu", integrated_and_virtual).device_index == 1);
  CHECK(resolve_device("auto", integrated_and_virtual).device_index == 1);

  // Only lavapipe: "gpu" takes it, "auto" silently prefers the CPU engine.
  const std::vector<DeviceInfo> lavapipe_only{fake_device(0, "cpu", true)};
  CHECK(resolve_device("gpu", lavapipe_only).device_index == 0);
  DeviceChoice automatic = resolve_device("auto", lavapipe_only);
  CHECK_FALSE(automatic.use_gpu);
  CHECK(automatic.notice.empty());
  const std::vector<DeviceInfo> virtual_only{fake_device(0, "virtual", true)};
  CHECK_FALSE(resolve_device("auto", virtual_only).use_gpu);
  CHECK(resolve_device("gpu", virtual_only).use_gpu);

  // A GPU that cannot run meshcvt: auto falls back with a notice naming what it lacks.
  const std::vector<DeviceInfo> old_gpu{fake_device(0, "cpu", true), fake_device(1, "discrete", false, "shaderInt64")};
  DeviceChoice fallback = resolve_device("auto", old_gpu);
  CHECK_FALSE(fallback.use_gpu);
  CHECK(fallback.notice.find("shaderInt64") != std::string::npos);
  CHECK(fallback.notice.find('\n') == std::string::npos);
  CHECK(resolve_device("gpu", old_gpu).device_index == 0);

  // No device at all.
  const std::vector<DeviceInfo> none;
  DeviceChoice nothing = resolve_device("auto", none);
  CHECK_FALSE(nothing.use_gpu);
  CHECK(nothing.notice.find("no Vulkan device") != std::string::npos);
  CHECK_THROWS_AS(resolve_device("gpu", none), DeviceError);
  CHECK(error_text([&] { resolve_device("gpu", none); }).find("mesa-vulkan-drivers") != std::string::npos);
  CHECK_THROWS_AS(resolve_device("gpu:0", none), DeviceError);

  const std::vector<DeviceInfo> all_unusable{fake_device(0, "discrete", false, "bufferDeviceAddress")};
  const std::string why = error_text([&] { resolve_device("gpu", all_unusable); });
  CHECK(why.find("bufferDeviceAddress") != std::string::npos);
}

// ---- on a device

TEST_CASE("vk: list_devices describes the devices" * doctest::skip(test::skip_gpu_tests())) {
  const uint32_t index = test::gpu_test_device();
  std::vector<DeviceInfo> devices = list_devices();
  REQUIRE(index < devices.size());
  for (uint32_t i = 0; i < devices.size(); ++i) {
    const DeviceInfo& d = devices[i];
    CAPTURE(d.name);
    CHECK(d.index == i);
    CHECK_FALSE(d.name.empty());
    CHECK(d.api_version.find('.') != std::string::npos);
    CHECK_FALSE(d.heap_sizes.empty());
    CHECK(d.heap_sizes.size() == d.heap_device_local.size());
    CHECK(d.max_storage_buffer_range > 0);
    CHECK(d.max_workgroup_count_x >= 65535);  // the Vulkan minimum
    CHECK(d.usable == d.missing_features.empty());
  }
  const DeviceInfo& d = devices[index];
  CHECK(d.usable);
  CHECK(d.subgroup_size > 0);
  // Real GPUs are preferred by "auto"; a machine with only lavapipe runs the CPU engine.
  bool has_real_gpu = false;
  for (const DeviceInfo& other : devices) has_real_gpu |= other.usable && (other.type == "discrete" || other.type == "integrated");
  ScopedEnv no_default("MESHCVT_DEVICE", nullptr);
  CHECK(resolve_device("auto").use_gpu == has_real_gpu);
  CHECK_THROWS_AS(resolve_device("gpu:99"), DeviceError);
  CHECK(error_text([] { resolve_device("gpu:99"); }).find("gpu:99") != std::string::npos);
}

TEST_CASE("vk: self-test of int64 atomics through buffer device addresses" * doctest::skip(test::skip_gpu_tests())) {
  const uint32_t index = test::gpu_test_device();
  const uint64_t messages = vk::validation_message_count();
  {
    vk::Context context(index);
    CHECK(context.validation() == vk::validation_requested());
    vk::run_self_test(context);
  }
  CHECK(self_test_device(index) > 0);
  CHECK(vk::validation_message_count() == messages);
  // The inputs really are what the test claims to cover: beyond 32 bits, and both signs.
  bool negative = false, positive = false;
  for (uint32_t i = 0; i < 100; ++i) {
    const int64_t v = vk::self_test_input(i);
    CHECK((v > (int64_t(1) << 32) || v < -(int64_t(1) << 32)));
    negative |= v < 0;
    positive |= v > 0;
  }
  CHECK(negative);
  CHECK(positive);
}

TEST_CASE("vk: a buffer larger than maxStorageBufferRange is addressed through its device address" *
          doctest::skip(test::skip_gpu_tests())) {
  const uint32_t index = test::gpu_test_device();
  const uint64_t messages = vk::validation_message_count();
  {
    vk::Context context(index);
    const uint64_t bytes = uint64_t(context.limits().maxStorageBufferRange) + (1u << 16);
    if (context.max_allocation_bytes() && bytes > context.max_allocation_bytes()) {
      // No buffer can outgrow a binding here (NVIDIA: both limits are 4 GiB): the allocation is
      // refused with an error naming the limit, before the driver sees it.
      MESSAGE("device allows no allocation beyond maxStorageBufferRange; checking the refusal instead");
      CHECK(error_text([&] { vk::Buffer(context, bytes, vk::MemoryUse::device, "big array"); })
                .find("maxMemoryAllocationSize") != std::string::npos);
      return;
    }
    vk::Buffer big(context, bytes, vk::MemoryUse::device, "big array");
    CHECK(big.size() >= bytes);
    CHECK(big.address() != 0);
    vk::ComputePipeline pipeline(context, vk::self_test_spirv(), "selftest", sizeof(vk::SelfTestPush), 32);
    vk::SelfTestPush push;
    push.inputs = big.address();
    push.mode = vk::self_test_write;
    const uint64_t last = bytes / 8 - 1;                 // beyond what one binding could reach
    const uint64_t first = 3;
    vk::Sequence sequence(context);
    push.index = first;
    push.value = -(int64_t(1) << 40) - 5;
    sequence.dispatch(pipeline, 1, push).barrier();
    push.index = last;
    push.value = (int64_t(1) << 50) + 7;
    sequence.dispatch(pipeline, 1, push);
    sequence.run();
    int64_t got_first = 0, got_last = 0;
    vk::download(context, big, &got_first, 8, first * 8);
    vk::download(context, big, &got_last, 8, last * 8);
    CHECK(got_first == -(int64_t(1) << 40) - 5);
    CHECK(got_last == (int64_t(1) << 50) + 7);
  }
  CHECK(vk::validation_message_count() == messages);
}

TEST_CASE("vk: the memory budget check refuses an allocation that cannot fit" * doctest::skip(test::skip_gpu_tests())) {
  const uint32_t index = test::gpu_test_device();
  const uint64_t messages = vk::validation_message_count();
  {
    vk::Context context(index);
    const uint64_t absurd = uint64_t(1) << 50;  // 1 PiB
    CHECK_THROWS_AS(vk::Buffer(context, absurd, vk::MemoryUse::device, "absurd array"), DeviceError);
    const std::string message = error_text([&] { vk::Buffer(context, absurd, vk::MemoryUse::device, "absurd array"); });
    CHECK(message.find("absurd array") != std::string::npos);
    CHECK(message.find("1073741824.0 MiB requested") != std::string::npos);
    CHECK(message.find("MiB available") != std::string::npos);

    // Just over the biggest heap is refused too, with the heap's size in the message.
    uint64_t biggest = 0;
    for (uint64_t size : context.info().heap_sizes) biggest = std::max(biggest, size);
    CHECK_THROWS_AS(vk::Buffer(context, biggest + 4096, vk::MemoryUse::device, "too big"), DeviceError);

    // Allocations count against the budget: what is left shrinks while a buffer lives.
    const uint32_t heap = context.memory_properties().memoryTypes[context.memory_type(~0u, vk::MemoryUse::device)].heapIndex;
    const uint64_t before = context.heap_available(heap);
    {
      vk::Buffer held(context, 8u << 20, vk::MemoryUse::device, "held");
      CHECK(context.heap_available(heap) < before);
    }
    // A refusal leaves the context usable.
    vk::Buffer small(context, 64, vk::MemoryUse::readback, "small");
    CHECK(small.mapped() != nullptr);
    CHECK_FALSE(context.failed());
  }
  CHECK(vk::validation_message_count() == messages);
}

TEST_CASE("vk: uploads and downloads, mapped and through staging copies" * doctest::skip(test::skip_gpu_tests())) {
  const uint32_t index = test::gpu_test_device();
  const uint64_t messages = vk::validation_message_count();
  {
    vk::Context context(index);
    // An odd size and several staging chunks.
    std::vector<uint8_t> data(300'001);
    for (size_t i = 0; i < data.size(); ++i) data[i] = static_cast<uint8_t>(i * 131 + (i >> 8));
    vk::Buffer device(context, data.size() + 16, vk::MemoryUse::device, "device data");
    vk::upload_staged(context, device, data.data(), data.size(), 5, 64 * 1024);
    std::vector<uint8_t> back(data.size());
    vk::download_staged(context, device, back.data(), back.size(), 5, 48 * 1024);
    CHECK(back == data);

    // The plain forms agree (mapped memcpy where the memory allows it).
    std::vector<uint32_t> words(1000);
    std::iota(words.begin(), words.end(), 7u);
    vk::Buffer small(context, words.size() * 4, vk::MemoryUse::device, "words");
    vk::upload(context, small, std::span<const uint32_t>(words));
    std::vector<uint32_t> words_back(words.size());
    vk::download(context, small, std::span<uint32_t>(words_back));
    CHECK(words_back == words);

    // fill + copy on the device.
    vk::Buffer readback(context, 16, vk::MemoryUse::readback, "readback");
    vk::Sequence sequence(context);
    sequence.fill(small, 0xABCD1234u).barrier().copy(small, readback, 16, 40, 0).run();
    const uint32_t* mapped = readback.mapped_as<uint32_t>();
    for (int i = 0; i < 4; ++i) CHECK(mapped[i] == 0xABCD1234u);

    CHECK_THROWS_AS(vk::upload(context, small, words.data(), 4, small.size()), std::out_of_range);
  }
  CHECK(vk::validation_message_count() == messages);
}

TEST_CASE("vk: a marker lets the host read a counter before the sequence ends" * doctest::skip(test::skip_gpu_tests())) {
  const uint32_t index = test::gpu_test_device();
  const uint64_t messages = vk::validation_message_count();
  {
    vk::Context context(index);
    vk::ComputePipeline pipeline(context, vk::self_test_spirv(), "selftest", sizeof(vk::SelfTestPush), 64);
    vk::Buffer counters(context, 2 * 8, vk::MemoryUse::device, "counters");
    vk::Buffer inputs(context, 1000 * 8, vk::MemoryUse::device, "inputs");
    vk::Buffer spin(context, 256 * 8, vk::MemoryUse::device, "spin results");
    vk::Buffer readback(context, 2 * 8, vk::MemoryUse::readback, "readback");
    std::vector<int64_t> values(1000, int64_t(1) << 33);
    vk::upload(context, inputs, std::span<const int64_t>(values));

    vk::SelfTestPush push;
    push.inputs = inputs.address();
    push.counters = counters.address();
    push.results = spin.address();
    push.count = 1000;
    push.counter_count = 1;
    vk::Sequence sequence(context);
    sequence.fill(counters, 0).barrier();
    push.mode = vk::self_test_accumulate;
    sequence.dispatch_1d(pipeline, 1000, push).barrier().copy(counters, readback, 16);
    const uint32_t marker = sequence.marker();
    push.mode = vk::self_test_spin;  // later work the host need not wait for
    push.count = 256;
    push.spin = 20000;
    sequence.dispatch_1d(pipeline, 256, push);
    CHECK_FALSE(sequence.reached(marker));  // recorded, not submitted
    sequence.submit();
    // Poll (bounded by the context's timeout in spirit; the work is tiny).
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (!sequence.reached(marker) && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::microseconds(100));
    REQUIRE(sequence.reached(marker));
    const int64_t* counted = readback.mapped_as<const int64_t>();
    CHECK(counted[0] == 1000 * (int64_t(1) << 33));
    CHECK(counted[1] == 1000);
    sequence.wait();
    CHECK(sequence.done());
    CHECK(sequence.reached(marker));
  }
  CHECK(vk::validation_message_count() == messages);
}

TEST_CASE("vk: timestamps measure the work between them" * doctest::skip(test::skip_gpu_tests())) {
  const uint32_t index = test::gpu_test_device();
  const uint64_t messages = vk::validation_message_count();
  {
    vk::Context context(index);
    vk::ComputePipeline pipeline(context, vk::self_test_spirv(), "selftest", sizeof(vk::SelfTestPush), 64);
    vk::Buffer spin(context, 256 * 8, vk::MemoryUse::device, "spin results");
    const vk::SelfTestPush push = spin_push(spin, 256, 2000);
    vk::Sequence sequence(context);
    for (int round = 0; round < 2; ++round) {  // the second recording reuses the query pool
      const uint32_t a = sequence.timestamp();
      sequence.dispatch_1d(pipeline, 256, push).barrier();
      const uint32_t b = sequence.timestamp();
      sequence.dispatch_1d(pipeline, 256, push).barrier();
      const uint32_t c = sequence.timestamp();
      CHECK(b == a + 1);
      CHECK(c == b + 1);
      CHECK_THROWS_AS((void)sequence.timestamp_seconds(a, c), std::out_of_range);  // not yet submitted
      sequence.run();
      const double ab = sequence.timestamp_seconds(a, b), bc = sequence.timestamp_seconds(b, c);
      CHECK(sequence.timestamp_seconds(a, a) == 0.0);
      CHECK(ab > 0.0);  // a dispatch of busy work lies between them
      CHECK(bc > 0.0);
      CHECK(ab < 60.0);
      CHECK(sequence.timestamp_seconds(a, c) == doctest::Approx(ab + bc).epsilon(1e-9));
      CHECK_THROWS_AS((void)sequence.timestamp_seconds(a, c + 1), std::out_of_range);
    }
  }
  CHECK(vk::validation_message_count() == messages);
}

TEST_CASE("vk: a wait that times out fails the context instead of hanging" * doctest::skip(test::skip_gpu_tests())) {
  const uint32_t index = test::gpu_test_device();
  const uint64_t messages = vk::validation_message_count();
  {
    vk::ContextOptions options;
    options.timeout_seconds = 1e-6;  // 1 us: far less than the work below takes on any device
    vk::Context context(index, options);
    vk::ComputePipeline pipeline(context, vk::self_test_spirv(), "selftest", sizeof(vk::SelfTestPush), 64);
    vk::Buffer results(context, 1024 * 8, vk::MemoryUse::device, "spin results");
    const vk::SelfTestPush push = spin_push(results, 1024, 100000);
    {
      vk::Sequence sequence(context);
      sequence.dispatch_1d(pipeline, 1024, push);
      sequence.submit();
      CHECK_THROWS_AS(sequence.wait(), DeviceError);
      CHECK(context.failed());
      CHECK(error_text([&] { sequence.wait(); }).find("did not finish within") != std::string::npos);
      // The sequence's destructor waits a short grace for the running work before releasing it.
    }
    CHECK_THROWS_AS(vk::Buffer(context, 64, vk::MemoryUse::device, "after failure"), DeviceError);
    CHECK(error_text([&] { vk::Sequence s(context); }).find("unusable after an earlier error") != std::string::npos);
  }
  CHECK(vk::validation_message_count() == messages);
}

TEST_CASE("vk: pipeline limits are checked before the driver sees them" * doctest::skip(test::skip_gpu_tests())) {
  const uint32_t index = test::gpu_test_device();
  vk::Context context(index);
  const uint32_t too_many = context.limits().maxPushConstantsSize + 4;
  CHECK_THROWS_AS(vk::ComputePipeline(context, vk::self_test_spirv(), "selftest", too_many, 64), DeviceError);
  CHECK_THROWS_AS(vk::ComputePipeline(context, vk::self_test_spirv(), "selftest", 56, 0), DeviceError);
  CHECK_THROWS_AS(vk::ComputePipeline(context, vk::self_test_spirv(), "selftest", 56,
                                      context.limits().maxComputeWorkGroupInvocations + 1),
                  DeviceError);
  vk::ComputePipeline pipeline(context, vk::self_test_spirv(), "selftest", sizeof(vk::SelfTestPush), 64);
  vk::Sequence sequence(context);
  const uint32_t wrong_size = 8;
  CHECK_THROWS_AS(sequence.dispatch(pipeline, 1, wrong_size), std::logic_error);
  CHECK_THROWS_AS(sequence.dispatch(pipeline, context.limits().maxComputeWorkGroupCount[0] + 1u, 1, 1, nullptr, 56),
                  DeviceError);
}

TEST_CASE("vk: validation asked for without the layer installed is an error" * doctest::skip(test::skip_gpu_tests())) {
  test::gpu_test_device();
  // The loader looks for explicit layers only in VK_LAYER_PATH when it is set.
  ScopedEnv no_layers("VK_LAYER_PATH", "/nonexistent-meshcvt-layer-path");
  ScopedEnv no_extra("VK_ADD_LAYER_PATH", nullptr);
  CHECK_THROWS_AS(vk::Instance(true), DeviceError);
  const std::string message = error_text([] { vk::Instance instance(true); });
  CHECK(message.find("VK_LAYER_KHRONOS_validation") != std::string::npos);
  CHECK(message.find("vulkan-validationlayers") != std::string::npos);
  CHECK_NOTHROW(vk::Instance(false));
}

TEST_CASE("vk: the validation messenger counts misuse" * doctest::skip(test::skip_gpu_tests())) {
  const uint32_t index = test::gpu_test_device();
  vk::ContextOptions options;
  options.validation = true;  // whatever MESHCVT_VALIDATION says: this test is about the messenger
  vk::Context context(index, options);
  REQUIRE(context.validation());
  vk::Buffer source(context, 64, vk::MemoryUse::device, "source");
  vk::Buffer target(context, 64, vk::MemoryUse::readback, "target");
  vk::Sequence sequence(context);
  const uint64_t before = vk::validation_message_count();
  {
    vk::ValidationMessagesMuted muted;
    // A fill then a copy of the same bytes without barrier(): synchronization validation reports a
    // read-after-write hazard. (Shader accesses through device addresses are invisible to it, so
    // barriers between dispatches are checked by results, not by the layer.)
    sequence.fill(source, 1).copy(source, target, 64).run();
  }
  CHECK(vk::validation_message_count() > before);
  const uint64_t after = vk::validation_message_count();
  sequence.fill(source, 2).barrier().copy(source, target, 64).run();  // the same, done right
  CHECK(vk::validation_message_count() == after);
  CHECK(target.mapped_as<uint32_t>()[0] == 2u);
}

TEST_CASE("vk: Context checks the device index and the timeout setting" * doctest::skip(test::skip_gpu_tests())) {
  const uint32_t index = test::gpu_test_device();
  const std::string missing = error_text([] { vk::Context context(9999); });
  CHECK(missing.find("gpu:9999") != std::string::npos);
  CHECK(missing.find("no such Vulkan device") != std::string::npos);
  {
    ScopedEnv bad("MESHCVT_GPU_TIMEOUT", "soon");
    CHECK_THROWS_AS(vk::Context{index}, OptionError);
    CHECK(error_text([&] { vk::Context context(index); }).find("MESHCVT_GPU_TIMEOUT=soon") != std::string::npos);
  }
  {
    ScopedEnv negative("MESHCVT_GPU_TIMEOUT", "-1");
    CHECK_THROWS_AS(vk::Context{index}, OptionError);
  }
  {
    ScopedEnv half("MESHCVT_GPU_TIMEOUT", "0.5");
    vk::Context context(index);
    CHECK(context.timeout_ns() == 500'000'000u);
  }
  ScopedEnv unset("MESHCVT_GPU_TIMEOUT", nullptr);
  vk::Context context(index);
  CHECK(context.timeout_ns() == 60'000'000'000u);  // the default
}
