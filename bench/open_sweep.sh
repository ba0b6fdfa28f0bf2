#!/usr/bin/env bash
# The boundary step of `meshcvt coarsen` (CoarsenOptions::boundary_onto_input) on open surfaces:
# the 34 libcgal-demo meshes with a boundary, each at n = faces/23, faces/60 and 60 (n >= 8), with
# the default command and with --no-boundary-snap (or with two binaries), one line per run, then a
# summary: angles below 30 degrees in all, mean Q avg, and the ratios of the Hausdorff and RMS
# distances between the two (quartiles, best, worst, how many fell or rose). Runs that fail with either (n too
# small for a component) are left out. Results go to bench/RESULTS.md ("Coarsening: open
# surfaces' boundaries").
# usage: bench/open_sweep.sh MESHCVT [MESHCVT_B]   (needs bench/fetch_meshes.sh)
#   one binary: A = --no-boundary-snap, B = default; two: A = the first, B = the second (defaults).
set -euo pipefail
cd "$(dirname "$0")/.."
a_bin=$1
b_bin=${2:-$1}
a_flags=()
[ $# -lt 2 ] && a_flags=(--no-boundary-snap)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
meshes=(ALSTOM_TEST4 ChineseDragon-10kv b9_mesh blade blob blobby_3cc corner_tris_with_hole corner_with_hole cylinder
        cylinder_locally_refined double-torus-3-holes elephant-with-holes head holes horizons lion lion-head
        mannequin-devil mask_cone mech-holes-shark mesh_with_border mushroom nefertiti patch-01 patch-13 patch-20
        patch-21 patch-23 patch-30 pig plane "poly2x^2+y^2-0.062500" polygon_mesh three_peaks)
run() {  # tag bin mesh n flags...
  local tag=$1 bin=$2 mesh=$3 n=$4
  shift 4
  if "$bin" coarsen "$mesh" -n "$n" -o "$work/$tag.off" -q --report "$work/$tag.json" "$@" 2>/dev/null; then
    python3 -c "
import json, sys
r = json.load(open(sys.argv[1])); q = r['quality']; e = r['error']
print('%.2f %d %.4f %.4f %.4f' % (q['min_angle_deg'], q['angles_below_30'], q['q_avg'], 100 * e['hausdorff_rel'], 100 * e['rms_rel']))
" "$work/$tag.json"
  else
    echo "-"
  fi
}
: >"$work/rows"
for b in "${meshes[@]}"; do
  m=bench/data/meshes/$b.off
  [ -f "$m" ] || continue
  faces=$(awk 'NR > 1 && !/^#/ && NF >= 2 { print $2; exit }' "$m")
  for n in $((faces / 23)) $((faces / 60)) 60; do
    [ "$n" -ge 8 ] || continue
    ra=$(run a "$a_bin" "$m" "$n" "${a_flags[@]}")
    rb=$(run b "$b_bin" "$m" "$n")
    echo "$b $n | $ra | $rb" | tee -a "$work/rows"
  done
done
python3 - "$work/rows" <<'PY'
import math, sys
rows = []
for line in open(sys.argv[1]):
    name, a, b = [x.strip() for x in line.split("|")]
    if a == "-" or b == "-":
        continue
    rows.append((name, [float(x) for x in a.split()], [float(x) for x in b.split()]))
h = sorted(b[3] / a[3] for _, a, b in rows if a[3] > 0)
r = sorted(b[4] / a[4] for _, a, b in rows if a[4] > 0)
q = lambda v, f: v[min(len(v) - 1, int(f * len(v)))]
print(f"{len(rows)} runs; angles below 30: A {sum(a[1] for _, a, _ in rows):.0f}, B {sum(b[1] for _, _, b in rows):.0f}; "
      f"mean Q avg A {sum(a[2] for _, a, _ in rows) / len(rows):.4f}, B {sum(b[2] for _, _, b in rows) / len(rows):.4f}")
for name, v in (("Hausdorff", h), ("RMS", r)):
    print(f"B / A {name}: quartiles {q(v, 0.25):.3f} {q(v, 0.5):.3f} {q(v, 0.75):.3f}, best {v[0]:.3g}, worst {v[-1]:.3f}; "
          f"lower by 10% or more in {sum(x <= 0.9 for x in v)}, higher by 1% or more in {sum(x >= 1.01 for x in v)}")
print("runs where B's smallest angle is below min(A's, 30):",
      sum(1 for _, a, b in rows if b[0] < min(a[0], 30) - 1e-9))
PY
