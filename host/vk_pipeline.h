// meshcvt Vulkan host layer: compute pipelines made from SPIR-V embedded in the binary.
//
// CMake compiles shaders/NAME.comp into build/shaders/NAME.spv.h, which defines
// `const uint32_t spirv_NAME[]`; include it in the one host/ file that makes that pipeline and pass
// MESHCVT_SPIRV(NAME). Shaders take their inputs from push constants, buffers by device address
// (GL_EXT_buffer_reference), never from descriptor sets: the pipeline layout has no sets.
// The workgroup size is specialization constant 0 (`layout(local_size_x_id = 0) in;`).
// Addresses that do not fit in the push constants (128 bytes = 16 addresses on every device) go
// into a small Buffer used as a pointer table, whose own address is pushed.
#pragma once

#include <volk.h>

#include <cstdint>
#include <span>
#include <string>

#include "vk_context.h"

/// The embedded SPIR-V words of shaders/NAME.comp, as a span (needs "NAME.spv.h" included).
#define MESHCVT_SPIRV(NAME) std::span<const uint32_t>(spirv_##NAME)

namespace meshcvt::vk {

class ComputePipeline {
 public:
  /// spirv: the shader's words (MESHCVT_SPIRV). name: for error messages.
  /// push_constant_bytes: size of the shader's push-constant block (multiple of 4, at most the
  /// device's maxPushConstantsSize, 0 for none); every dispatch passes exactly that many bytes.
  /// local_size_x: workgroup size, specialization constant 0, within the device limits.
  /// constants: further 32-bit specialization constants, ids 1, 2, ... in order.
  /// Throws DeviceError when a limit is exceeded or the driver refuses the shader.
  ComputePipeline(Context& context, std::span<const uint32_t> spirv, std::string name, uint32_t push_constant_bytes,
                  uint32_t local_size_x = 64, std::span<const uint32_t> constants = {});
  ~ComputePipeline();
  ComputePipeline(const ComputePipeline&) = delete;
  ComputePipeline& operator=(const ComputePipeline&) = delete;

  VkPipeline handle() const { return pipeline_; }
  VkPipelineLayout layout() const { return layout_; }
  uint32_t push_constant_bytes() const { return push_constant_bytes_; }
  uint32_t local_size_x() const { return local_size_x_; }
  const std::string& name() const { return name_; }

 private:
  Context& context_;
  std::string name_;
  uint32_t push_constant_bytes_ = 0;
  uint32_t local_size_x_ = 0;
  VkPipelineLayout layout_ = VK_NULL_HANDLE;
  VkPipeline pipeline_ = VK_NULL_HANDLE;
};

}  // namespace meshcvt::vk
