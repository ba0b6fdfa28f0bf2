// meshcvt Vulkan host layer: the boundary rule evaluated on a device (see vk_rule_check.h).
#include "vk_rule_check.h"

#include <cstring>

#include "rule_check.spv.h"
#include "vk_buffer.h"
#include "vk_pipeline.h"
#include "vk_sequence.h"

namespace meshcvt::vk {

namespace {
// Push constants of shaders/rule_check.comp.
struct RuleCheckPush {
  uint64_t cases = 0;    ///< device address of the RuleCase array
  uint64_t results = 0;  ///< device address of the RuleResult array
  uint32_t count = 0;
  uint32_t unused = 0;
};
static_assert(sizeof(RuleCheckPush) == 24);
}  // namespace

std::vector<RuleResult> evaluate_boundary_rule(Context& context, std::span<const RuleCase> cases) {
  std::vector<RuleResult> results(cases.size());
  if (cases.empty()) return results;
  Buffer input(context, cases.size_bytes(), MemoryUse::device, "rule check cases");
  Buffer output(context, results.size() * sizeof(RuleResult), MemoryUse::device, "rule check results");
  Buffer readback(context, output.size(), MemoryUse::readback, "rule check readback");
  upload(context, input, cases);
  ComputePipeline pipeline(context, MESHCVT_SPIRV(rule_check), "rule_check", sizeof(RuleCheckPush), 64);
  RuleCheckPush push;
  push.cases = input.address();
  push.results = output.address();
  push.count = static_cast<uint32_t>(cases.size());
  Sequence sequence(context);
  sequence.dispatch_1d(pipeline, cases.size(), push).barrier();
  sequence.copy(output, readback, results.size() * sizeof(RuleResult));
  sequence.run();
  std::memcpy(results.data(), readback.mapped(), results.size() * sizeof(RuleResult));
  return results;
}

}  // namespace meshcvt::vk
