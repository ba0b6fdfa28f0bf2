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
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "boundary_rule.h"
#include "meshcvt/device.h"
#include "meshcvt/error.h"
#include "vk_context.h"
#include "vk_rule_check.h"

using namespace meshcvt;

namespace {

bool skip_gpu_tests() {
  const char* value = std::getenv("MESHCVT_SKIP_GPU_TESTS");
  return value && std::strcmp(value, "1") == 0;
}

uint32_t gpu_device() {
  std::vector<DeviceInfo> devices;
  try {
    devices = list_devices();
  } catch (const DeviceError& e) {
    FAIL("GPU tests need a Vulkan device (" << e.what() << "); or set MESHCVT_SKIP_GPU_TESTS=1");
  }
  if (devices.empty())
    FAIL("GPU tests need a Vulkan device: install mesa-vulkan-drivers (lavapipe), or set MESHCVT_SKIP_GPU_TESTS=1");
  DeviceChoice choice = resolve_device("gpu", devices);
  REQUIRE(choice.use_gpu);
  return static_cast<uint32_t>(choice.device_index);
}

std::string show(float x) {
  char text[32];
  std::snprintf(text, sizeof text, "%.9g", double(x));
  return text;
}

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

// Cases in the ranges the engine sees (normalized coordinates in [0, 1], weights are face areas in
// those units), placed on the roundings:
//  - p and g differing by 2^-24..1 per coordinate, so that the three squares span many binades
//    and the order of their sum matters;
//  - case 4 of the rule with the two weighted sums equal to within a few ulps (the exact tie
//    solved in double, then stepped ulp by ulp), and the exact ties of cases 1-3 (d_lp == d_lq,
//    d_rp == d_rq);
//  - destinations at equal distances with either cluster id lower;
//  - tiny faces and generators close to a face near the box's corner (2^-60..2^-80 apart,
//    weights down to 2^-110):
//    squares and products below 2^-126, where a device that flushes subnormals gives zero.
std::vector<vk::RuleCase> make_cases(bool subnormal) {
  std::mt19937_64 rng(subnormal ? 20261128 : 1128);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::uniform_int_distribution<int> coin(0, 1);
  auto scaled = [&](int low_exponent, int high_exponent) {  // a value with a random binade in the range
    std::uniform_int_distribution<int> e(low_exponent, high_exponent);
    return std::ldexp(0.5f + 0.5f * unit(rng), e(rng));
  };
  std::vector<vk::RuleCase> cases;
  for (int i = 0; i < 1 << 15; ++i) {
    vk::RuleCase c;
    for (int k = 0; k < 3; ++k) {
      // (Subnormal squares need p and g near 0: a corner of the normalized bounding box.)
      // (Every fourth case: a subnormal coordinate and weight, which a device may read as zero.)
      c.p[k] = !subnormal ? unit(rng) : i % 4 == 0 ? scaled(-140, -127) : scaled(-70, -50);
      const float delta = subnormal ? scaled(-80, -60) : scaled(-24, 0);
      c.g[k] = coin(rng) ? c.p[k] + delta : c.p[k] - delta;
    }
    // Case 4 near a tie: d_lp > d_lq and d_rp < d_rq, both_in_p == both_in_q within ulps.
    c.w_l = !subnormal ? scaled(-30, -1) : i % 4 == 0 ? scaled(-140, -127) : scaled(-110, -90);
    c.w_r = subnormal ? scaled(-110, -90) : scaled(-30, -1);
    c.d_lq = subnormal ? scaled(-40, -20) : scaled(-20, 0);
    c.d_lp = c.d_lq * (1.0f + unit(rng));
    c.d_rq = float((double(c.d_lp) - c.d_lq) * c.w_l / c.w_r) * (1.5f + unit(rng));
    float tie = float((double(c.d_lq) * c.w_l + double(c.d_rq) * c.w_r - double(c.d_lp) * c.w_l) / c.w_r);
    for (int steps = i % 9 - 4; steps != 0; steps += steps > 0 ? -1 : 1)
      tie = std::nextafter(tie, steps > 0 ? INFINITY : 0.0f);
    c.d_rp = tie;
    // Every eighth case: the exact ties of cases 1-3 instead.
    if (i % 8 == 7) {
      const int which = int(rng() % 3);  // 0: case 2, 1: case 3, 2: case 1
      if (which != 1) c.d_lp = c.d_lq;
      if (which != 0) c.d_rp = c.d_rq;
    }
    // Destinations: equal distances half the time.
    c.d = unit(rng);
    c.best_d = coin(rng) ? c.d : std::nextafter(c.d, coin(rng) ? 2.0f : 0.0f);
    c.c = uint32_t(rng() % 1000);
    c.best_c = uint32_t(rng() % 1000);
    cases.push_back(c);
  }
  return cases;
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
    vk::Context context(gpu_device());
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
  Power power;
  int wrong_distance = 0, wrong_edge = 0, wrong_destination = 0;
  for (size_t i = 0; i < cases.size(); ++i) {
    const vk::RuleCase& c = cases[i];
    const float d = squared_distance(c.p, c.g);
    const EdgeMove edge = decide_cluster_edge(c.d_lp, c.d_lq, c.d_rp, c.d_rq, c.w_l, c.w_r);
    const bool better = better_destination(c.d, c.c, c.best_d, c.best_c);
    if (bits(results[i].squared_distance) != bits(d) && wrong_distance++ == 0)
      MESSAGE("case " << i << ": squared_distance " << show(results[i].squared_distance) << " on the device, "
                      << show(d) << " on the CPU");
    if (results[i].edge_move != uint32_t(edge) && wrong_edge++ == 0)
      MESSAGE("case " << i << ": decide_cluster_edge " << results[i].edge_move << " on the device, "
                      << uint32_t(edge) << " on the CPU");
    if (results[i].better != uint32_t(better)) ++wrong_destination;
    power.reordered += bits(squared_distance_reordered(c.p, c.g)) != bits(d);
    power.fused += bits(squared_distance_fused(c.p, c.g)) != bits(d) ||
                   decide_fused(c.d_lp, c.d_lq, c.d_rp, c.d_rq, c.w_l, c.w_r) != edge;
    power.subnormal +=
        bits(squared_distance_unfloored(c.p, c.g, false)) != bits(squared_distance_unfloored(c.p, c.g, true)) ||
        decide_unfloored(c.d_lp, c.d_lq, c.d_rp, c.d_rq, c.w_l, c.w_r, false) !=
            decide_unfloored(c.d_lp, c.d_lq, c.d_rp, c.d_rq, c.w_l, c.w_r, true);
  }
  CHECK(wrong_distance == 0);
  CHECK(wrong_edge == 0);
  CHECK(wrong_destination == 0);
  return power;
}

}  // namespace

TEST_CASE("gpu: the boundary rule on the device equals src/boundary_rule.h bit for bit" *
          doctest::skip(skip_gpu_tests())) {
  const std::vector<vk::RuleCase> cases = make_cases(false);
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
          doctest::skip(skip_gpu_tests())) {
  const std::vector<vk::RuleCase> cases = make_cases(true);
  const Power power = check_on_device(cases);
  // The cases reach the subnormals: without the floor, a device that flushes them would give
  // other results on many (NVIDIA did, on 29514 distances and 4324 decisions of these).
  MESSAGE("cases whose unfloored results change when subnormals are flushed: " << power.subnormal << " of "
                                                                                << cases.size());
  CHECK(power.subnormal > 1000);
}
