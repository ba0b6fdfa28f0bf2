// meshcvt Vulkan host layer: Sequence = one command buffer of dispatches, copies and barriers,
// submitted once and waited for with a fence and a timeout.
//
// Use: record (dispatch/barrier/copy/fill/marker), submit(), then wait() (or run() for both); after
// the wait the sequence is empty and can be recorded again. Every submission ends with a barrier
// that makes shader and copy writes visible to the host, so mapped buffers can be read after wait().
// Dispatches recorded one after the other are NOT ordered: put barrier() between a dispatch that
// writes and one that reads (validation with MESHCVT_VALIDATION=1 checks this).
#pragma once

#include <volk.h>

#include <cstdint>
#include <vector>

#include "vk_buffer.h"
#include "vk_context.h"
#include "vk_pipeline.h"

namespace meshcvt::vk {

class Sequence {
 public:
  explicit Sequence(Context& context);
  /// Waits for submitted work (up to the context's timeout; a short grace after a failure) and
  /// leaks rather than destroys what the GPU may still use.
  ~Sequence();
  Sequence(const Sequence&) = delete;
  Sequence& operator=(const Sequence&) = delete;

  /// Dispatches groups_x * groups_y * groups_z workgroups of `pipeline`, with `push_bytes` bytes of
  /// push constants (must equal pipeline.push_constant_bytes()). Throws DeviceError when a count
  /// is beyond maxComputeWorkGroupCount.
  Sequence& dispatch(const ComputePipeline& pipeline, uint32_t groups_x, uint32_t groups_y, uint32_t groups_z,
                     const void* push, uint32_t push_bytes);
  template <typename Push>
  Sequence& dispatch(const ComputePipeline& pipeline, uint32_t groups_x, const Push& push) {
    return dispatch(pipeline, groups_x, 1, 1, &push, sizeof(Push));
  }

  /// Enough workgroups of pipeline.local_size_x() for `invocations` invocations (0: records nothing),
  /// spread over y when x would exceed maxComputeWorkGroupCount.x. The shader computes its index as
  ///   (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * gl_WorkGroupSize.x + gl_LocalInvocationID.x
  /// and must return when it is >= the count (the last groups run past it).
  Sequence& dispatch_1d(const ComputePipeline& pipeline, uint64_t invocations, const void* push, uint32_t push_bytes);
  template <typename Push>
  Sequence& dispatch_1d(const ComputePipeline& pipeline, uint64_t invocations, const Push& push) {
    return dispatch_1d(pipeline, invocations, &push, sizeof(Push));
  }

  /// Orders everything recorded before against everything after (compute and copies, all memory).
  Sequence& barrier();
  /// Copies `bytes` from `source` at source_offset to `destination` at destination_offset.
  Sequence& copy(const Buffer& source, Buffer& destination, uint64_t bytes, uint64_t source_offset = 0,
                 uint64_t destination_offset = 0);
  /// Copies each region (srcOffset, dstOffset, size in bytes) from `source` to `destination` in
  /// one command: many small scattered pieces at the cost of one copy.
  Sequence& copy_regions(const Buffer& source, Buffer& destination, const std::vector<VkBufferCopy>& regions);
  /// Fills `bytes` (multiple of 4; UINT64_MAX: to the end) of `destination` from `offset` with the
  /// 32-bit `value`.
  Sequence& fill(Buffer& destination, uint32_t value, uint64_t offset = 0, uint64_t bytes = UINT64_MAX);

  /// Makes all writes recorded so far visible to the host, then sets a marker the host can poll with
  /// reached(): once reached, mapped readback buffers hold what was written before the marker, while
  /// the rest of the sequence still runs (e.g. a move counter read early). Returns the marker's id.
  uint32_t marker();
  /// Whether the GPU has passed `marker` of the current submission (non-blocking).
  bool reached(uint32_t marker) const;

  /// Records a GPU timestamp once everything recorded before it has finished (put it after a
  /// barrier() to time the dispatches between two of them). Returns its id in this recording; read
  /// it with timestamp_seconds() after wait(). Throws DeviceError when the queue has no timestamps
  /// (timestampValidBits 0). For benchmarks: the GPU time of a kernel, without the submission.
  uint32_t timestamp();
  /// Seconds between timestamps `from` and `to` of the last completed submission (device clock,
  /// scaled by timestampPeriod), until the next recording begins. Throws std::out_of_range for a
  /// timestamp that submission did not write.
  double timestamp_seconds(uint32_t from, uint32_t to) const;

  /// Ends recording and submits to the queue. Throws DeviceError on failure (the context is then failed).
  void submit();
  /// Non-blocking: whether the submitted work has finished. Throws DeviceError when the device is lost.
  bool done();
  /// Waits for the submitted work, at most the context's timeout. Throws DeviceError when the wait
  /// times out or the device is lost; the context is then failed. Returns at once if nothing was submitted.
  void wait();
  /// submit() then wait().
  void run() {
    submit();
    wait();
  }

  uint32_t dispatch_count() const { return dispatches_; }  ///< in the current recording

 private:
  enum class State { idle, recording, submitted };
  void begin();
  bool wait_for(uint64_t timeout_ns);  // true when the fence signaled (or the device is lost)

  Context& context_;
  VkCommandPool pool_ = VK_NULL_HANDLE;
  VkCommandBuffer commands_ = VK_NULL_HANDLE;
  VkFence fence_ = VK_NULL_HANDLE;
  std::vector<VkEvent> events_;  // markers; events_[i] is marker i of the current recording
  uint32_t markers_ = 0;
  VkQueryPool timestamps_pool_ = VK_NULL_HANDLE;  // made at the first timestamp()
  uint32_t timestamps_ = 0;                       // written in the current recording
  std::vector<uint64_t> timestamp_values_;         // of the last completed submission
  uint32_t dispatches_ = 0;
  State state_ = State::idle;
};

}  // namespace meshcvt::vk
