// meshcvt Vulkan host layer: the device self-test (shaders/selftest.comp). Checks, with exact
// expected values computed on the host, that 64-bit atomics through buffer device addresses,
// barriers between dispatches and copies work on a device. Used by `meshcvt devices --check`,
// self_test_device() and the tests.
#pragma once

#include <cstdint>
#include <span>

#include "vk_context.h"

namespace meshcvt::vk {

/// Push constants of shaders/selftest.comp (std430 push-constant layout; 56 bytes).
struct SelfTestPush {
  uint64_t inputs = 0;    ///< device address of int64 inputs (mode 0), or of the array to write (mode 2)
  uint64_t counters = 0;  ///< device address of counter_count + 1 int64 sums
  uint64_t results = 0;   ///< device address of int64 results (modes 1 and 3)
  uint64_t index = 0;     ///< mode 2: element to write (< 2^32)
  int64_t value = 0;      ///< mode 2: value to write; mode 3: seed
  uint32_t count = 0;     ///< invocations that do work
  uint32_t counter_count = 0;
  uint32_t mode = 0;      ///< SelfTestMode
  uint32_t spin = 0;      ///< mode 3: loop iterations per invocation
};
static_assert(sizeof(SelfTestPush) == 56);

enum SelfTestMode : uint32_t {
  self_test_accumulate = 0,  ///< counters[i % counter_count] += inputs[i]; counters[counter_count] += 1
  self_test_combine = 1,     ///< results[j] = 3 * counters[j] - j, j < counter_count
  self_test_write = 2,       ///< inputs[index] = value (one invocation)
  self_test_spin = 3,        ///< results[i] = LCG^spin(i + value): busy work
};

/// The embedded SPIR-V of shaders/selftest.comp.
std::span<const uint32_t> self_test_spirv();

/// Input value i of the accumulate test: |value| between 2^24 and 2^44, negative for even i % 5.
int64_t self_test_input(uint32_t i);

/// Runs the self-test on `context` (about 65k invocations, 5 counters, 3 submissions).
/// Throws DeviceError naming the first wrong value (expected vs actual).
void run_self_test(Context& context);

}  // namespace meshcvt::vk
