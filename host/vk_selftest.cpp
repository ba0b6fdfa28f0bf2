// meshcvt Vulkan host layer: the device self-test. Sums of large signed 64-bit values are
// accumulated with atomics on the device, combined by a second dispatch after a barrier, copied
// to a mapped readback buffer, and compared exactly with the same sums computed on the host.
#include "vk_selftest.h"

#include <cstring>
#include <vector>

#include "meshcvt/error.h"
#include "selftest.spv.h"
#include "vk_buffer.h"
#include "vk_pipeline.h"
#include "vk_sequence.h"

namespace meshcvt::vk {

namespace {
constexpr uint32_t kInvocations = (1u << 16) + 7;  // not a multiple of the workgroup size: bounds checks run
constexpr uint32_t kCounters = 5;
}  // namespace

std::span<const uint32_t> self_test_spirv() { return MESHCVT_SPIRV(selftest); }

int64_t self_test_input(uint32_t i) {
  // splitmix-style hash: values spread over the whole 2^24..2^44 range.
  uint64_t h = (uint64_t(i) + 1) * 0x9E3779B97F4A7C15ull;
  h = (h ^ (h >> 31)) * 0xBF58476D1CE4E5B9ull;
  h ^= h >> 29;
  const int64_t magnitude = int64_t(((h & 0xFFFFF) + 1) << 24) + int64_t((h >> 20) & 0xFFFFFF);
  return (i % kCounters) % 2 == 0 ? -magnitude : magnitude;
}

void run_self_test(Context& context) {
  std::vector<int64_t> inputs(kInvocations);
  std::vector<int64_t> expected(2 * kCounters + 1, 0);  // counters, invocation count, combined
  for (uint32_t i = 0; i < kInvocations; ++i) {
    inputs[i] = self_test_input(i);
    expected[i % kCounters] += inputs[i];
  }
  expected[kCounters] = kInvocations;
  for (uint32_t j = 0; j < kCounters; ++j) expected[kCounters + 1 + j] = expected[j] * 3 - int64_t(j);

  Buffer input_buffer(context, inputs.size() * sizeof(int64_t), MemoryUse::device, "self-test inputs");
  Buffer counters(context, (kCounters + 1) * sizeof(int64_t), MemoryUse::device, "self-test counters");
  Buffer results(context, kCounters * sizeof(int64_t), MemoryUse::device, "self-test results");
  Buffer readback(context, expected.size() * sizeof(int64_t), MemoryUse::readback, "self-test readback");
  upload(context, input_buffer, std::span<const int64_t>(inputs));
  ComputePipeline pipeline(context, self_test_spirv(), "selftest", sizeof(SelfTestPush), 64);

  SelfTestPush push;
  push.inputs = input_buffer.address();
  push.counters = counters.address();
  push.results = results.address();
  push.count = kInvocations;
  push.counter_count = kCounters;

  Sequence sequence(context);
  sequence.fill(counters, 0).barrier();
  push.mode = self_test_accumulate;
  sequence.dispatch_1d(pipeline, kInvocations, push).barrier();
  push.mode = self_test_combine;
  sequence.dispatch_1d(pipeline, kCounters, push).barrier();
  sequence.copy(counters, readback, counters.size());
  sequence.copy(results, readback, results.size(), 0, counters.size());
  sequence.run();

  std::vector<int64_t> actual(expected.size());
  std::memcpy(actual.data(), readback.mapped(), actual.size() * sizeof(int64_t));
  static const char* const names[] = {"counter", "invocation count", "combined"};
  for (size_t k = 0; k < expected.size(); ++k) {
    if (actual[k] == expected[k]) continue;
    const int part = k < kCounters ? 0 : k == kCounters ? 1 : 2;
    throw DeviceError("GPU self-test failed on " + context.info().name + ": " + names[part] + " " +
                      std::to_string(part == 2 ? k - kCounters - 1 : part == 0 ? k : 0) + " is " +
                      std::to_string(actual[k]) + ", expected " + std::to_string(expected[k]));
  }
}

}  // namespace meshcvt::vk
