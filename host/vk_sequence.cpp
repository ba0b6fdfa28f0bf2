// meshcvt Vulkan host layer: command recording, submission, and fence waits with a timeout, so a
// hung or lost device ends the run with an error instead of hanging it.
#include "vk_sequence.h"

#include <algorithm>
#include <cstdio>
#include <stdexcept>

#include "meshcvt/error.h"
#include "vk_errors.h"

namespace meshcvt::vk {

namespace {

constexpr VkPipelineStageFlags kWorkStages = VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT;
constexpr VkAccessFlags kWrites = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;
constexpr VkAccessFlags kReadsAndWrites =
    VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;

// After a failure the destructor waits this long at most for work still running, then leaks it.
constexpr uint64_t kGraceNs = 2'000'000'000;

// Timestamps one recording may hold.
constexpr uint32_t kMaxTimestamps = 256;

void memory_barrier(const VolkDeviceTable& vk, VkCommandBuffer commands, VkPipelineStageFlags dst_stages,
                    VkAccessFlags dst_access) {
  VkMemoryBarrier barrier{};
  barrier.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
  barrier.srcAccessMask = kWrites;
  barrier.dstAccessMask = dst_access;
  vk.vkCmdPipelineBarrier(commands, kWorkStages, dst_stages, 0, 1, &barrier, 0, nullptr, 0, nullptr);
}

std::string seconds_text(uint64_t ns) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%g s", static_cast<double>(ns) * 1e-9);
  return buffer;
}

}  // namespace

Sequence::Sequence(Context& context) : context_(context) {
  context.ensure_usable();
  const auto& vk = context.vk();
  const VkDevice device = context.device();
  VkCommandPoolCreateInfo pool_info{};
  pool_info.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
  pool_info.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pool_info.queueFamilyIndex = context.queue_family();
  check(vk.vkCreateCommandPool(device, &pool_info, nullptr, &pool_), "vkCreateCommandPool");

  VkCommandBufferAllocateInfo allocate{};
  allocate.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
  allocate.commandPool = pool_;
  allocate.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  allocate.commandBufferCount = 1;
  VkResult result = vk.vkAllocateCommandBuffers(device, &allocate, &commands_);
  if (result == VK_SUCCESS) {
    VkFenceCreateInfo fence_info{};
    fence_info.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
    result = vk.vkCreateFence(device, &fence_info, nullptr, &fence_);
  }
  if (result != VK_SUCCESS) {
    vk.vkDestroyCommandPool(device, pool_, nullptr);  // frees the command buffer too
    throw_result(result, fence_ ? "vkCreateFence" : "vkAllocateCommandBuffers");
  }
}

Sequence::~Sequence() {
  const auto& vk = context_.vk();
  const VkDevice device = context_.device();
  if (state_ == State::submitted) {
    // Normally reached when an exception left between submit() and wait(): the work is fine and
    // finishes. After a timeout it may never finish; then it is left running and leaked.
    const uint64_t limit = context_.failed() ? kGraceNs : context_.timeout_ns();
    VkResult result = vk.vkWaitForFences(device, 1, &fence_, VK_TRUE, limit);
    if (result == VK_TIMEOUT) {
      context_.fail("GPU work did not finish within " + seconds_text(limit));
      return;
    }
    context_.note_completed();  // finished, or the device is lost and it never will
  }
  for (VkEvent event : events_) vk.vkDestroyEvent(device, event, nullptr);
  if (timestamps_pool_) vk.vkDestroyQueryPool(device, timestamps_pool_, nullptr);
  vk.vkDestroyFence(device, fence_, nullptr);
  vk.vkDestroyCommandPool(device, pool_, nullptr);
}

void Sequence::begin() {
  context_.ensure_usable();
  if (state_ == State::submitted)
    throw std::logic_error("meshcvt::vk::Sequence: recording while submitted work is pending; call wait() first");
  if (state_ == State::recording) return;
  const auto& vk = context_.vk();
  // The previous submission has completed (wait() ran), so its markers can be reset from the host.
  for (uint32_t i = 0; i < markers_; ++i) check(vk.vkResetEvent(context_.device(), events_[i]), "vkResetEvent");
  markers_ = 0;
  timestamps_ = 0;
  timestamp_values_.clear();  // they belonged to the submission before this recording
  dispatches_ = 0;
  VkCommandBufferBeginInfo info{};
  info.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
  info.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  check(vk.vkBeginCommandBuffer(commands_, &info), "vkBeginCommandBuffer");
  state_ = State::recording;
}

Sequence& Sequence::dispatch(const ComputePipeline& pipeline, uint32_t groups_x, uint32_t groups_y,
                             uint32_t groups_z, const void* push, uint32_t push_bytes) {
  if (push_bytes != pipeline.push_constant_bytes())
    throw std::logic_error("meshcvt::vk::Sequence: shader " + pipeline.name() + " takes " +
                           std::to_string(pipeline.push_constant_bytes()) + " bytes of push constants, got " +
                           std::to_string(push_bytes));
  const uint32_t* max = context_.limits().maxComputeWorkGroupCount;
  if (groups_x > max[0] || groups_y > max[1] || groups_z > max[2])
    throw DeviceError("shader " + pipeline.name() + ": " + std::to_string(groups_x) + " x " + std::to_string(groups_y) +
                      " x " + std::to_string(groups_z) + " workgroups exceed the device's maxComputeWorkGroupCount " +
                      std::to_string(max[0]) + " x " + std::to_string(max[1]) + " x " + std::to_string(max[2]));
  begin();
  const auto& vk = context_.vk();
  vk.vkCmdBindPipeline(commands_, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline.handle());
  if (push_bytes > 0)
    vk.vkCmdPushConstants(commands_, pipeline.layout(), VK_SHADER_STAGE_COMPUTE_BIT, 0, push_bytes, push);
  vk.vkCmdDispatch(commands_, groups_x, groups_y, groups_z);
  ++dispatches_;
  return *this;
}

Sequence& Sequence::dispatch_1d(const ComputePipeline& pipeline, uint64_t invocations, const void* push,
                                uint32_t push_bytes) {
  if (invocations == 0) return *this;
  const uint64_t groups = (invocations + pipeline.local_size_x() - 1) / pipeline.local_size_x();
  const uint64_t max_x = context_.limits().maxComputeWorkGroupCount[0];
  // Balanced over y so that the last row wastes little: y rows of x groups, x * y >= groups.
  const uint64_t y = (groups + max_x - 1) / max_x;
  const uint64_t x = (groups + y - 1) / y;
  if (y > UINT32_MAX) throw DeviceError("shader " + pipeline.name() + ": too many invocations for one dispatch");
  return dispatch(pipeline, static_cast<uint32_t>(x), static_cast<uint32_t>(y), 1, push, push_bytes);
}

Sequence& Sequence::barrier() {
  begin();
  memory_barrier(context_.vk(), commands_, kWorkStages, kReadsAndWrites);
  return *this;
}

Sequence& Sequence::copy(const Buffer& source, Buffer& destination, uint64_t bytes, uint64_t source_offset,
                         uint64_t destination_offset) {
  if (source_offset > source.size() || bytes > source.size() - source_offset ||
      destination_offset > destination.size() || bytes > destination.size() - destination_offset)
    throw std::out_of_range("meshcvt::vk::Sequence: copy of " + std::to_string(bytes) + " bytes from " +
                            source.name() + " to " + destination.name() + " is out of range");
  begin();
  if (bytes == 0) return *this;
  VkBufferCopy region{source_offset, destination_offset, bytes};
  context_.vk().vkCmdCopyBuffer(commands_, source.handle(), destination.handle(), 1, &region);
  return *this;
}

Sequence& Sequence::copy_regions(const Buffer& source, Buffer& destination, const std::vector<VkBufferCopy>& regions) {
  for (const VkBufferCopy& r : regions)
    if (r.srcOffset > source.size() || r.size > source.size() - r.srcOffset || r.dstOffset > destination.size() ||
        r.size > destination.size() - r.dstOffset || r.size == 0)
      throw std::out_of_range("meshcvt::vk::Sequence: a copy region of " + std::to_string(r.size) + " bytes from " +
                              source.name() + " to " + destination.name() + " is out of range or empty");
  begin();
  if (regions.empty()) return *this;
  context_.vk().vkCmdCopyBuffer(commands_, source.handle(), destination.handle(), uint32_t(regions.size()),
                                regions.data());
  return *this;
}

Sequence& Sequence::fill(Buffer& destination, uint32_t value, uint64_t offset, uint64_t bytes) {
  if (bytes == UINT64_MAX) bytes = offset < destination.size() ? destination.size() - offset : 0;
  if (offset % 4 || bytes % 4 || offset > destination.size() || bytes > destination.size() - offset)
    throw std::out_of_range("meshcvt::vk::Sequence: fill of " + std::to_string(bytes) + " bytes at " +
                            std::to_string(offset) + " in " + destination.name() + " is out of range or unaligned");
  begin();
  if (bytes == 0) return *this;
  context_.vk().vkCmdFillBuffer(commands_, destination.handle(), offset, bytes, value);
  return *this;
}

uint32_t Sequence::marker() {
  begin();
  const auto& vk = context_.vk();
  if (markers_ == events_.size()) {
    VkEventCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_EVENT_CREATE_INFO;
    VkEvent event = VK_NULL_HANDLE;
    check(vk.vkCreateEvent(context_.device(), &info, nullptr, &event), "vkCreateEvent");
    events_.push_back(event);
  }
  // The barrier's second scope includes the compute/transfer stages the event waits for, so the
  // writes before it are available to the host by the time the host sees the event set.
  memory_barrier(vk, commands_, kWorkStages | VK_PIPELINE_STAGE_HOST_BIT, kReadsAndWrites | VK_ACCESS_HOST_READ_BIT);
  vk.vkCmdSetEvent(commands_, events_[markers_], kWorkStages);
  return markers_++;
}

bool Sequence::reached(uint32_t marker) const {
  if (marker >= markers_) throw std::out_of_range("meshcvt::vk::Sequence: no marker " + std::to_string(marker));
  if (state_ != State::submitted) return state_ == State::idle;  // idle: waited, so every marker was passed
  VkResult result = context_.vk().vkGetEventStatus(context_.device(), events_[marker]);
  if (result == VK_EVENT_SET) return true;
  if (result == VK_EVENT_RESET) return false;
  context_.fail("vkGetEventStatus failed: " + result_name(result));
  throw_result(result, "vkGetEventStatus");
}

uint32_t Sequence::timestamp() {
  begin();
  const auto& vk = context_.vk();
  if (!timestamps_pool_) {
    if (context_.timestamp_valid_bits() == 0)
      throw DeviceError(context_.info().name + ": its compute queue has no timestamps (timestampValidBits 0)");
    VkQueryPoolCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO;
    info.queryType = VK_QUERY_TYPE_TIMESTAMP;
    info.queryCount = kMaxTimestamps;
    check(vk.vkCreateQueryPool(context_.device(), &info, nullptr, &timestamps_pool_), "vkCreateQueryPool");
  }
  if (timestamps_ == kMaxTimestamps)
    throw std::out_of_range("meshcvt::vk::Sequence: more than " + std::to_string(kMaxTimestamps) +
                            " timestamps in one recording");
  // Queries must be reset before they are written; each is reset in the recording that writes it.
  vk.vkCmdResetQueryPool(commands_, timestamps_pool_, timestamps_, 1);
  vk.vkCmdWriteTimestamp(commands_, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, timestamps_pool_, timestamps_);
  return timestamps_++;
}

double Sequence::timestamp_seconds(uint32_t from, uint32_t to) const {
  if (from >= timestamp_values_.size() || to >= timestamp_values_.size())
    throw std::out_of_range("meshcvt::vk::Sequence: no such timestamp in the last submission");
  const uint32_t bits = context_.timestamp_valid_bits();
  const uint64_t mask = bits >= 64 ? UINT64_MAX : (uint64_t(1) << bits) - 1;
  const uint64_t ticks = (timestamp_values_[to] - timestamp_values_[from]) & mask;
  return double(ticks) * double(context_.limits().timestampPeriod) * 1e-9;
}

void Sequence::submit() {
  begin();  // an empty sequence submits an empty command buffer, so wait() works the same
  const auto& vk = context_.vk();
  memory_barrier(vk, commands_, VK_PIPELINE_STAGE_HOST_BIT, VK_ACCESS_HOST_READ_BIT | VK_ACCESS_HOST_WRITE_BIT);
  VkResult result = vk.vkEndCommandBuffer(commands_);
  if (result == VK_SUCCESS) {
    VkSubmitInfo info{};
    info.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    info.commandBufferCount = 1;
    info.pCommandBuffers = &commands_;
    result = vk.vkQueueSubmit(context_.queue(), 1, &info, fence_);
    if (result != VK_SUCCESS) {
      context_.fail("vkQueueSubmit failed: " + result_name(result));
      throw_result(result, "vkQueueSubmit");
    }
  } else {
    context_.fail("vkEndCommandBuffer failed: " + result_name(result));
    throw_result(result, "vkEndCommandBuffer");
  }
  state_ = State::submitted;
  context_.note_submitted();
}

bool Sequence::done() {
  if (state_ != State::submitted) return true;
  VkResult result = context_.vk().vkGetFenceStatus(context_.device(), fence_);
  if (result == VK_SUCCESS) return true;
  if (result == VK_NOT_READY) return false;
  wait();  // reports the device loss (or other failure) the same way a wait does
  return true;
}

void Sequence::wait() {
  if (state_ != State::submitted) return;
  const auto& vk = context_.vk();
  VkResult result = vk.vkWaitForFences(context_.device(), 1, &fence_, VK_TRUE, context_.timeout_ns());
  // (An armed fault takes the place of a completed wait's result: the work is done, as after a
  // real loss nothing runs any more.)
  if (result == VK_SUCCESS && context_.fault_due(Context::Fault::device_lost)) result = VK_ERROR_DEVICE_LOST;
  if (result == VK_TIMEOUT) {
    const std::string what = "GPU work did not finish within " + seconds_text(context_.timeout_ns());
    context_.fail(what);
    throw DeviceError(what + " (vkWaitForFences timed out: the device may be hung or too slow for this job)",
                      "raise MESHCVT_GPU_TIMEOUT or use --device cpu");
  }
  // Finished, or failed for good (device lost): either way it no longer runs.
  state_ = State::idle;
  context_.note_completed();
  if (result != VK_SUCCESS) {
    context_.fail("vkWaitForFences failed: " + result_name(result));
    throw_result(result, "vkWaitForFences");
  }
  result = vk.vkResetFences(context_.device(), 1, &fence_);
  if (result != VK_SUCCESS) {
    context_.fail("vkResetFences failed: " + result_name(result));
    throw_result(result, "vkResetFences");
  }
  timestamp_values_.assign(timestamps_, 0);
  if (timestamps_)
    check(vk.vkGetQueryPoolResults(context_.device(), timestamps_pool_, 0, timestamps_,
                                   timestamp_values_.size() * sizeof(uint64_t), timestamp_values_.data(),
                                   sizeof(uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
          "vkGetQueryPoolResults");
}

}  // namespace meshcvt::vk
