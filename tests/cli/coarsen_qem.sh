#!/usr/bin/env bash
# CLI test of `meshcvt coarsen --vertex qem` and its fitting options, on the elephant (chi -4):
# - the default fits the coarse mesh (vertex moves and edge swaps, counted in the JSON report) and
#   the written file is a closed, consistently oriented manifold with the input's chi and exactly n
#   vertices, checked here in Python from the file;
# - --no-fit-swaps moves vertices only (swapped_edges 0) and its RMS distance is higher than the
#   default's; --fit-passes 0 does neither and is higher still;
# - without --subdivide, qem subdivides as ACVD does (20 faces per cluster: the elephant's 5558 faces
#   for 300 vertices get one level, subdivision_levels 1 in the report); --subdivide 0 keeps the
#   input as given, and `projected` does so by default;
# - --fit-swap-angle 10 (the swaps' floor before the sixteenth session) swaps more edges and leaves
#   more angles below 30 degrees than the default 30, and the report says which floor ran;
# - the report counts the qem points moved to unfold triangles (unfolded_vertices; 0 for projected);
# - --fit-min-angle 0 turns the widening of thin triangles off (angle_floor_moves 0) and leaves
#   the smallest angle no larger than the default 20 does; the report names the floor;
# - a bad --fit-passes, --fit-swap-angle or --fit-min-angle exits 2 and writes nothing;
# - -n 4500 --subdivide 2 leaves dual triangles of no area (clusters straddling the subdivided
#   input's straight edges, whose points lie on one line even with their own planes): a cluster of
#   each takes its projected point (surface_points in the report), so no defect remains and relax
#   runs (before, 4 defects remained, no relax, Q avg 0.66), and no finer clustering is tried
#   for such triangles (before, 25 iterations of them).
# usage: coarsen_qem.sh /path/to/meshcvt /path/to/tests/data
set -euo pipefail
cli=$1
data=$2
source "$(dirname "$0")/prologue.bash"  # $tmp, fail

run() {  # run NAME [options...]
  local name=$1
  shift
  "$cli" coarsen "$data/elephant.off" -n 300 --vertex qem -o "$tmp/$name.off" --report "$tmp/$name.json" -q "$@" \
    || fail "coarsen $* failed"
}
run swaps
run moves --no-fit-swaps
run none --fit-passes 0
run raw --subdivide 0
run low_floor --fit-swap-angle 10
run no_widening --fit-min-angle 0
"$cli" coarsen "$data/elephant.off" -n 300 -o "$tmp/projected.off" --report "$tmp/projected.json" -q ||
  fail "coarsen (projected) failed"

python3 - "$tmp" <<'PY' || fail "report or output check failed"
import json, sys
tmp = sys.argv[1]
r = {k: json.load(open(f"{tmp}/{k}.json")) for k in ("swaps", "moves", "none")}
assert r["swaps"]["fit_swaps"] is True and r["moves"]["fit_swaps"] is False, "fit_swaps not reported"
assert r["swaps"]["swapped_edges"] > 0 and r["swaps"]["fitted_moves"] > 0, r["swaps"]
assert r["moves"]["swapped_edges"] == 0 and r["moves"]["fitted_moves"] > 0, r["moves"]
assert r["none"]["swapped_edges"] == 0 and r["none"]["fitted_moves"] == 0, r["none"]
levels = {k: json.load(open(f"{tmp}/{k}.json"))["subdivision_levels"] for k in ("swaps", "raw", "projected")}
assert levels == {"swaps": 1, "raw": 0, "projected": 0}, levels
assert all(v["subdivision_levels"] == 1 for v in r.values()), "qem's default should subdivide"
rms = {k: v["error"]["rms"] for k, v in r.items()}
assert rms["swaps"] < rms["moves"] < rms["none"], rms
# The report says how many qem points were moved toward the surface to unfold a triangle.
projected = json.load(open(f"{tmp}/projected.json"))
assert all(isinstance(v["unfolded_vertices"], int) and v["unfolded_vertices"] >= 0 for v in r.values()), r
assert projected["unfolded_vertices"] == 0, projected["unfolded_vertices"]
# Widening the thin triangles (--fit-min-angle, default 20) never lowers the smallest angle.
off = json.load(open(f"{tmp}/no_widening.json"))
assert r["swaps"]["fit_min_angle_deg"] == 20 and off["fit_min_angle_deg"] == 0, "angle floor not reported"
assert off["angle_floor_moves"] == 0, off["angle_floor_moves"]
assert r["swaps"]["quality"]["min_angle_deg"] >= off["quality"]["min_angle_deg"], (r["swaps"]["quality"], off["quality"])
low = json.load(open(f"{tmp}/low_floor.json"))
assert r["swaps"]["fit_swap_min_angle_deg"] == 30 and low["fit_swap_min_angle_deg"] == 10, "floor not reported"
assert low["swapped_edges"] > r["swaps"]["swapped_edges"], (low["swapped_edges"], r["swaps"]["swapped_edges"])
assert low["quality"]["angles_below_30"] > r["swaps"]["quality"]["angles_below_30"], "the 10-degree floor should leave more angles below 30 than the default"

# The written default output, read back: OFF, triangles only.
lines = [l.split() for l in open(f"{tmp}/swaps.off") if l.strip() and not l.startswith("#")]
assert lines[0] == ["OFF"], lines[0]
nv, nf = int(lines[1][0]), int(lines[1][1])
faces = [tuple(map(int, l[1:4])) for l in lines[2 + nv:2 + nv + nf]]
assert nv == 300, nv
directed = set()
for a, b, c in faces:
    assert len({a, b, c}) == 3, (a, b, c)
    for e in ((a, b), (b, c), (c, a)):
        assert e not in directed, f"directed edge {e} twice: orientation or manifold broken"
        directed.add(e)
assert all((b, a) in directed for a, b in directed), "an edge with one triangle: not closed"
edges = len(directed) // 2
used = len({v for f in faces for v in f})
assert used == 300, used
assert used - edges + nf == -4, used - edges + nf
PY

if "$cli" coarsen "$data/elephant.off" -n 300 --vertex qem --fit-passes -1 -o "$tmp/bad.off" 2>"$tmp/err"; then
  fail "--fit-passes -1 accepted"
fi
[ ! -e "$tmp/bad.off" ] || fail "--fit-passes -1 wrote a file"
for option in --fit-swap-angle --fit-min-angle; do
  for angle in -1 61 nan; do
    rc=0
    "$cli" coarsen "$data/elephant.off" -n 300 --vertex qem "$option" "$angle" -o "$tmp/bad.off" 2>"$tmp/err" || rc=$?
    [ "$rc" -eq 2 ] || fail "$option $angle: exit $rc, not 2"
    grep -q -- "${option#--}" "$tmp/err" || fail "$option $angle: message does not name the option: $(cat "$tmp/err")"
    [ ! -e "$tmp/bad.off" ] || fail "$option $angle wrote a file"
  done
done

# qem asked for more vertices than the input has: a note says what to expect and what suits better;
# below that, nothing is said.
"$cli" coarsen "$data/elephant.off" -n 2775 --vertex qem --subdivide 0 -o "$tmp/fine.off" --no-error \
  >"$tmp/out" 2>"$tmp/err" || fail "qem -> 2775: $(cat "$tmp/err")"
grep -q "^meshcvt: note: .*elephant.off: --vertex qem with n = 2775, not below the input's 2775 vertices: .*projected" \
  "$tmp/err" || fail "qem -> 2775: no note: $(cat "$tmp/err")"
"$cli" coarsen "$data/elephant.off" -n 2774 --vertex qem --subdivide 0 -o "$tmp/fine.off" --no-error \
  >"$tmp/out" 2>"$tmp/err" || fail "qem -> 2774: $(cat "$tmp/err")"
grep -q "not below the input" "$tmp/err" && fail "qem -> 2774: note: $(cat "$tmp/err")"
# Degenerate triangles left by the fix rounds: one cluster's point goes to the surface.
"$cli" coarsen "$data/elephant.off" -n 4500 --subdivide 2 --vertex qem -o "$tmp/straddle.off" --no-error \
  --report "$tmp/straddle.json" >"$tmp/out" 2>"$tmp/err" || fail "qem -> 4500: $(cat "$tmp/err")"
grep -q "defects remain" "$tmp/err" && fail "qem -> 4500: defects remain: $(cat "$tmp/err")"
python3 - "$tmp/straddle.json" <<'PY' || fail "qem -> 4500: report check failed"
import json, sys
r = json.load(open(sys.argv[1]))
assert r["subdivision_levels"] == 2, r["subdivision_levels"]
assert r["fix_loop"]["initial_defects"] > 0, "the case no longer starts with degenerate triangles"
assert r["defects"] == [] and r["output"]["vertices"] == 4500, (r["defects"], r["output"])
assert r["surface_points"] > 0 and r["relaxed_moves"] > 0, (r["surface_points"], r["relaxed_moves"])
assert r["quality"]["q_avg"] > 0.75, r["quality"]
# No finer clustering was tried for them (the elephant is one component of 88928 faces, above
# max_face_start_faces): no fix iterations at all.
assert r["fix_loop"]["iterations"] == 0, r["fix_loop"]
PY
echo ok
