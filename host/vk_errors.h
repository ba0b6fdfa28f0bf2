// meshcvt Vulkan host layer: VkResult -> DeviceError. Every failing Vulkan call is reported by the
// call's name and the result's name (e.g. "vkAllocateMemory failed: VK_ERROR_OUT_OF_DEVICE_MEMORY"),
// with what it means and what to do where the result has a usual cause.
#pragma once

#include <volk.h>

#include <string>

namespace meshcvt::vk {

/// The enumerator's name, e.g. "VK_ERROR_DEVICE_LOST"; "VkResult(N)" for values this build does not know.
std::string result_name(VkResult result);

/// Throws DeviceError "CALL failed: RESULT_NAME[ (meaning)]", with advice where the result has a
/// usual cause (see DeviceError). Never returns.
[[noreturn]] void throw_result(VkResult result, const char* call);

/// Throws (see throw_result) unless `result` is VK_SUCCESS. `call` names the Vulkan function.
inline void check(VkResult result, const char* call) {
  if (result != VK_SUCCESS) throw_result(result, call);
}

}  // namespace meshcvt::vk
