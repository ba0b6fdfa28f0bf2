#!/usr/bin/env bash
# `--vertex qem` (or $PLACEMENT: projected, closest) on every mesh bench/fetch_meshes.sh fetched
# (libcgal-demo's data/meshes), two binaries side by side: n = faces / 40 (at most 1000; meshes under 800 faces are skipped), then
# `meshcvt stats OUT --ref IN`. Prints one row per mesh (angles below 30 degrees, Q avg, RMS % of
# the diagonal, smallest angle, defects left, for each binary) and a summary: total angles below
# 30, mean Q avg, the median smallest angle and the meshes whose smallest angle is below 5 and 10
# degrees, the median, smallest and largest RMS ratio NEW / BASE and the meshes above 1.2. A mesh either
# binary refuses (an error exit) is listed with its message; meshes `meshcvt info` cannot read are
# skipped. Results go to bench/RESULTS.md ("meshcvt against ACVD").
# usage: [PLACEMENT=projected] bench/qem_sweep.sh BASE NEW [EXTRA OPTIONS...]
#        (needs bench/fetch_meshes.sh once)
set -euo pipefail
cd "$(dirname "$0")/.."
base=$1 new=$2
shift 2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for mesh in bench/data/meshes/*.off bench/data/meshes/*.ply; do
  [ -f "$mesh" ] || continue
  faces=$("$new" info "$mesh" --json 2>/dev/null | python3 -c "import json, sys; print(json.load(sys.stdin)['faces'])" 2>/dev/null) || continue
  n=$((faces / 40))
  [ "$n" -gt 1000 ] && n=1000
  [ "$n" -lt 20 ] && continue
  row="$(basename "$mesh") $n"
  for bin in "$base" "$new"; do
    if ! "$bin" coarsen "$mesh" -n "$n" -o "$work/out.ply" -q --vertex "${PLACEMENT:-qem}" --no-error --report "$work/r.json" "$@" \
        2>"$work/err"; then
      echo "$row ERROR $(head -c 120 "$work/err" | tr '\n' ' ')" >>"$work/rows"
      continue 2
    fi
    "$bin" stats "$work/out.ply" --ref "$mesh" --json >"$work/s.json"
    row="$row $(python3 -c "
import json, sys
r, s = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
print(r['quality']['angles_below_30'], r['quality']['q_avg'], 100 * s['error']['rms_rel'], len(r['defects']),
      r['quality']['min_angle_deg'])" \
      "$work/r.json" "$work/s.json")"
  done
  echo "$row" >>"$work/rows"
done
python3 - "$work/rows" <<'PY'
import statistics as st, sys
rows = [l.split() for l in open(sys.argv[1])]
print(f"{'mesh':<34} {'n':>5}  {'<30 base/new':>13}  {'Q avg base/new':>15}  {'RMS % base/new':>17}  "
      f"{'min angle':>11}  defects")
ratios, below, q, smallest = [], [0, 0], [[], []], [[], []]
for r in rows:
    if len(r) != 12:
        print(" ".join(r))
        continue
    name, n = r[0], int(r[1])
    b = (int(r[2]), float(r[3]), float(r[4]), int(r[5]), float(r[6]))
    w = (int(r[7]), float(r[8]), float(r[9]), int(r[10]), float(r[11]))
    print(f"{name:<34} {n:>5}  {b[0]:>6}/{w[0]:<6}  {b[1]:.3f}/{w[1]:.3f}  {b[2]:.4f}/{w[2]:.4f}  "
          f"{b[4]:5.1f}/{w[4]:<5.1f}  {b[3]}/{w[3]}")
    below[0] += b[0]; below[1] += w[0]; q[0].append(b[1]); q[1].append(w[1])
    smallest[0].append(b[4]); smallest[1].append(w[4])
    if b[2] > 0: ratios.append((w[2] / b[2], name))
ratios.sort()
print(f"meshes {len(q[0])}; angles below 30: {below[0]} -> {below[1]}; mean Q avg {st.mean(q[0]):.3f} -> {st.mean(q[1]):.3f}")
print(f"smallest angle: median {st.median(smallest[0]):.1f} -> {st.median(smallest[1]):.1f} degrees; meshes below "
      f"5 degrees {sum(a < 5 for a in smallest[0])} -> {sum(a < 5 for a in smallest[1])}, below 10 "
      f"{sum(a < 10 for a in smallest[0])} -> {sum(a < 10 for a in smallest[1])}")
print(f"RMS new/base: median {st.median(r for r, _ in ratios):.3f}, smallest {ratios[0][0]:.3f} ({ratios[0][1]}), "
      f"largest {ratios[-1][0]:.3f} ({ratios[-1][1]}); above 1.2: {[f'{m} {r:.2f}' for r, m in ratios if r > 1.2]}")
PY
