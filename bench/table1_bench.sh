#!/usr/bin/env bash
# The paper's Table 1 columns for `meshcvt coarsen` on real meshes, one markdown row per mesh and
# vertex placement: whole job wall time (read + cluster + fixes + coarsen + write, as a user runs
# it, measured outside the process), its clustering and coarsening parts, topology in and out, the
# quality columns and the distance to the input. Results go to bench/RESULTS.md ("Table 1").
#
# Meshes: libcgal-demo's bunny00 -> 500, fandisk -> 1000, refined_elephant -> 1000 (fetched by
# bench/fetch_meshes.sh), a 131k-face UV sphere -> 200 (generated here), the subdivided bunny
# (bench/data/bunny-1.2M.ply, bunny-4.8M.ply) -> 10000 when present.
# usage: bench/table1_bench.sh [path/to/meshcvt] [placements...]   (default: closest projected qem)
set -euo pipefail
cd "$(dirname "$0")/.."
meshcvt=${1:-build/meshcvt}
shift || true
placements=("$@")
[ ${#placements[@]} -gt 0 ] || placements=(closest projected qem)
bench/fetch_meshes.sh "$meshcvt" >/dev/null
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

sphere=bench/data/sphere-131k.off
if [ ! -f "$sphere" ]; then  # 256 x 256 quads split in two, poles fanned: 131072 triangles
  python3 - "$sphere" <<'PY'
import math, sys
nu, nv = 256, 257
verts, faces = [(0.0, 0.0, 1.0)], []
for j in range(1, nv - 1):
    t = math.pi * j / (nv - 1)
    for i in range(nu):
        p = 2 * math.pi * i / nu
        verts.append((math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)))
verts.append((0.0, 0.0, -1.0))
ring = lambda j, i: 1 + (j - 1) * nu + i % nu
for i in range(nu):
    faces.append((0, ring(1, i), ring(1, i + 1)))
for j in range(1, nv - 2):
    for i in range(nu):
        a, b, c, d = ring(j, i), ring(j, i + 1), ring(j + 1, i), ring(j + 1, i + 1)
        faces += [(a, c, d), (a, d, b)]
last = len(verts) - 1
for i in range(nu):
    faces.append((last, ring(nv - 2, i + 1), ring(nv - 2, i)))
with open(sys.argv[1], "w") as f:
    f.write(f"OFF\n{len(verts)} {len(faces)} 0\n")
    f.writelines(f"{x:.7f} {y:.7f} {z:.7f}\n" for x, y, z in verts)
    f.writelines(f"3 {a} {b} {c}\n" for a, b, c in faces)
PY
fi

cases=(bench/data/meshes/bunny00.off 500 bench/data/meshes/fandisk.off 1000
       bench/data/meshes/refined_elephant.off 1000 "$sphere" 200)
[ -f bench/data/bunny-1.2M.ply ] && cases+=(bench/data/bunny-1.2M.ply 10000)
[ -f bench/data/bunny-4.8M.ply ] && cases+=(bench/data/bunny-4.8M.ply 10000)

echo "machine: $(nproc) cores, $(uname -m); load average before: $(cut -d' ' -f1-3 /proc/loadavg)"
echo
echo "| mesh | faces | n | vertex | V out | chi in/out | loops in/out | manifold | fixes | min angle | avg min angle | angles < 30 | Q min | Q avg | Hausdorff % diag | RMS % diag | job s | cluster s | coarsen s |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
for ((i = 0; i < ${#cases[@]}; i += 2)); do
  mesh=${cases[i]} n=${cases[i + 1]}
  for v in "${placements[@]}"; do
    # whole job timed on its own (no error measurement), then the same run again with the error
    start=$(date +%s.%N)
    "$meshcvt" coarsen "$mesh" -n "$n" --vertex "$v" -o "$out/c.ply" --no-error -q
    end=$(date +%s.%N)
    "$meshcvt" coarsen "$mesh" -n "$n" --vertex "$v" -o "$out/c.ply" --report "$out/r.json" -q
    python3 - "$out/r.json" "$mesh" "$v" "$start" "$end" <<'PY'
import json, sys
r = json.load(open(sys.argv[1])); o = r["output"]; q = r["quality"]; e = r["error"]; t = r["timings_s"]
manifold = "yes" if o["nonmanifold_edges"] == 0 and o["nonmanifold_vertices"] == 0 else "no"
print(f"| {sys.argv[2].split('/')[-1]} | {r['faces']} | {r['clusters']} | {sys.argv[3]} | {o['vertices']} | "
      f"{o['input_euler_characteristic']}/{o['euler_characteristic']} | {o['input_boundary_loops']}/{o['boundary_loops']} | "
      f"{manifold} | {r['fix_loop']['fixes']} | {q['min_angle_deg']:.1f} | {q['avg_min_angle_deg']:.1f} | {q['angles_below_30']} | "
      f"{q['q_min']:.3f} | {q['q_avg']:.3f} | {100 * e['hausdorff_rel']:.3f} | {100 * e['rms_rel']:.4f} | "
      f"{float(sys.argv[5]) - float(sys.argv[4]):.3f} | {t['cluster']:.3f} | {t['coarsen']:.3f} |")
PY
  done
done
echo
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
