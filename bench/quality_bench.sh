#!/usr/bin/env bash
# Benchmark for mesh quality, the triangle BVH and approximation_error (see bench/quality_bench.cpp).
# Builds the library (release) in build-bench/, compiles the benchmark against it (with Embree for
# comparison when libembree-dev is installed: it is not a dependency of meshcvt), fetches CGAL's demo
# meshes (Debian libcgal-demo, never committed) and runs:
#   - fandisk (12.9k faces), bunny00 (75k) and refined_elephant (89k): quality, BVH build, queries
#   - a bumpy icosphere subdivided 8 times (1.3M faces) and 9 times (5.2M faces): BVH build and
#     queries; approximation_error of a 20k-face icosphere against the 5.2M one;
#   - bunny00 split 3 times (4.8M faces, the same surface): approximation_error of bunny00 against it.
# usage: bench/quality_bench.sh [--quick]   (--quick: skip the 5.2M-face runs)
#        environment: MESHCVT_BENCH_DATA (download cache, default /tmp/meshcvt-bench-data)
set -euo pipefail
cd "$(dirname "$0")/.."
quick=0
[ "${1:-}" = "--quick" ] && quick=1

cmake -S . -B build-bench -G Ninja -DCMAKE_BUILD_TYPE=Release -DMESHCVT_TESTS=OFF >/dev/null
cmake --build build-bench --target meshcvt >/dev/null

embree=()
if [ -f /usr/include/embree3/rtcore.h ]; then embree=(-DWITH_EMBREE -lembree3); fi
c++ -std=c++20 -O2 -DNDEBUG -ffp-contract=off -Isrc bench/quality_bench.cpp build-bench/libmeshcvt.a \
  -ltinyobjloader_double -pthread -ldl "${embree[@]}" -o build-bench/quality_bench

# CGAL's demo meshes (data.tar.gz inside Debian's libcgal-demo): downloaded and unpacked into a
# cache outside the tree (shared with the other benchmarks), never committed.
data=${MESHCVT_BENCH_DATA:-/tmp/meshcvt-bench-data}
meshes="$data/d/data/meshes"
if [ ! -f "$meshes/bunny00.off" ]; then
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

echo "== machine: $(nproc) cores, $(lscpu | sed -n 's/^Model name: *//p')"
for m in fandisk bunny00 refined_elephant; do
  echo "== $m"
  build-bench/quality_bench "$meshes/$m.off"
done
echo "== icosphere, 8 subdivisions"
build-bench/quality_bench sphere:8
if [ "$quick" = 0 ]; then
  echo "== icosphere, 9 subdivisions, and a 20k-face icosphere against it"
  build-bench/quality_bench sphere:9 sphere:5
  echo "== bunny00 subdivided 3 times (4.8M faces), and bunny00 against it"
  build-bench/quality_bench "subdiv:3:$meshes/bunny00.off" "$meshes/bunny00.off"
fi
