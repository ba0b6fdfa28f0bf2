#!/usr/bin/env bash
# Benchmarks the Vulkan host layer (bench/vk_host_bench.cpp) on one device: setup costs, submit
# round trip, dispatch overhead, upload/download bandwidth, 64-bit atomics. Needs no mesh data.
# Usage: bench/vk_host_bench.sh [DEVICE_INDEX]   (build dir: $BUILD, default build-bench)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${BUILD:-build-bench}
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DMESHCVT_TESTS=OFF >/dev/null
cmake --build "$build" --target meshcvt >/dev/null
g++ -std=c++20 -O2 -ffp-contract=off -Isrc -Ihost -I"$build/shaders" bench/vk_host_bench.cpp "$build/libmeshcvt.a" \
    -ldl -lpthread -o "$build/vk_host_bench"
unset MESHCVT_VALIDATION   # timings without the validation layer
"$build/vk_host_bench" "$@"
