#!/usr/bin/env bash
# CLI test of `meshcvt approximate` (L2,1 shape approximation): on the real elephant mesh (closed,
# genus 3) the output triangle mesh is checked here independently (plain Python over the OFF file:
# every edge in exactly two triangles, in opposite directions; counts agree with the report and the
# polygon file), --max-error meets its bound, runs are deterministic, and bad usage fails with exit
# code 2 (1 for a missing file) without leaving any output file.
# usage: approximate.sh /path/to/meshcvt /path/to/tests/data
set -euo pipefail
cli=$1
data=$2
source "$(dirname "$0")/prologue.bash"  # $tmp, fail
py=python3
[ -x /usr/bin/python3 ] && py=/usr/bin/python3

# -n: triangle mesh (OFF), polygons (OBJ), partition (PLY), labels and report.
"$cli" approximate "$data/elephant.off" -n 40 --device cpu -o "$tmp/out.off" --polygons "$tmp/poly.obj" \
  --partition "$tmp/part.ply" --labels "$tmp/labels.txt" --report "$tmp/r.json" -q
for f in out.off poly.obj part.ply labels.txt r.json; do [ -s "$tmp/$f" ] || fail "$f not written"; done
# The labels: one region id per input face (the OFF's face count), as in the partition's per-face
# property, as many distinct ids as regions.
ply_face_ids "$tmp/part.ply" >"$tmp/part-ids.txt" || fail "cannot read the partition's ids"
cmp -s "$tmp/part-ids.txt" "$tmp/labels.txt" || fail "--labels does not match --partition"
$py - "$tmp/labels.txt" "$tmp/r.json" "$data/elephant.off" <<'PY' || fail "--labels: count or regions"
import json, sys
labels = [int(x) for x in open(sys.argv[1]).read().split()]
assert len(labels) == int(open(sys.argv[3]).read().split()[2]), len(labels)
assert len(set(labels)) == json.load(open(sys.argv[2]))["regions"]
PY
$py - "$tmp/out.off" "$tmp/poly.obj" "$tmp/r.json" <<'PY' || fail "output check (elephant, -n 40)"
import json, sys
tok = []
for line in open(sys.argv[1]):
    tok += line.split('#')[0].split()
nv, nf = int(tok[1]), int(tok[2])
k = 4 + 3 * nv
tris = []
for _ in range(nf):
    assert int(tok[k]) == 3
    tris.append(tuple(int(x) for x in tok[k + 1:k + 4])); k += 4
directed = {}
for a, b, c in tris:
    assert len({a, b, c}) == 3, "degenerate triangle"
    for e in ((a, b), (b, c), (c, a)):
        directed[e] = directed.get(e, 0) + 1
assert all(n == 1 for n in directed.values()), "an edge used twice in the same direction"
assert all((b, a) in directed for (a, b) in directed), "an edge with one triangle: not closed"
r = json.load(open(sys.argv[3]))
assert r["output"]["triangles"] == nf and r["output"]["vertices"] == nv
assert r["output"]["boundary_edges"] == 0 and r["output"]["nonmanifold_edges"] == 0
assert r["regions"] >= 40 and r["partition"]["proxies"] == 40
assert 0 < r["relative_error"] < 4
# one polygon per region, each n-gon triangulated into n - 2 of the output triangles
faces = [l.split()[1:] for l in open(sys.argv[2]) if l.startswith('f ')]
verts = [l for l in open(sys.argv[2]) if l.startswith('v ')]
assert len(faces) == r["regions"], (len(faces), r["regions"])
assert len(verts) == nv
assert sum(len(f) - 2 for f in faces) == nf
kinds = {f["kind"] for f in r["fixes"]}
assert kinds <= {"split_region", "loop_anchors", "polygon_anchor", "duplicate_chord", "fallback_triangulation",
                 "anchor_position", "flip_anchor", "flipped_triangles", "split_curved", "skipped_region",
                 "solid_component"}, kinds
PY

# Deterministic: the same command gives the same bytes.
"$cli" approximate "$data/elephant.off" -n 40 --device cpu -o "$tmp/again.off" -q
cmp -s "$tmp/out.off" "$tmp/again.off" || fail "two runs differ"

# --max-error: the report's E/A meets the bound, after rounds that each add proxies.
"$cli" approximate "$data/elephant.off" --max-error 0.15 --device cpu -o "$tmp/err.ply" --report "$tmp/e.json" -q
$py - "$tmp/e.json" <<'PY' || fail "--max-error 0.15 not met"
import json, sys
r = json.load(open(sys.argv[1]))
assert r["relative_error"] <= 0.15, r["relative_error"]
rounds = r["partition"]["rounds"]
assert rounds and rounds[-1]["relative_error"] <= 0.15
assert all(a["proxies"] < b["proxies"] for a, b in zip(rounds, rounds[1:]))
PY

# The summary line names the counts, and where the regions beyond the proxies come from (the
# report's split fixes): with 12 proxies on the elephant, regions too curved for one polygon and
# regions that are not disks.
out=$("$cli" approximate "$data/elephant.off" -n 12 --device cpu -o "$tmp/s.obj" --report "$tmp/s.json")
echo "$out" | grep -q "regions" || fail "no summary line: $out"
$py - "$out" "$tmp/s.json" <<'PY' || fail "summary line against the report: $out"
import json, re, sys
r = json.load(open(sys.argv[2]))
fixes = r["fixes"]
curved = sum(f["kind"] == "split_curved" for f in fixes)
disks = sum(f.get("count", 0) for f in fixes if f["kind"] == "split_region")
solid = sum(f["kind"] == "solid_component" for f in fixes)
assert curved > 0 and disks > 0, (curved, disks)
assert r["regions"] == 12 + curved + disks + solid
m = re.search(r"-> (\d+) regions \(12 proxies; split off: (\d+) as too curved for one polygon, (\d+) as not disks\)",
              sys.argv[1])
assert m, "no split counts"
assert [int(x) for x in m.groups()] == [r["regions"], curved, disks]
PY

# Bad usage: exit 2, nothing written.
expect_fail() {
  local code=$1; shift
  set +e
  "$cli" approximate "$@" 2>"$tmp/err.txt" >/dev/null
  local got=$?
  set -e
  [ "$got" = "$code" ] || fail "expected exit $code, got $got for: $* ($(cat "$tmp/err.txt"))"
  grep -q "meshcvt: error:" "$tmp/err.txt" || fail "no error message for: $*"
}
expect_fail 2 "$data/elephant.off" -n 10 --max-error 0.1 -o "$tmp/bad.off"
expect_fail 2 "$data/elephant.off" -o "$tmp/bad.off"
expect_fail 2 "$data/elephant.off" --max-error -1 -o "$tmp/bad.off"
expect_fail 2 "$data/elephant.off" -n 0 -o "$tmp/bad.off"
expect_fail 2 "$data/elephant.off" -n 100000 -o "$tmp/bad.off"
expect_fail 2 "$data/elephant.off" -n 10 --chord-error -0.5 -o "$tmp/bad.off"
expect_fail 2 "$data/elephant.off" -n 10 --chord-rule vsa -o "$tmp/bad.off"
expect_fail 2 "$data/elephant.off" -n 10 -o "$tmp/bad.off" --polygons "$tmp/bad.stl"
expect_fail 2 "$data/elephant.off" -n 10 -o "$tmp/bad.xyz"
expect_fail 1 "$tmp/missing.off" -n 10 -o "$tmp/bad.off"
grep -q "missing.off" "$tmp/err.txt" || fail "the error does not name the missing file"
ls "$tmp" | grep -q "^bad" && fail "a failed run left a file: $(ls "$tmp" | grep "^bad")"

# Faces with a repeated corner (welded slivers): left out with a note, each given the region of a
# face at a corner; the output is the plain elephant's.
$py "$(dirname "$0")/with_collapsed_faces.py" "$data/elephant.off" "$tmp/collapsed.off" 7
"$cli" approximate "$tmp/collapsed.off" -n 40 --device cpu -o "$tmp/collapsed-out.off" --report "$tmp/collapsed.json" \
  2>"$tmp/err.txt" >/dev/null || fail "collapsed faces: $(cat "$tmp/err.txt")"
grep -q "note: .*collapsed.off: left out 7 faces with a repeated corner" "$tmp/err.txt" ||
  fail "no note on the collapsed faces: $(cat "$tmp/err.txt")"
cmp -s "$tmp/collapsed-out.off" "$tmp/out.off" || fail "collapsed faces: not the plain elephant's output"
$py -c 'import json, sys; assert json.load(open(sys.argv[1]))["collapsed_faces"] == 7' "$tmp/collapsed.json" ||
  fail "collapsed faces: report"
echo "approximate CLI: ok"
