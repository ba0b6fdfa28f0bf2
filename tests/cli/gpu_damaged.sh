#!/usr/bin/env bash
# CLI test: the GPU engine on damaged meshes. bench/gpu_consistency_sweep.py damages the elephant
# as bench/pipeline_stress.py does (holes, fins, welded and collapsed faces, stray parts, far
# offsets, ...), picks a metric, topology mode, count, initialization, gradation, Lloyd steps and
# accelerator setting, and runs `meshcvt cluster` with --device cpu and --device gpu. Each run must
# give the same labels, iterations, energy history and repair on both engines, or the same error
# from both. The seed is fixed: the same 100 runs every time. Without a Vulkan device it fails,
# unless MESHCVT_SKIP_GPU_TESTS=1.
# usage: gpu_damaged.sh /path/to/meshcvt /path/to/tests/data
set -euo pipefail
cli=$1
data=$2
[ "${MESHCVT_SKIP_GPU_TESTS:-}" = 1 ] && { echo "skipped: MESHCVT_SKIP_GPU_TESTS=1"; exit 0; }
source "$(dirname "$0")/prologue.bash"  # $tmp, fail
root=$(cd "$(dirname "$0")/../.." && pwd)
python3 "$root/bench/gpu_consistency_sweep.py" "$cli" 0 "$data/elephant.off" --runs 100 --seed 1 --jobs 2 \
  --timeout 600 --work "$tmp/work" >"$tmp/out" 2>&1 || fail "gpu on damaged meshes: $(cat "$tmp/out")"
grep -q "^100 runs (error [0-9]*, ok [0-9]*), 0 failed$" "$tmp/out" || fail "gpu on damaged meshes: $(cat "$tmp/out")"
# Both kinds of run happened (the seed makes it so; a change there should keep it so).
grep -q "error [1-9][0-9]*, ok [1-9]" "$tmp/out" || fail "gpu on damaged meshes: no valid or no refused run: $(cat "$tmp/out")"
echo "gpu_damaged.sh: ok"
