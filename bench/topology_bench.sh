#!/usr/bin/env bash
# Benchmark for reading + build_topology (`meshcvt info`) and midpoint subdivision
# (`meshcvt subdivide`). Builds the CLI and the library (release) in build-bench-topo/, compiles
# bench/topology_bench.cpp against it, fetches CGAL's demo meshes (Debian libcgal-demo, downloaded
# with apt-get download and unpacked here, never committed) and:
#   - info on fandisk (12.9k faces), bunny00 (75k) and refined_elephant (89k);
#   - subdivide bunny00 with -k 2 (1.2M faces) and -k 3 (4.8M faces) to binary PLY, timing the
#     subdivision itself and the whole command;
#   - info on those two, and on the 1.2M mesh with its faces shuffled (no locality at all);
#   - topology_bench on the same: best wall and best CPU time of build_topology alone (CPU time:
#     both threads together, what the work costs even when the machine is shared).
# Each info line is the best of $REPS runs (default 5) of read ms / topology ms as info reports them.
# usage: bench/topology_bench.sh [--quick]   (--quick: skip the 4.8M-face mesh)
set -euo pipefail
cd "$(dirname "$0")/.."
quick=0
[ "${1:-}" = "--quick" ] && quick=1
reps=${REPS:-5}

cmake -S . -B build-bench-topo -G Ninja -DCMAKE_BUILD_TYPE=Release -DMESHCVT_TESTS=OFF >/dev/null
cmake --build build-bench-topo --target meshcvt_cli meshcvt >/dev/null
cli=build-bench-topo/meshcvt
c++ -std=c++20 -O3 -DNDEBUG -ffp-contract=off -Isrc bench/topology_bench.cpp build-bench-topo/libmeshcvt.a \
  -ltinyobjloader_double -pthread -ldl -o build-bench-topo/topology_bench

meshes=build-bench-topo/cgal/data/meshes
if [ ! -f "$meshes/bunny00.off" ]; then
  rm -rf build-bench-topo/cgal && mkdir -p build-bench-topo/cgal
  (cd build-bench-topo/cgal && apt-get download libcgal-demo >/dev/null 2>&1 && dpkg-deb -x libcgal-demo_*.deb pkg &&
     tar -xzf pkg/usr/share/doc/libcgal-dev/data.tar.gz data/meshes)
  [ -f "$meshes/bunny00.off" ] || { echo "bunny00.off not found in libcgal-demo" >&2; exit 1; }
fi
work=build-bench-topo/work
mkdir -p "$work"

# best_info FILE: best read and topology times over $reps runs of `meshcvt info --json`.
best_info() {
  for _ in $(seq "$reps"); do "$cli" info "$1" --json >"$work/info-$_.json"; done
  python3 - "$(basename "$1")" "$work"/info-*.json <<'PY'
import json, sys
runs = [json.load(open(p)) for p in sys.argv[2:]]
d = runs[0]
read = min(r["timings_ms"]["read"] for r in runs)
topo = min(r["timings_ms"]["topology"] for r in runs)
print("%-28s %9d faces  read %8.1f ms  topology %8.1f ms  components %d  genus %d"
      % (sys.argv[1], d["faces"], read, topo, d["components"], d["genus"]))
PY
  rm -f "$work"/info-*.json
}

echo "== machine: $(nproc) cores, $(lscpu | sed -n 's/^Model name: *//p'), load $(cut -d' ' -f1-3 /proc/loadavg)"
echo "== info (best of $reps)"
for m in fandisk bunny00 refined_elephant; do best_info "$meshes/$m.off"; done

echo "== subdivide"
levels=(2)
[ "$quick" = 0 ] && levels+=(3)
for k in "${levels[@]}"; do
  start=$(date +%s.%N)
  "$cli" subdivide "$meshes/bunny00.off" -k "$k" -o "$work/bunny00-k$k.ply"
  echo "   whole command: $(python3 -c "print(f'{$(date +%s.%N) - $start:.3f}')") s"
done

echo "== info on subdivided meshes (best of $reps)"
for k in "${levels[@]}"; do best_info "$work/bunny00-k$k.ply"; done
# The same 1.2M faces in random order: every vertex's faces are far apart in memory.
python3 - "$work/bunny00-k2.ply" "$work/bunny00-k2-shuffled.ply" <<'PY'
import random, struct, sys
data = open(sys.argv[1], "rb").read()
end = data.index(b"end_header\n") + len(b"end_header\n")
header = data[:end].decode()
nv = int(header.split("element vertex ")[1].split()[0])
nf = int(header.split("element face ")[1].split()[0])
vprops = header.split("element vertex")[1].split("element face")[0].count("property")
assert "property list uchar int vertex_indices" in header and header.count("property") == vprops + 1, header
vbytes = nv * 4 * vprops
faces = [data[end + vbytes + 13 * i: end + vbytes + 13 * (i + 1)] for i in range(nf)]
random.Random(1).shuffle(faces)
open(sys.argv[2], "wb").write(data[:end + vbytes] + b"".join(faces) + data[end + vbytes + 13 * nf:])
PY
best_info "$work/bunny00-k2-shuffled.ply"

echo "== build_topology alone (best of $reps): wall and CPU"
build-bench-topo/topology_bench "$meshes/bunny00.off" 0 "$reps"
build-bench-topo/topology_bench "$meshes/refined_elephant.off" 0 "$reps"
for k in "${levels[@]}"; do build-bench-topo/topology_bench "$meshes/bunny00.off" "$k" "$reps"; done
build-bench-topo/topology_bench "$work/bunny00-k2-shuffled.ply" 0 "$reps"
echo "== load at the end: $(cut -d' ' -f1-3 /proc/loadavg)"
