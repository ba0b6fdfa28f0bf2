#!/usr/bin/env bash
# File I/O benchmark: times read_mesh and build_topology on a ~1.2M-face mesh stored as binary PLY,
# OBJ, OFF and binary STL. The mesh is bunny00 (75k faces, Debian package libcgal-demo, fetched
# with apt-get download into bench/data/, which git ignores) subdivided 1-to-4 twice.
# Targets on the 2-core Debian 12 VM: binary PLY read + topology <= 0.4 s, OBJ read + topology <= 2 s.
#
# usage: bench/io_bench.sh [REPEAT]     (default 5 runs per file, best and median shown)
set -euo pipefail
cd "$(dirname "$0")/.."
repeat=${1:-5}
build=build-bench
data=bench/data
mkdir -p "$data"

if [ ! -f "$data/bunny00.off" ]; then
  tmp=$(mktemp -d)
  trap 'rm -rf "$tmp"' EXIT
  (cd "$tmp" && apt-get download libcgal-demo)
  dpkg-deb -x "$tmp"/libcgal-demo_*.deb "$tmp/deb"
  tar -xzf "$tmp/deb/usr/share/doc/libcgal-dev/data.tar.gz" -C "$tmp" data/meshes/bunny00.off
  cp "$tmp/data/meshes/bunny00.off" "$data/bunny00.off"
fi

cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DMESHCVT_TESTS=OFF >/dev/null
if grep -q "add_subdirectory(bench)" CMakeLists.txt; then
  cmake --build "$build" --target io_read_bench
  bench=$build/bench/io_read_bench
else
  # bench/ is not part of the build yet: build the library and link the program by hand.
  cmake --build "$build" --target meshcvt
  c++ -std=c++20 -O2 -Isrc bench/io_read_bench.cpp -o "$build/io_read_bench" "$build/libmeshcvt.a" \
    -ltinyobjloader_double -ldl -pthread
  bench=$build/io_read_bench
fi

if [ ! -f "$data/bunny_1m.stl" ]; then
  "$bench" make "$data/bunny00.off" "$data/bunny_1m" 1000000
fi
echo "== $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg)"
"$bench" read --repeat "$repeat" "$data/bunny_1m.ply" "$data/bunny_1m.obj" "$data/bunny_1m.off" "$data/bunny_1m.stl"
