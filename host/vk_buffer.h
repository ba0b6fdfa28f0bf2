// meshcvt Vulkan host layer: buffers. One VkBuffer with its own VkDeviceMemory, usable as a
// storage buffer, copy source/destination, and through its buffer device address, which is how
// shaders reach it (GL_EXT_buffer_reference): no descriptor binding, so no array is limited by
// maxStorageBufferRange (128 MiB on lavapipe). Every allocation is checked against the memory
// budget first, so a mesh too big for the device fails with sizes in the message.
#pragma once

#include <volk.h>

#include <cstdint>
#include <span>
#include <string>

#include "vk_context.h"

namespace meshcvt::vk {

class Buffer {
 public:
  Buffer() = default;
  /// `bytes` (rounded up to a multiple of 4, at least 4) of memory `use` on `context`; `name` is
  /// used in error messages ("face labels"). Contents are undefined. Throws DeviceError when it does
  /// not fit (see Context::check_allocation) or the allocation fails.
  Buffer(Context& context, uint64_t bytes, MemoryUse use, std::string name);
  ~Buffer();
  Buffer(Buffer&& other) noexcept { swap(other); }
  Buffer& operator=(Buffer&& other) noexcept {
    Buffer(std::move(other)).swap(*this);
    return *this;
  }
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;

  VkBuffer handle() const { return buffer_; }
  uint64_t size() const { return size_; }  ///< bytes (as rounded)
  /// The buffer's device address, for push constants or pointer tables.
  VkDeviceAddress address() const { return address_; }
  /// Host pointer to the whole buffer while it lives: always for staging and readback memory,
  /// also for device memory that is host-visible and coherent (integrated GPUs, lavapipe); else null.
  void* mapped() const { return mapped_; }
  template <typename T>
  T* mapped_as() const { return static_cast<T*>(mapped_); }
  const std::string& name() const { return name_; }

  void swap(Buffer& other) noexcept;

 private:
  Context* context_ = nullptr;
  VkBuffer buffer_ = VK_NULL_HANDLE;
  VkDeviceMemory memory_ = VK_NULL_HANDLE;
  uint64_t size_ = 0;
  uint64_t allocation_size_ = 0;
  uint32_t heap_ = 0;
  void* mapped_ = nullptr;
  VkDeviceAddress address_ = 0;
  std::string name_;
};

/// Copies `bytes` from host memory `source` into `destination` at byte `offset` and returns when it is
/// there: a plain memcpy when the buffer is mapped, else through a staging buffer (64 MiB at most)
/// and copy commands. No GPU work may use `destination` meanwhile.
void upload(Context& context, Buffer& destination, const void* source, uint64_t bytes, uint64_t offset = 0);

/// Copies `bytes` of `source` from byte `offset` into host memory `destination` (the reverse of upload).
/// No GPU work may write `source` meanwhile.
void download(Context& context, const Buffer& source, void* destination, uint64_t bytes, uint64_t offset = 0);

/// The staging paths of upload/download, also for mapped buffers (tests use them to cover the path
/// that devices with host-visible memory never take). `chunk`: staging buffer size in bytes.
void upload_staged(Context& context, Buffer& destination, const void* source, uint64_t bytes, uint64_t offset,
                   uint64_t chunk = 64ull << 20);
void download_staged(Context& context, const Buffer& source, void* destination, uint64_t bytes, uint64_t offset,
                     uint64_t chunk = 64ull << 20);

/// Typed forms: the whole span, at element offset 0.
template <typename T>
void upload(Context& context, Buffer& destination, std::span<const T> source) {
  upload(context, destination, source.data(), source.size_bytes());
}
template <typename T>
void download(Context& context, const Buffer& source, std::span<T> destination) {
  download(context, source, destination.data(), destination.size_bytes());
}

}  // namespace meshcvt::vk
