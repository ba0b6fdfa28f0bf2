// meshcvt Vulkan host layer: compute pipeline creation (shader module, push-constant-only layout,
// specialization constants for the workgroup size and tuning values).
#include "vk_pipeline.h"

#include <vector>

#include "meshcvt/error.h"
#include "vk_errors.h"

namespace meshcvt::vk {

ComputePipeline::ComputePipeline(Context& context, std::span<const uint32_t> spirv, std::string name,
                                 uint32_t push_constant_bytes, uint32_t local_size_x,
                                 std::span<const uint32_t> constants)
    : context_(context), name_(std::move(name)), push_constant_bytes_(push_constant_bytes), local_size_x_(local_size_x) {
  context.ensure_usable();
  const VkPhysicalDeviceLimits& limits = context.limits();
  if (push_constant_bytes % 4 != 0 || push_constant_bytes > limits.maxPushConstantsSize)
    throw DeviceError("shader " + name_ + ": " + std::to_string(push_constant_bytes) +
                      " bytes of push constants; the device allows " + std::to_string(limits.maxPushConstantsSize) +
                      " (maxPushConstantsSize), in multiples of 4");
  if (local_size_x == 0 || local_size_x > limits.maxComputeWorkGroupSize[0] ||
      local_size_x > limits.maxComputeWorkGroupInvocations)
    throw DeviceError("shader " + name_ + ": workgroup size " + std::to_string(local_size_x) +
                      " is beyond the device's maxComputeWorkGroupSize.x " +
                      std::to_string(limits.maxComputeWorkGroupSize[0]));

  const auto& vk = context.vk();
  const VkDevice device = context.device();

  VkShaderModuleCreateInfo module_info{};
  module_info.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
  module_info.codeSize = spirv.size_bytes();
  module_info.pCode = spirv.data();
  VkShaderModule module = VK_NULL_HANDLE;
  check(vk.vkCreateShaderModule(device, &module_info, nullptr, &module),
        ("vkCreateShaderModule (" + name_ + ")").c_str());

  VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, push_constant_bytes};
  VkPipelineLayoutCreateInfo layout_info{};
  layout_info.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
  layout_info.pushConstantRangeCount = push_constant_bytes > 0 ? 1 : 0;
  layout_info.pPushConstantRanges = &range;
  VkResult result = vk.vkCreatePipelineLayout(device, &layout_info, nullptr, &layout_);
  if (result != VK_SUCCESS) {
    vk.vkDestroyShaderModule(device, module, nullptr);
    throw_result(result, ("vkCreatePipelineLayout (" + name_ + ")").c_str());
  }

  // Constant i (id i) is values[i]: 0 the workgroup size, then the caller's.
  std::vector<uint32_t> values{local_size_x};
  values.insert(values.end(), constants.begin(), constants.end());
  std::vector<VkSpecializationMapEntry> entries(values.size());
  for (uint32_t i = 0; i < values.size(); ++i) entries[i] = {i, i * 4u, 4u};
  VkSpecializationInfo specialization{};
  specialization.mapEntryCount = static_cast<uint32_t>(entries.size());
  specialization.pMapEntries = entries.data();
  specialization.dataSize = values.size() * 4;
  specialization.pData = values.data();

  VkComputePipelineCreateInfo pipeline_info{};
  pipeline_info.sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO;
  pipeline_info.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
  pipeline_info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  pipeline_info.stage.module = module;
  pipeline_info.stage.pName = "main";
  pipeline_info.stage.pSpecializationInfo = &specialization;
  pipeline_info.layout = layout_;
  result = vk.vkCreateComputePipelines(device, VK_NULL_HANDLE, 1, &pipeline_info, nullptr, &pipeline_);
  vk.vkDestroyShaderModule(device, module, nullptr);  // the pipeline keeps what it needs
  if (result != VK_SUCCESS) {
    pipeline_ = VK_NULL_HANDLE;
    vk.vkDestroyPipelineLayout(device, layout_, nullptr);
    throw_result(result, ("vkCreateComputePipelines (" + name_ + ")").c_str());
  }
}

ComputePipeline::~ComputePipeline() {
  if (context_.work_pending()) return;  // may still run after a timeout: leak, see Context
  const auto& vk = context_.vk();
  vk.vkDestroyPipeline(context_.device(), pipeline_, nullptr);
  vk.vkDestroyPipelineLayout(context_.device(), layout_, nullptr);
}

}  // namespace meshcvt::vk
