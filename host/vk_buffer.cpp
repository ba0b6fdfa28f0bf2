// meshcvt Vulkan host layer: buffer allocation (budget-checked, device-addressable) and host
// upload/download, directly through a mapping where the memory allows it, else through staging.
#include "vk_buffer.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <utility>

#include "meshcvt/error.h"
#include "vk_errors.h"
#include "vk_sequence.h"

namespace meshcvt::vk {

namespace {

// Every buffer can be a storage buffer, a copy end and a device address: one kind of buffer keeps
// the driver code simple, and none of these flags costs anything on the drivers we know.
constexpr VkBufferUsageFlags kUsage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT |
                                      VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                                      VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT;

// Staging chunks: big enough to amortize a submission, small enough to fit next to the data.
constexpr uint64_t kStagingChunk = 64ull << 20;

}  // namespace

Buffer::Buffer(Context& context, uint64_t bytes, MemoryUse use, std::string name)
    : context_(&context), name_(std::move(name)) {
  context.ensure_usable();
  // fillBuffer and copies want multiples of 4; a zero-sized buffer is not allowed in Vulkan.
  size_ = std::max<uint64_t>(4, bytes > UINT64_MAX - 3 ? bytes : (bytes + 3) & ~uint64_t(3));
  const auto& vk = context.vk();
  const VkDevice device = context.device();

  // Before vkCreateBuffer: an absurd size must fail with the sizes, not with a driver error (or a
  // validation message about maxBufferSize).
  const uint32_t likely_type = context.memory_type(~0u, use);
  context.check_allocation(size_, context.memory_properties().memoryTypes[likely_type].heapIndex, name_);

  VkBufferCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
  info.size = size_;
  info.usage = kUsage;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  check(vk.vkCreateBuffer(device, &info, nullptr, &buffer_), "vkCreateBuffer");

  try {
    VkMemoryRequirements requirements{};
    vk.vkGetBufferMemoryRequirements(device, buffer_, &requirements);
    const uint32_t type = context.memory_type(requirements.memoryTypeBits, use);
    const VkMemoryType& memory_type = context.memory_properties().memoryTypes[type];
    heap_ = memory_type.heapIndex;
    context.check_allocation(requirements.size, heap_, name_);

    VkMemoryAllocateFlagsInfo flags{};
    flags.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_FLAGS_INFO;
    flags.flags = VK_MEMORY_ALLOCATE_DEVICE_ADDRESS_BIT;
    VkMemoryAllocateInfo allocate{};
    allocate.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    allocate.pNext = &flags;
    allocate.allocationSize = requirements.size;
    allocate.memoryTypeIndex = type;
    VkResult result = context.fault_due(Context::Fault::out_of_memory)
                          ? VK_ERROR_OUT_OF_DEVICE_MEMORY
                          : vk.vkAllocateMemory(device, &allocate, nullptr, &memory_);
    if (result != VK_SUCCESS) {
      memory_ = VK_NULL_HANDLE;
      throw_result(result, ("vkAllocateMemory (" + mib(requirements.size) + " for " + name_ + ")").c_str());
    }
    allocation_size_ = requirements.size;
    context.note_allocated(heap_, allocation_size_);
    check(vk.vkBindBufferMemory(device, buffer_, memory_, 0), "vkBindBufferMemory");

    const VkMemoryPropertyFlags host = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    if ((memory_type.propertyFlags & host) == host)
      check(vk.vkMapMemory(device, memory_, 0, VK_WHOLE_SIZE, 0, &mapped_), "vkMapMemory");

    VkBufferDeviceAddressInfo address{};
    address.sType = VK_STRUCTURE_TYPE_BUFFER_DEVICE_ADDRESS_INFO;
    address.buffer = buffer_;
    address_ = vk.vkGetBufferDeviceAddress(device, &address);
  } catch (...) {
    if (memory_) {
      vk.vkFreeMemory(device, memory_, nullptr);
      context.note_freed(heap_, allocation_size_);
    }
    vk.vkDestroyBuffer(device, buffer_, nullptr);
    throw;
  }
}

Buffer::~Buffer() {
  if (!context_ || !buffer_) return;
  if (context_->work_pending()) return;  // the GPU may still use it after a timeout: leak, see Context
  const auto& vk = context_->vk();
  if (mapped_) vk.vkUnmapMemory(context_->device(), memory_);
  vk.vkDestroyBuffer(context_->device(), buffer_, nullptr);
  vk.vkFreeMemory(context_->device(), memory_, nullptr);
  context_->note_freed(heap_, allocation_size_);
}

void Buffer::swap(Buffer& other) noexcept {
  std::swap(context_, other.context_);
  std::swap(buffer_, other.buffer_);
  std::swap(memory_, other.memory_);
  std::swap(size_, other.size_);
  std::swap(allocation_size_, other.allocation_size_);
  std::swap(heap_, other.heap_);
  std::swap(mapped_, other.mapped_);
  std::swap(address_, other.address_);
  std::swap(name_, other.name_);
}

static void check_range(const Buffer& buffer, uint64_t bytes, uint64_t offset, const char* what) {
  if (offset > buffer.size() || bytes > buffer.size() - offset)
    throw std::out_of_range(std::string(what) + " of " + std::to_string(bytes) + " bytes at offset " +
                            std::to_string(offset) + " exceeds buffer " + buffer.name() + " (" +
                            std::to_string(buffer.size()) + " bytes)");
}

void upload(Context& context, Buffer& destination, const void* source, uint64_t bytes, uint64_t offset) {
  check_range(destination, bytes, offset, "upload");
  context.ensure_usable();
  if (bytes == 0) return;
  if (destination.mapped())
    std::memcpy(destination.mapped_as<char>() + offset, source, bytes);
  else
    upload_staged(context, destination, source, bytes, offset, kStagingChunk);
}

void download(Context& context, const Buffer& source, void* destination, uint64_t bytes, uint64_t offset) {
  check_range(source, bytes, offset, "download");
  context.ensure_usable();
  if (bytes == 0) return;
  if (source.mapped())
    std::memcpy(destination, source.mapped_as<const char>() + offset, bytes);
  else
    download_staged(context, source, destination, bytes, offset, kStagingChunk);
}

void upload_staged(Context& context, Buffer& destination, const void* source, uint64_t bytes, uint64_t offset,
                   uint64_t chunk) {
  check_range(destination, bytes, offset, "upload");
  if (bytes == 0) return;
  Buffer staging(context, std::min(bytes, std::max<uint64_t>(chunk, 4)), MemoryUse::staging,
                 "staging for " + destination.name());
  Sequence sequence(context);
  for (uint64_t done = 0; done < bytes;) {
    const uint64_t n = std::min(bytes - done, staging.size());
    std::memcpy(staging.mapped(), static_cast<const char*>(source) + done, n);
    sequence.copy(staging, destination, n, 0, offset + done).run();
    done += n;
  }
}

void download_staged(Context& context, const Buffer& source, void* destination, uint64_t bytes, uint64_t offset,
                     uint64_t chunk) {
  check_range(source, bytes, offset, "download");
  if (bytes == 0) return;
  Buffer staging(context, std::min(bytes, std::max<uint64_t>(chunk, 4)), MemoryUse::staging,
                 "staging for " + source.name());
  Sequence sequence(context);
  for (uint64_t done = 0; done < bytes;) {
    const uint64_t n = std::min(bytes - done, staging.size());
    sequence.copy(source, staging, n, offset + done, 0).run();
    std::memcpy(static_cast<char*>(destination) + done, staging.mapped(), n);
    done += n;
  }
}

}  // namespace meshcvt::vk
