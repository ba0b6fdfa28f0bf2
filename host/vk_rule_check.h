// meshcvt Vulkan host layer: the boundary rule evaluated on a device (shaders/rule_check.comp), so
// that a test can compare it with src/boundary_rule.h bit for bit on cases chosen to tell apart
// the orders of operations, fused multiply-adds and flushed subnormals (tests/test_boundary_rule.cpp).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "vk_context.h"

namespace meshcvt::vk {

/// The inputs of one evaluation of each function of the boundary rule (64 bytes, as the shader
/// reads them).
struct RuleCase {
  float p[3] = {0, 0, 0}, g[3] = {0, 0, 0};  ///< squared_distance(p, g)
  float d_lp = 0, d_lq = 0, d_rp = 0, d_rq = 0, w_l = 0, w_r = 0;  ///< decide_cluster_edge
  float d = 0, best_d = 0;                    ///< better_destination(d, c, best_d, best_c)
  uint32_t c = 0, best_c = 0;
};
static_assert(sizeof(RuleCase) == 64);

/// What the device computed for one RuleCase.
struct RuleResult {
  float squared_distance = 0;
  uint32_t edge_move = 0;  ///< EdgeMove's value: 0 none, 1 right_to_p, 2 left_to_q
  uint32_t better = 0;     ///< 1 when better_destination returned true
  uint32_t unused = 0;
};
static_assert(sizeof(RuleResult) == 16);

/// Evaluates every case on `context`'s device, one invocation each. Throws DeviceError on a
/// device failure.
std::vector<RuleResult> evaluate_boundary_rule(Context& context, std::span<const RuleCase> cases);

}  // namespace meshcvt::vk
