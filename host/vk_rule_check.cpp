// meshcvt Vulkan host layer: the boundary rule evaluated on a device (see vk_rule_check.h).
#include "vk_rule_check.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>

#include "boundary_rule.h"
#include "meshcvt/error.h"
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

constexpr int kCases = 1 << 15;

uint32_t bits(float x) {
  uint32_t b;
  std::memcpy(&b, &x, sizeof b);
  return b;
}

std::string show(float x) {
  char text[32];
  std::snprintf(text, sizeof text, "%.9g", double(x));
  return text;
}
}  // namespace

std::vector<RuleCase> boundary_rule_cases(bool subnormal) {
  std::mt19937_64 rng(subnormal ? 20261128 : 1128);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::uniform_int_distribution<int> coin(0, 1);
  auto scaled = [&](int low_exponent, int high_exponent) {  // a value with a random binade in the range
    std::uniform_int_distribution<int> e(low_exponent, high_exponent);
    return std::ldexp(0.5f + 0.5f * unit(rng), e(rng));
  };
  std::vector<RuleCase> cases;
  cases.reserve(kCases);
  for (int i = 0; i < kCases; ++i) {
    RuleCase c;
    for (int k = 0; k < 3; ++k) {
      // (Subnormal squares need p and g near 0: a corner of the normalized bounding box.)
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

std::vector<RuleResult> evaluate_boundary_rule(Context& context, std::span<const RuleCase> cases) {
  std::vector<RuleResult> results(cases.size());
  if (cases.empty()) return results;
  if (cases.size() > UINT32_MAX) throw DeviceError("evaluate_boundary_rule: more than 2^32 - 1 cases");
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

std::string rule_differences(std::span<const RuleCase> cases, std::span<const RuleResult> results) {
  if (results.size() != cases.size())
    return std::to_string(results.size()) + " results for " + std::to_string(cases.size()) + " cases";
  size_t wrong = 0;
  std::string first;
  for (size_t i = 0; i < cases.size(); ++i) {
    const RuleCase& c = cases[i];
    const float d = squared_distance(c.p, c.g);
    const uint32_t edge = uint32_t(decide_cluster_edge(c.d_lp, c.d_lq, c.d_rp, c.d_rq, c.w_l, c.w_r));
    const uint32_t better = better_destination(c.d, c.c, c.best_d, c.best_c) ? 1 : 0;
    const RuleResult& r = results[i];
    if (bits(r.squared_distance) == bits(d) && r.edge_move == edge && r.better == better) continue;
    if (wrong++ > 0) continue;
    first = "case " + std::to_string(i) + ": ";
    if (bits(r.squared_distance) != bits(d))
      first += "squared_distance " + show(r.squared_distance) + " on the device, " + show(d) + " on the CPU";
    else if (r.edge_move != edge)
      first += "decide_cluster_edge " + std::to_string(r.edge_move) + " on the device, " + std::to_string(edge) +
               " on the CPU";
    else
      first += "better_destination " + std::to_string(r.better) + " on the device, " + std::to_string(better) +
               " on the CPU";
  }
  if (wrong == 0) return "";
  return std::to_string(wrong) + " of " + std::to_string(cases.size()) + " cases differ; first, " + first;
}

void check_boundary_rule(Context& context) {
  for (bool subnormal : {false, true}) {
    const std::vector<RuleCase> cases = boundary_rule_cases(subnormal);
    const std::string differences = rule_differences(cases, evaluate_boundary_rule(context, cases));
    if (!differences.empty())
      throw DeviceError("the boundary rule on " + context.info().name + " differs from the CPU engine's" +
                            (subnormal ? " where values are subnormal" : "") + ": " + differences +
                            ". The GPU engine would not give the CPU engine's labels",
                        "use --device cpu");
  }
}

}  // namespace meshcvt::vk
