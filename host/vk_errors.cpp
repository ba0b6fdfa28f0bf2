// meshcvt Vulkan host layer: names of VkResult values and the DeviceError thrown for a failed call.
// The names are spelled out here because Debian's headers ship no vk_enum_string_helper.h.
#include "vk_errors.h"

#include "meshcvt/error.h"

namespace meshcvt::vk {

std::string result_name(VkResult result) {
  switch (result) {
#define MESHCVT_RESULT(name) \
  case name:                 \
    return #name;
    MESHCVT_RESULT(VK_SUCCESS)
    MESHCVT_RESULT(VK_NOT_READY)
    MESHCVT_RESULT(VK_TIMEOUT)
    MESHCVT_RESULT(VK_EVENT_SET)
    MESHCVT_RESULT(VK_EVENT_RESET)
    MESHCVT_RESULT(VK_INCOMPLETE)
    MESHCVT_RESULT(VK_ERROR_OUT_OF_HOST_MEMORY)
    MESHCVT_RESULT(VK_ERROR_OUT_OF_DEVICE_MEMORY)
    MESHCVT_RESULT(VK_ERROR_INITIALIZATION_FAILED)
    MESHCVT_RESULT(VK_ERROR_DEVICE_LOST)
    MESHCVT_RESULT(VK_ERROR_MEMORY_MAP_FAILED)
    MESHCVT_RESULT(VK_ERROR_LAYER_NOT_PRESENT)
    MESHCVT_RESULT(VK_ERROR_EXTENSION_NOT_PRESENT)
    MESHCVT_RESULT(VK_ERROR_FEATURE_NOT_PRESENT)
    MESHCVT_RESULT(VK_ERROR_INCOMPATIBLE_DRIVER)
    MESHCVT_RESULT(VK_ERROR_TOO_MANY_OBJECTS)
    MESHCVT_RESULT(VK_ERROR_FORMAT_NOT_SUPPORTED)
    MESHCVT_RESULT(VK_ERROR_FRAGMENTED_POOL)
    MESHCVT_RESULT(VK_ERROR_UNKNOWN)
    MESHCVT_RESULT(VK_ERROR_OUT_OF_POOL_MEMORY)
    MESHCVT_RESULT(VK_ERROR_INVALID_EXTERNAL_HANDLE)
    MESHCVT_RESULT(VK_ERROR_FRAGMENTATION)
    MESHCVT_RESULT(VK_ERROR_INVALID_OPAQUE_CAPTURE_ADDRESS)
    MESHCVT_RESULT(VK_PIPELINE_COMPILE_REQUIRED)
    MESHCVT_RESULT(VK_ERROR_SURFACE_LOST_KHR)
    MESHCVT_RESULT(VK_ERROR_NATIVE_WINDOW_IN_USE_KHR)
    MESHCVT_RESULT(VK_SUBOPTIMAL_KHR)
    MESHCVT_RESULT(VK_ERROR_OUT_OF_DATE_KHR)
    MESHCVT_RESULT(VK_ERROR_INCOMPATIBLE_DISPLAY_KHR)
    MESHCVT_RESULT(VK_ERROR_VALIDATION_FAILED_EXT)
    MESHCVT_RESULT(VK_ERROR_INVALID_SHADER_NV)
    MESHCVT_RESULT(VK_ERROR_NOT_PERMITTED_KHR)
    MESHCVT_RESULT(VK_THREAD_IDLE_KHR)
    MESHCVT_RESULT(VK_THREAD_DONE_KHR)
    MESHCVT_RESULT(VK_OPERATION_DEFERRED_KHR)
    MESHCVT_RESULT(VK_OPERATION_NOT_DEFERRED_KHR)
    MESHCVT_RESULT(VK_ERROR_COMPRESSION_EXHAUSTED_EXT)
#undef MESHCVT_RESULT
    default:
      return "VkResult(" + std::to_string(static_cast<int>(result)) + ")";
  }
}

// What the results with a usual cause mean, and what a user can do about them.
struct Hint {
  const char* meaning;  // part of the reason
  const char* advice;   // DeviceError::advice
};

static Hint hint(VkResult result) {
  switch (result) {
    case VK_ERROR_OUT_OF_DEVICE_MEMORY:
      return {"the GPU is out of memory", "try a smaller mesh or --device cpu"};
    case VK_ERROR_OUT_OF_HOST_MEMORY:
      return {"the driver ran out of host memory", nullptr};
    case VK_ERROR_DEVICE_LOST:
      return {"the GPU was lost: driver reset, hang or crash", "the run was abandoned; try --device cpu"};
    case VK_ERROR_INCOMPATIBLE_DRIVER:
      return {"no compatible Vulkan driver", "install one, e.g. mesa-vulkan-drivers for the CPU device lavapipe"};
    default:
      return {nullptr, nullptr};
  }
}

void throw_result(VkResult result, const char* call) {
  std::string reason = std::string(call) + " failed: " + result_name(result);
  const Hint h = hint(result);
  if (h.meaning) reason += std::string(" (") + h.meaning + ")";
  throw DeviceError(reason, h.advice ? h.advice : "");
}

}  // namespace meshcvt::vk
