#!/usr/bin/env bash
# CLI test: damaged meshes through the whole pipeline. bench/pipeline_stress.py damages the elephant
# (holes, duplicated and flipped faces, fins on non-manifold edges, collapsed faces, welded and
# coinciding vertices, stray small parts, far offsets and extreme scales, unreferenced vertices,
# NaN coordinates, truncation; one to three at a time), writes it as OBJ, OFF, PLY or STL, and runs
# `coarsen`, `cluster` or `approximate` on it with a random count and options. Each run must exit 0
# with its outputs complete (coarsen: exactly n vertices unless it warned of defects), or exit 1 or
# 2 with an error naming the input, no internal error, no output and no temporary file left; never
# a signal, a sanitizer report or a timeout. The seed is fixed: the same 60 runs every time.
# usage: damaged_meshes.sh /path/to/meshcvt /path/to/tests/data
set -euo pipefail
cli=$1
data=$2
source "$(dirname "$0")/prologue.bash"  # $tmp, fail
root=$(cd "$(dirname "$0")/../.." && pwd)
python3 "$root/bench/pipeline_stress.py" "$cli" 0 --runs 60 --seed 1 --light --timeout 600 --work "$tmp/work" \
  "$data/elephant.off" >"$tmp/out" 2>&1 || fail "damaged meshes: $(cat "$tmp/out")"
grep -q "^60 runs, 0 failures; error [0-9]*, ok [0-9]*$" "$tmp/out" || fail "damaged meshes: $(cat "$tmp/out")"
# Both kinds of run happened (the seed makes it so; a change there should keep it so).
grep -q "error [1-9][0-9]*, ok [1-9]" "$tmp/out" || fail "damaged meshes: no valid or no refused run: $(cat "$tmp/out")"
echo "damaged_meshes.sh: ok"
