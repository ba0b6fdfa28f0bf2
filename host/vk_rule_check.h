// meshcvt Vulkan host layer: the boundary rule evaluated on a device (shaders/rule_check.comp) and
// compared with src/boundary_rule.h bit for bit, on cases chosen to tell apart the orders of
// operations, fused multiply-adds and flushed subnormals. Part of the device self-test
// (self_test_device, `meshcvt devices --check`): a device that passes takes the CPU engine's
// decisions; tests/test_gpu_rule.cpp checks that the cases have that power.
#pragma once

#include <cstdint>
#include <span>
#include <string>
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

/// 32768 cases (the same on every run), in the ranges the engine sees (normalized coordinates in
/// [0, 1], weights face areas in those units), placed on the roundings. subnormal = false:
///  - p and g differing by 2^-24..1 per coordinate, so that the three squares span many binades
///    and the order of their sum matters;
///  - case 4 of the rule with the two weighted sums equal to within 4 ulps (the exact tie solved in
///    double, then stepped ulp by ulp); one case in eight an exact tie of cases 1-3 instead;
///  - destinations at equal distances half the time, with either cluster id lower.
/// subnormal = true: the same near points 2^-80..2^-60 apart next to 0 and weights near 2^-100, so
/// that squares and products fall below 2^-126; one case in four has a subnormal coordinate and
/// weight, which a device may read as zero.
std::vector<RuleCase> boundary_rule_cases(bool subnormal);

/// Evaluates every case on `context`'s device, one invocation each. Throws DeviceError on a
/// device failure.
std::vector<RuleResult> evaluate_boundary_rule(Context& context, std::span<const RuleCase> cases);

/// Compares results from a device with src/boundary_rule.h: "" when every one is equal, else how
/// many differ and what the first is.
std::string rule_differences(std::span<const RuleCase> cases, std::span<const RuleResult> results);

/// Evaluates both sets of boundary_rule_cases on the device and compares every result with
/// src/boundary_rule.h. Throws DeviceError naming how many cases differ and the first.
void check_boundary_rule(Context& context);

}  // namespace meshcvt::vk
