#!/usr/bin/env bash
# Uniform coarsening benchmark (bench/coarsen_bench.cpp): builds the library in release mode,
# fetches CGAL's sample meshes (Debian package libcgal-demo; never committed), and times
# coarsen_clustering for each vertex placement:
#   1. bunny00 (75k faces) -> 1000 clusters, labels from the CPU engine (coarsening vs clustering);
#   2. bunny00 subdivided 3 times (4.8M faces) -> 10k clusters, labels from region growing, with the
#      vertex numbering subdivision leaves and with vertices renumbered by first use;
#   3. with COARSEN_BENCH_BIG_ENGINE=1 also 2. with labels from the engine (minutes on 2 cores).
# Numbers go to bench/RESULTS.md, section "Uniform coarsening".
#   4. the fix loop of coarsen_mesh (bench/coarsen_fix_bench.cpp): bunny00 -> 500, fandisk -> 1000,
#      refined_elephant -> 1000, a 131k-face sphere -> 200, bunny-1.2M -> 10000 (when
#      bench/data/bunny-1.2M.ply exists), and the elephant of tests/data at 20, 50, 300, 500: defects
#      before and after, fixes, rounds, chi / boundary loops / parts in and out, time of the loop.
#      Numbers go to bench/RESULTS.md, section "Coarsening: topology fixes". COARSEN_FIX_ONLY=1 runs
#      only this part; COARSEN_FIX_OUT=DIR keeps the coarse meshes.
#
# usage: bench/coarsen_bench.sh [REPEATS]     environment: BUILD (default build-bench),
#        MESHCVT_BENCH_DATA (download cache, default /tmp/meshcvt-bench-data)
set -euo pipefail
cd "$(dirname "$0")/.."
repeats=${1:-5}
build=${BUILD:-build-bench}
data=${MESHCVT_BENCH_DATA:-/tmp/meshcvt-bench-data}

mesh="$data/d/data/meshes/bunny00.off"
[ -f bench/data/meshes/bunny00.off ] && mesh=bench/data/meshes/bunny00.off  # bench/fetch_meshes.sh
if [ ! -f "$mesh" ]; then
  echo "== fetching libcgal-demo (sample meshes) into $data"
  mkdir -p "$data"
  (
    cd "$data"
    apt-get download libcgal-demo >/dev/null
    dpkg-deb -x libcgal-demo_*.deb x
    mkdir -p d
    tar xzf x/usr/share/doc/libcgal-dev/data.tar.gz -C d data/meshes
  )
fi

echo "== build ($build, release)"
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j "$(nproc)" --target meshcvt >/dev/null
g++ -std=c++20 -O2 -ffp-contract=off -Isrc bench/coarsen_bench.cpp "$build/libmeshcvt.a" \
  -ltinyobjloader_double -lpthread -ldl -o "$build/coarsen_bench"

g++ -std=c++20 -O2 -ffp-contract=off -Isrc bench/coarsen_fix_bench.cpp "$build/libmeshcvt.a" \
  -ltinyobjloader_double -lpthread -ldl -o "$build/coarsen_fix_bench"

echo "== machine: $(nproc) cores, $(uname -m); load average now: $(cut -d' ' -f1-3 /proc/loadavg)"
meshes=$(dirname "$mesh")
fix_cases=("$meshes/bunny00.off" 500 "$meshes/fandisk.off" 1000 "$meshes/refined_elephant.off" 1000 sphere:7 200)
[ -f bench/data/bunny-1.2M.ply ] && fix_cases+=(bench/data/bunny-1.2M.ply 10000)
fix_cases+=(tests/data/elephant.off 20 tests/data/elephant.off 50 tests/data/elephant.off 300 tests/data/elephant.off 500)
# harder cases: 26 closed parts, an open surface with 7 holes, a knot, a genus-2 "8", and a
# non-manifold input (65 non-manifold vertices: nothing can be guaranteed there)
fix_cases+=("$meshes/bones.off" 300 "$meshes/holes.off" 30 "$meshes/holes.off" 100 "$meshes/knot1.off" 100
            "$meshes/eight.off" 20 "$meshes/elephant-with-holes.off" 300)
echo "== coarsen_mesh fix loop"
"$build/coarsen_fix_bench" "${fix_cases[@]}"
echo "== load average after the fix loop rows: $(cut -d' ' -f1-3 /proc/loadavg)"
[ "${COARSEN_FIX_ONLY:-0}" = 1 ] && exit 0

echo "== bunny00 -> 1000 clusters (engine labels)"
"$build/coarsen_bench" "$mesh" 0 1000 engine "$repeats"
echo "== bunny00 x 4^3 = 4.8M faces -> 10k clusters (region-growing labels)"
"$build/coarsen_bench" "$mesh" 3 10000 grow "$repeats"
"$build/coarsen_bench" "$mesh" 3 10000 grow "$repeats" first-use
if [ "${COARSEN_BENCH_BIG_ENGINE:-0}" = 1 ]; then
  echo "== bunny00 x 4^3 = 4.8M faces -> 10k clusters (engine labels)"
  "$build/coarsen_bench" "$mesh" 3 10000 engine "$repeats"
fi
echo "== load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
