#!/usr/bin/env bash
# The main job on the sample mesh shipped in the repo: installs what is needed, builds, runs, and
# writes its outputs to out/. Idempotent.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DMESHCVT_TESTS=OFF >/dev/null
cmake --build build -j "$(nproc)" --target meshcvt_cli
mkdir -p out
./build/meshcvt info data/sample-elephant.off
