// Tests that shaders/boundary_rule.glsl, run on the device (host/vk_rule_check.cpp), computes what
// src/boundary_rule.h computes, bit for bit: the squared distances, the four-case decisions and the
// destination tie rule. The engine consistency tests (test_gpu_engine.cpp) compare whole
// clusterings, where a difference in rounding shows only when a mesh brings two candidates within a
// rounding of each other: a shader summing the squared distance in another order passed all of
// them. The cases here are made to sit on those roundings, and the test checks that they do: a
// reordered sum or a fused multiply-add changes many of their results. Others reach below 2^-126,
// where NVIDIA's driver flushes subnormals to zero; the rule floors its squares and products at
// 2^-100 (kRuleFloor) so that both engines agree there too.
//
// GPU tests need a Vulkan device (lavapipe from mesa-vulkan-drivers is enough); without one they
// fail with a message saying so, unless MESHCVT_SKIP_GPU_TESTS=1 skips them.
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "boundary_rule.h"
#include "gpu_test_device.h"
#include "vk_context.h"
#include "vk_rule_check.h"

using namespace meshcvt;

namespace {

uint32_t bits(float x) {
  uint32_t b;
  std::memcpy(&b, &x, sizeof b);
  return b;
}

// The same functions as a careless shader could compute them: the sum in another order, or fused
// multiply-adds where the rule multiplies and then adds. The cases must tell each from the rule.
float squared_distance_reordered(const float p[3], const float g[3]) {
  const float dx = p[0] - g[0], dy = p[1] - g[1], dz = p[2] - g[2];
  return dx * dx + (dy * dy + dz * dz);
}
float squared_distance_fused(const float p[3], const float g[3]) {
  const float dx = p[0] - g[0], dy = p[1] - g[1], dz = p[2] - g[2];
  return std::fma(dz, dz, std::fma(dy, dy, dx * dx));
}
EdgeMove decide_fused(float d_lp, float d_lq, float d_rp, float d_rq, float w_l, float w_r) {
  if (d_lp <= d_lq && d_rp >= d_rq) return EdgeMove::none;
  if (d_lp <= d_lq) return EdgeMove::right_to_p;
  if (d_rp >= d_rq) return EdgeMove::left_to_q;
  return std::fma(d_lp, w_l, d_rp * w_r) < std::fma(d_lq, w_l, d_rq * w_r) ? EdgeMove::right_to_p
                                                                          : EdgeMove::left_to_q;
}
// The rule without its floor (kRuleFloor), as IEEE arithmetic gives it and as a device that flushes
// subnormal results to zero gives it: where these two differ, a case reaches the subnormals.
float flushed(float x) { return std::fpclassify(x) == FP_SUBNORMAL ? std::copysign(0.0f, x) : x; }
float squared_distance_unfloored(const float p[3], const float g[3], bool flush) {
  auto f = [&](float x) { return flush ? flushed(x) : x; };
  const float dx = f(p[0] - g[0]), dy = f(p[1] - g[1]), dz = f(p[2] - g[2]);
  return f(f(f(dx * dx) + f(dy * dy)) + f(dz * dz));
}
EdgeMove decide_unfloored(float d_lp, float d_lq, float d_rp, float d_rq, float w_l, float w_r, bool flush) {
  auto f = [&](float x) { return flush ? flushed(x) : x; };
  if (d_lp <= d_lq && d_rp >= d_rq) return EdgeMove::none;
  if (d_lp <= d_lq) return EdgeMove::right_to_p;
  if (d_rp >= d_rq) return EdgeMove::left_to_q;
  const float both_in_p = f(f(d_lp * w_l) + f(d_rp * w_r));
  const float both_in_q = f(f(d_lq * w_l) + f(d_rq * w_r));
  return both_in_p < both_in_q ? EdgeMove::right_to_p : EdgeMove::left_to_q;
}

// Runs the cases on the device and checks every result against the rule; returns how many of
// them tell the rule apart from each careless variant (reordered, fused), and how many reach the
// subnormals (the rule without its floor gives another result when subnormals are flushed).
struct Power {
  int reordered = 0, fused = 0, subnormal = 0;
};
Power check_on_device(const std::vector<vk::RuleCase>& cases) {
  const uint64_t messages = vk::validation_message_count();
  std::vector<vk::RuleResult> results;
  {
    vk::Context context(test::gpu_test_device());
    results = vk::evaluate_boundary_rule(context, cases);
    VkPhysicalDeviceFloatControlsProperties controls{};
    controls.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FLOAT_CONTROLS_PROPERTIES;
    VkPhysicalDeviceProperties2 properties{};
    properties.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2;
    properties.pNext = &controls;
    vkGetPhysicalDeviceProperties2(context.physical(), &properties);
    MESSAGE("boundary rule checked on " << context.info().name << " (shaderDenormPreserveFloat32 "
                                        << controls.shaderDenormPreserveFloat32 << ", shaderDenormFlushToZeroFloat32 "
                                        << controls.shaderDenormFlushToZeroFloat32 << ")");
  }
  CHECK(vk::validation_message_count() == messages);
  REQUIRE(results.size() == cases.size());
  // Equal on the device, bit for bit (rule_differences names the first difference).
  const std::string differences = vk::rule_differences(cases, results);
  CHECK_MESSAGE(differences.empty(), differences);
  Power power;
  for (const vk::RuleCase& c : cases) {
    const float d = squared_distance(c.p, c.g);
    const EdgeMove edge = decide_cluster_edge(c.d_lp, c.d_lq, c.d_rp, c.d_rq, c.w_l, c.w_r);
    power.reordered += bits(squared_distance_reordered(c.p, c.g)) != bits(d);
    power.fused += bits(squared_distance_fused(c.p, c.g)) != bits(d) ||
                   decide_fused(c.d_lp, c.d_lq, c.d_rp, c.d_rq, c.w_l, c.w_r) != edge;
    power.subnormal +=
        bits(squared_distance_unfloored(c.p, c.g, false)) != bits(squared_distance_unfloored(c.p, c.g, true)) ||
        decide_unfloored(c.d_lp, c.d_lq, c.d_rp, c.d_rq, c.w_l, c.w_r, false) !=
            decide_unfloored(c.d_lp, c.d_lq, c.d_rp, c.d_rq, c.w_l, c.w_r, true);
  }
  return power;
}

}  // namespace

TEST_CASE("gpu: the boundary rule on the device equals src/boundary_rule.h bit for bit" *
          doctest::skip(test::skip_gpu_tests())) {
  const std::vector<vk::RuleCase> cases = vk::boundary_rule_cases(false);
  const Power power = check_on_device(cases);
  // The cases can tell: a shader that reorders the sum or fuses a multiply-add would fail many.
  MESSAGE("cases that tell the rule from a reordered sum: " << power.reordered << ", from fused multiply-adds: "
                                                             << power.fused << " of " << cases.size());
  CHECK(power.reordered > 1000);
  CHECK(power.fused > 1000);
  // Every kind of case came up: each outcome of the rule, and both answers of the tie rule.
  int outcomes[3] = {0, 0, 0}, ties = 0, tie_wins = 0;
  for (const vk::RuleCase& c : cases) {
    ++outcomes[int(decide_cluster_edge(c.d_lp, c.d_lq, c.d_rp, c.d_rq, c.w_l, c.w_r))];
    if (c.d == c.best_d) ++ties, tie_wins += better_destination(c.d, c.c, c.best_d, c.best_c);
  }
  CHECK(outcomes[0] > 1000);
  CHECK(outcomes[1] > 1000);
  CHECK(outcomes[2] > 1000);
  CHECK(tie_wins > 1000);
  CHECK(ties - tie_wins > 1000);
}

TEST_CASE("gpu: the boundary rule gives the CPU's results where distances and weighted sums are subnormal" *
          doctest::skip(test::skip_gpu_tests())) {
  const std::vector<vk::RuleCase> cases = vk::boundary_rule_cases(true);
  const Power power = check_on_device(cases);
  // The cases reach the subnormals: without the floor, a device that flushes them would give
  // other results on many (NVIDIA did, on 29514 distances and 4324 decisions of these).
  MESSAGE("cases whose unfloored results change when subnormals are flushed: " << power.subnormal << " of "
                                                                                << cases.size());
  CHECK(power.subnormal > 1000);
}

TEST_CASE("gpu: check_boundary_rule (the device self-test) passes on the device, and names a difference") {
  // The comparison itself, without a device: a result changed in its last bit is named.
  const std::vector<vk::RuleCase> cases = vk::boundary_rule_cases(false);
  std::vector<vk::RuleResult> results(cases.size());
  for (size_t i = 0; i < cases.size(); ++i) {
    const vk::RuleCase& c = cases[i];
    results[i].squared_distance = squared_distance(c.p, c.g);
    results[i].edge_move = uint32_t(decide_cluster_edge(c.d_lp, c.d_lq, c.d_rp, c.d_rq, c.w_l, c.w_r));
    results[i].better = better_destination(c.d, c.c, c.best_d, c.best_c) ? 1 : 0;
  }
  CHECK(vk::rule_differences(cases, results).empty());
  results[5].squared_distance = std::nextafter(results[5].squared_distance, INFINITY);
  results[9].edge_move ^= 3;
  const std::string named = vk::rule_differences(cases, results);
  CAPTURE(named);
  CHECK(named.find("2 of 32768 cases differ") == 0);
  CHECK(named.find("case 5: squared_distance") != std::string::npos);
  CHECK(vk::rule_differences(cases, std::span<const vk::RuleResult>(results).first(7)).find("7 results") == 0);
  if (test::skip_gpu_tests()) return;
  // On the device, as `meshcvt devices --check` runs it.
  const uint64_t messages = vk::validation_message_count();
  {
    vk::Context context(test::gpu_test_device());
    CHECK_NOTHROW(vk::check_boundary_rule(context));
  }
  CHECK(vk::validation_message_count() == messages);
}
