#!/usr/bin/env bash
# `meshcvt coarsen --gradation g` and `--subdivide auto|K` on real meshes (bench/RESULTS.md, section
# "Coarsening: gradation and subdivision"). Builds the CLI in release mode, then:
#   1. fandisk -> 1000, bunny00 -> 500, refined_elephant -> 1000 with g = 0, 1, 2: quality and
#      distance to the input measured by /work/shared/tools/meshstats.py (independent of meshcvt),
#      and the mean coarse edge length in the input's high- vs low-curvature parts
#      (bench/edge_by_curvature.py, also independent);
#   2. coarse inputs (cow 5.8k faces -> 1000, pig 891 faces -> 300) without and with --subdivide auto;
#   3. the time of curvature_density next to build_topology, 75k to 4.8M faces (bench/density_bench.cpp).
# Meshes: bench/data/meshes (bench/fetch_meshes.sh) and bench/data/bunny-1.2M.ply (bench/io_bench.sh).
#
# usage: bench/gradation_bench.sh      environment: BUILD (default build-bench), OUT (default
#        /tmp/meshcvt-gradation), TOOLS (default /work/shared/tools)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${BUILD:-build-bench}
out=${OUT:-/tmp/meshcvt-gradation}
tools=${TOOLS:-/work/shared/tools}
meshes=bench/data/meshes
mkdir -p "$out"

echo "== build ($build, release)"
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j 2 --target meshcvt_cli meshcvt >/dev/null
cli=$build/meshcvt
echo "== machine: $(nproc) cores, $(uname -m); load average now: $(cut -d' ' -f1-3 /proc/loadavg)"

# row MESH N LABEL COARSE REPORT: one table row from the CLI's report and meshstats.py.
row() {
  local stats
  stats=$(/usr/bin/python3 "$tools/meshstats.py" "$4" --ref "$meshes/$1.off")
  python3 - "$5" "$stats" "$1" "$2" "$3" <<'PY'
import json, sys
r, stats = json.load(open(sys.argv[1])), json.loads(sys.argv[2])
s = {}
def flatten(d):
    for k, v in d.items():
        flatten(v) if isinstance(v, dict) else s.setdefault(k, v)
flatten(stats)
print(f"| {sys.argv[3]} -> {sys.argv[4]} | {sys.argv[5]} | {r['subdivision_levels']} | {s['vertices']} | "
      f"{s['euler_characteristic']} ({r['output']['input_euler_characteristic']}), {'yes' if s['closed_manifold'] else 'no'} | "
      f"{s['min_angle_deg']:.1f} | {s['avg_min_angle_deg']:.1f} | {s['angles_below_30']} | "
      f"{s['q_min']:.3f} | {s['q_avg']:.3f} | {s['hausdorff_rel']:.4f} | {s['rms_rel']:.5f} | "
      f"{len(r['defects'])} | {r['timings_s']['cluster']:.3f} s |")
PY
}

header="| input -> n | options | levels | vertices | chi (input), closed manifold | min angle | avg min angle | angles < 30 | Q min | Q avg | Hausdorff | RMS | defects | cluster time |"
rule="|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"

echo "== 1. gradation"
echo "$header"
echo "$rule"
for spec in "fandisk 1000" "bunny00 500" "refined_elephant 1000"; do
  set -- $spec
  for g in 0 1 2; do
    "$cli" coarsen "$meshes/$1.off" -n "$2" -o "$out/$1-g$g.off" --gradation "$g" --no-error -q \
      --report "$out/$1-g$g.json"
    row "$1" "$2" "--gradation $g" "$out/$1-g$g.off" "$out/$1-g$g.json"
  done
done
for m in fandisk bunny00 refined_elephant; do
  /usr/bin/python3 bench/edge_by_curvature.py "$meshes/$m.off" "$out/$m-g0.off" "$out/$m-g1.off" "$out/$m-g2.off"
done

echo "== 2. subdivision of coarse inputs"
echo "$header"
echo "$rule"
for spec in "cow 1000" "pig 300"; do
  set -- $spec
  for s in 0 auto; do
    "$cli" coarsen "$meshes/$1.off" -n "$2" -o "$out/$1-s$s.off" --subdivide "$s" --no-error -q \
      --report "$out/$1-s$s.json"
    row "$1" "$2" "--subdivide $s" "$out/$1-s$s.off" "$out/$1-s$s.json"
  done
done

echo "== 3. time of curvature_density (bench/density_bench.cpp)"
g++ -std=c++20 -O2 -ffp-contract=off -Isrc bench/density_bench.cpp "$build/libmeshcvt.a" \
  -ltinyobjloader_double -lpthread -ldl -o "$build/density_bench"
for m in "$meshes/bunny00.off" bench/data/bunny-1.2M.ply bench/data/bunny-4.8M.ply; do
  [ -f "$m" ] && "$build/density_bench" "$m" 3
done
echo "== load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
