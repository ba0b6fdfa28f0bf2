// meshcvt Vulkan host layer: the loader, the instance (with validation and its debug messenger),
// device description, and Context = one logical device with one compute queue.
//
// Everything here is internal (host/ is not installed): the public view is src/meshcvt/device.h.
// Device functions are called through a per-device volk table (Context::vk()), not through volk's
// global pointers, so two contexts on different drivers never call into each other's driver.
// Instance-level pointers are volk's globals: they are the loader's trampolines, valid for any instance.
#pragma once

#include <volk.h>

#include <cassert>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "meshcvt/device.h"

namespace meshcvt::vk {

/// Opens the Vulkan loader once per process ($MESHCVT_VULKAN_LIBRARY, else libvulkan.so.1).
/// Throws DeviceError naming what to install when it cannot. Thread-safe.
void load_vulkan();
/// Whether load_vulkan() has succeeded in this process.
bool vulkan_loaded();

/// Validation-layer messages (warnings and errors) seen so far by any instance of this process.
/// GPU tests assert it stays 0 with MESHCVT_VALIDATION=1.
uint64_t validation_message_count();

/// True when $MESHCVT_VALIDATION is set to anything but "" or "0".
bool validation_requested();

/// While one lives, validation messages are counted but not printed: for tests that provoke a
/// message on purpose to prove the messenger works.
class ValidationMessagesMuted {
 public:
  ValidationMessagesMuted();
  ~ValidationMessagesMuted();
  ValidationMessagesMuted(const ValidationMessagesMuted&) = delete;
  ValidationMessagesMuted& operator=(const ValidationMessagesMuted&) = delete;
};

/// A VkInstance, plus the debug messenger when validation is on.
class Instance {
 public:
  /// validation: enable VK_LAYER_KHRONOS_validation (with synchronization validation) and a
  /// messenger that prints every warning/error to stderr and counts it. Throws DeviceError when
  /// there is no loader, no driver (VK_ERROR_INCOMPATIBLE_DRIVER, only if `allow_no_driver` is false),
  /// or validation is asked for but the layer is not installed.
  explicit Instance(bool validation, bool allow_no_driver = false);
  ~Instance();
  Instance(const Instance&) = delete;
  Instance& operator=(const Instance&) = delete;

  /// VK_NULL_HANDLE when allow_no_driver was given and the loader found no driver.
  VkInstance handle() const { return instance_; }
  bool validation() const { return messenger_ != VK_NULL_HANDLE; }
  /// The loader's devices, in its order (empty without a driver).
  std::vector<VkPhysicalDevice> physical_devices() const;

 private:
  VkInstance instance_ = VK_NULL_HANDLE;
  VkDebugUtilsMessengerEXT messenger_ = VK_NULL_HANDLE;
};

/// The process-wide instance with or without validation (allow_no_driver: an empty device list
/// when there is no driver), made on first use and never destroyed. Why: creating an instance loads
/// the drivers (lavapipe pulls in LLVM), and the loader unloads them again when it is destroyed,
/// after which leak checkers see the drivers' static allocations as leaks they cannot even name.
/// Throws as Instance() does; a failure is not cached.
Instance& shared_instance(bool validation);

/// What meshcvt needs of a device (see DeviceInfo::usable), and whether it has it.
DeviceInfo describe_device(VkPhysicalDevice physical, uint32_t index);

struct ContextOptions {
  /// Enable validation; unset: validation_requested().
  std::optional<bool> validation;
  /// Longest a wait for GPU work may take before the run fails, seconds (> 0);
  /// unset: $MESHCVT_GPU_TIMEOUT, else 60.
  std::optional<double> timeout_seconds;
};

/// Which memory a buffer lives in (see vk_buffer.h).
enum class MemoryUse {
  device,    ///< device-local; host-mapped only where the device's memory is host-visible anyway (UMA)
  staging,   ///< host-visible, for uploads/downloads through copies
  readback,  ///< host-visible and coherent, mapped for its whole life: small results, counters
};

/// One logical device with one compute queue. Not thread-safe: use a context from one thread.
/// Every object made from a context (Buffer, ComputePipeline, Sequence) must be destroyed first.
///
/// Faults: when a wait times out or the device is lost, the context is marked failed; every later
/// operation on it throws DeviceError and objects still in use by the GPU are leaked rather than
/// destroyed under it, so a fault ends the run with an error, never a hang or a crash.
class Context {
 public:
  /// Opens device `device_index` (DeviceInfo::index). Throws DeviceError when it is out of range,
  /// not usable (naming what it lacks), or device creation fails.
  explicit Context(uint32_t device_index, const ContextOptions& options = {});
  ~Context();
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;

  const VolkDeviceTable& vk() const { return table_; }
  VkDevice device() const { return device_; }
  VkPhysicalDevice physical() const { return physical_; }
  VkQueue queue() const { return queue_; }
  uint32_t queue_family() const { return queue_family_; }
  const DeviceInfo& info() const { return info_; }
  const VkPhysicalDeviceLimits& limits() const { return limits_; }
  /// The largest single allocation in bytes (maxMemoryAllocationSize).
  uint64_t max_allocation_bytes() const { return max_allocation_size_; }
  /// The compute queue's timestampValidBits (0: no timestamps).
  uint32_t timestamp_valid_bits() const { return timestamp_valid_bits_; }
  bool validation() const { return instance_.validation(); }
  bool has_float64() const { return has_float64_; }
  /// The wait limit in nanoseconds.
  uint64_t timeout_ns() const { return timeout_ns_; }

  /// Memory: the memory type a buffer of `use` gets among `type_bits` (from VkMemoryRequirements).
  /// Throws DeviceError when none fits.
  uint32_t memory_type(uint32_t type_bits, MemoryUse use) const;
  const VkPhysicalDeviceMemoryProperties& memory_properties() const { return memory_; }
  /// Bytes that may still be allocated from `heap`: VK_EXT_memory_budget's budget minus usage when
  /// the device has it, else the heap size minus what this context has allocated.
  uint64_t heap_available(uint32_t heap) const;
  /// Throws DeviceError "cannot allocate WHAT: X MiB requested, Y MiB available ..." unless `bytes`
  /// fit in `heap` and in the device's single-allocation and buffer size limits.
  void check_allocation(uint64_t bytes, uint32_t heap, const std::string& what) const;
  /// Bookkeeping for heap_available without the budget extension.
  void note_allocated(uint32_t heap, uint64_t bytes) { allocated_[heap] += bytes; }
  void note_freed(uint32_t heap, uint64_t bytes) { allocated_[heap] -= bytes; }

  /// Marks the context failed (device lost, timeout); the reason goes into later errors.
  void fail(const std::string& reason);
  bool failed() const { return !failure_.empty(); }
  /// Throws DeviceError when the context has failed.
  void ensure_usable() const;

  /// Faults on demand, for tests of the error paths (device lost, out of memory) on a healthy
  /// device: see arm_faults_from_environment. `count` >= 1: the count-th wait of a Sequence on
  /// this context from now on (device_lost) or the count-th buffer allocation (out_of_memory) fails
  /// as if the driver had returned VK_ERROR_DEVICE_LOST or VK_ERROR_OUT_OF_DEVICE_MEMORY; the wait
  /// still waits, so no work runs under the objects the error path then destroys. none disarms.
  enum class Fault { none, device_lost, out_of_memory };
  void arm_fault(Fault kind, uint32_t count) { fault_ = kind, fault_countdown_ = count; }
  /// Whether the armed fault of `kind` is due now (counts one wait or allocation down).
  bool fault_due(Fault kind) {
    if (fault_ != kind || fault_countdown_ == 0) return false;
    return --fault_countdown_ == 0;
  }

  /// Submissions whose completion has not been seen (see Sequence). While any is pending, the
  /// destructors of buffers, pipelines and the context leak their objects instead of destroying
  /// them under work that may still run (only after a timeout).
  void note_submitted() { ++pending_; }
  void note_completed() { assert(pending_ > 0); --pending_; }
  bool work_pending() const { return pending_ > 0; }

 private:
  Instance& instance_;
  VkPhysicalDevice physical_ = VK_NULL_HANDLE;
  VkDevice device_ = VK_NULL_HANDLE;
  VolkDeviceTable table_{};
  VkQueue queue_ = VK_NULL_HANDLE;
  uint32_t queue_family_ = 0;
  uint32_t timestamp_valid_bits_ = 0;
  DeviceInfo info_;
  VkPhysicalDeviceLimits limits_{};
  VkPhysicalDeviceMemoryProperties memory_{};
  bool has_memory_budget_ = false;
  bool has_float64_ = false;
  uint64_t max_allocation_size_ = 0;  // maxMemoryAllocationSize (Vulkan 1.1)
  uint64_t max_buffer_size_ = 0;      // maxBufferSize (Vulkan 1.3), 0 when unknown
  uint64_t timeout_ns_ = 0;
  std::vector<uint64_t> allocated_;
  std::string failure_;
  uint32_t pending_ = 0;
  Fault fault_ = Fault::none;
  uint32_t fault_countdown_ = 0;
};

/// Arms `context` from $MESHCVT_GPU_FAULT: "lost:N" (the N-th wait reports a lost device) or
/// "memory:N" (the N-th buffer allocation runs out of device memory), N >= 1; unset or empty
/// disarms. The GPU engine calls it once its device is open, so N counts the engine's own waits
/// and allocations. Throws OptionError naming the variable when the value is malformed.
void arm_faults_from_environment(Context& context);

/// Bytes as MiB with one decimal, for messages: "1.5 MiB".
std::string mib(uint64_t bytes);

}  // namespace meshcvt::vk
