// meshcvt benchmark of the Vulkan host layer (host/): what the GPU clustering driver pays for
// setup, a submission round trip, a dispatch, moving data, and 64-bit atomics, on one device.
// Not built by CMake; build it against a release build directory (see bench/vk_host_bench.sh):
//   g++ -std=c++20 -O2 -Isrc -Ihost -Ibuild/shaders bench/vk_host_bench.cpp build/libmeshcvt.a -ldl -lpthread
// Usage: vk_host_bench [DEVICE_INDEX]   (default: the device "gpu" picks)
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "meshcvt/device.h"
#include "vk_buffer.h"
#include "vk_context.h"
#include "vk_pipeline.h"
#include "vk_selftest.h"
#include "vk_sequence.h"

using namespace meshcvt;
using Clock = std::chrono::steady_clock;

static double since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

int main(int argc, char** argv) {
  auto start = Clock::now();
  const uint32_t index = argc > 1 ? static_cast<uint32_t>(std::atoi(argv[1]))
                                  : static_cast<uint32_t>(resolve_device("gpu").device_index);
  std::printf("list_devices + resolve (first instance):  %8.1f ms\n", since(start) * 1e3);

  start = Clock::now();
  vk::Context context(index);
  std::printf("Context (device %u, %s, validation %s): %8.1f ms\n", index, context.info().name.c_str(),
              context.validation() ? "on" : "off", since(start) * 1e3);

  start = Clock::now();
  vk::ComputePipeline pipeline(context, vk::self_test_spirv(), "selftest", sizeof(vk::SelfTestPush), 64);
  std::printf("ComputePipeline (selftest.comp):          %8.1f ms\n", since(start) * 1e3);

  vk::Sequence sequence(context);
  const int rounds = 200;
  start = Clock::now();
  for (int i = 0; i < rounds; ++i) sequence.run();
  std::printf("empty submit + wait round trip:           %8.1f us\n", since(start) / rounds * 1e6);

  vk::Buffer counters(context, 64 * 8, vk::MemoryUse::device, "counters");
  vk::SelfTestPush push;
  push.counters = counters.address();
  push.results = counters.address();
  push.mode = vk::self_test_combine;
  push.counter_count = 1;
  const int dispatches = 1000;
  start = Clock::now();
  for (int i = 0; i < dispatches; ++i) sequence.dispatch(pipeline, 1, push).barrier();
  sequence.run();
  std::printf("tiny dispatch + barrier (1000 per submit): %7.1f us each\n", since(start) / dispatches * 1e6);

  const uint64_t bytes = 256ull << 20;
  std::vector<char> host(bytes, 1);
  vk::Buffer big(context, bytes, vk::MemoryUse::device, "big");
  start = Clock::now();
  vk::upload(context, big, host.data(), bytes);
  std::printf("upload 256 MiB (%s):               %8.1f ms = %6.0f MiB/s\n", big.mapped() ? "mapped" : "staged",
              since(start) * 1e3, 256 / since(start));
  start = Clock::now();
  vk::upload_staged(context, big, host.data(), bytes, 0);
  std::printf("upload 256 MiB through staging copies:    %8.1f ms = %6.0f MiB/s\n", since(start) * 1e3,
              256 / since(start));
  start = Clock::now();
  vk::download_staged(context, big, host.data(), bytes, 0);
  std::printf("download 256 MiB through staging copies:  %8.1f ms = %6.0f MiB/s\n", since(start) * 1e3,
              256 / since(start));

  // 64-bit atomics: 16M invocations, each adding into one of N counters and into one shared
  // invocation counter (so even the spread case keeps one fully contended address).
  const uint32_t count = 16u << 20;
  vk::Buffer inputs(context, uint64_t(count) * 8, vk::MemoryUse::device, "inputs");
  vk::Buffer sums(context, 4097 * 8, vk::MemoryUse::device, "sums");
  push.inputs = inputs.address();
  push.counters = sums.address();
  push.mode = vk::self_test_accumulate;
  push.count = count;
  for (uint32_t spread : {5u, 4096u}) {
    push.counter_count = spread;
    sequence.fill(sums, 0).barrier().dispatch_1d(pipeline, count, push);
    start = Clock::now();
    sequence.run();
    std::printf("16M x 2 int64 atomicAdd, %4u counters:   %8.1f ms = %6.1f M invocations/s\n", spread, since(start) * 1e3,
                count / since(start) * 1e-6);
  }
  return 0;
}
