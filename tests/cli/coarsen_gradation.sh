#!/usr/bin/env bash
# CLI test of `meshcvt coarsen --subdivide auto|K --gradation g`:
# - an icosahedron (20 faces) cannot give 30 vertices as it is (exit 2, with --split-edges off: by
#   default every one of its edges is longer than the coarse edge and split), but with --subdivide auto it
#   is subdivided twice (20 * 16 = 320 >= 10 * 30 faces) and gives exactly 30 vertices, a closed
#   oriented manifold with chi = 2, checked here in Python from the written file; the JSON report
#   says 2 levels; --subdivide K gives K levels where auto gives another count;
# - --gradation 1 on the elephant gives exactly n vertices, the JSON report carries the gradation,
#   and the output differs from --gradation 0;
# - bad values of either option exit 2 with a message naming the accepted values, and write nothing.
# usage: coarsen_gradation.sh /path/to/meshcvt /path/to/tests/data
set -euo pipefail
cli=$1
data=$2
source "$(dirname "$0")/prologue.bash"  # $tmp, fail

cat >"$tmp/ico.off" <<'EOF'
OFF
12 20 0
-0.525731 0.850651 0
0.525731 0.850651 0
-0.525731 -0.850651 0
0.525731 -0.850651 0
0 -0.525731 0.850651
0 0.525731 0.850651
0 -0.525731 -0.850651
0 0.525731 -0.850651
0.850651 0 -0.525731
0.850651 0 0.525731
-0.850651 0 -0.525731
-0.850651 0 0.525731
3 0 11 5
3 0 5 1
3 0 1 7
3 0 7 10
3 0 10 11
3 1 5 9
3 5 11 4
3 11 10 2
3 10 7 6
3 7 1 8
3 3 9 4
3 3 4 2
3 3 2 6
3 3 6 8
3 3 8 9
3 4 9 5
3 2 4 11
3 6 2 10
3 8 6 7
3 9 8 1
EOF

# closed_manifold OFF N: exactly N referenced vertices, every edge in exactly two triangles with
# opposite directions, no zero-area triangle, V - E + F = 2.
closed_manifold() {
  python3 - "$1" "$2" <<'PY'
import math, sys
path, n = sys.argv[1], int(sys.argv[2])
tok = []
for line in open(path):
    tok += line.split('#')[0].split()
nv, nf = int(tok[1]), int(tok[2])
p = [tuple(float(x) for x in tok[4 + 3 * i: 7 + 3 * i]) for i in range(nv)]
k, tris = 4 + 3 * nv, []
for _ in range(nf):
    assert int(tok[k]) == 3, "not a triangle"
    tris.append(tuple(int(x) for x in tok[k + 1: k + 4])); k += 4
used = {v for t in tris for v in t}
if len(used) != n:
    sys.exit(f"{path}: {len(used)} referenced vertices, expected {n}")
directed = {}
for a, b, c in tris:
    for u, v in ((a, b), (b, c), (c, a)):
        directed[(u, v)] = directed.get((u, v), 0) + 1
    e1 = [p[b][i] - p[a][i] for i in range(3)]; e2 = [p[c][i] - p[a][i] for i in range(3)]
    cr = (e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0])
    if math.sqrt(sum(x * x for x in cr)) == 0:
        sys.exit(f"{path}: zero-area triangle {a} {b} {c}")
for (u, v), count in directed.items():
    if count != 1 or directed.get((v, u), 0) != 1:
        sys.exit(f"{path}: edge {u}-{v} is not one triangle each way")
edges = len(directed) // 2
if len(used) - edges + len(tris) != 2:
    sys.exit(f"{path}: chi = {len(used) - edges + len(tris)}, expected 2")
PY
}

json_check() {  # json_check FILE PYTHON_EXPR (d = the report)
  python3 -c 'import json, sys; d = json.load(open(sys.argv[1])); sys.exit(0 if eval("(" + sys.argv[2] + ")") else "not true: " + sys.argv[2] + "\n" + json.dumps(d))' "$1" "$2"
}

# ---- too coarse without --subdivide (and with --split-edges off, which would refine its long
# edges): 30 clusters from 20 faces is refused
set +e
"$cli" coarsen "$tmp/ico.off" -n 30 -o "$tmp/plain.off" --split-edges off >/dev/null 2>"$tmp/err"
rc=$?
set -e
[ $rc -eq 2 ] || fail "20 faces -> 30 vertices without --subdivide: expected exit 2, got $rc"
[ ! -e "$tmp/plain.off" ] || fail "a refused run left an output file"
grep -q "30 vertices from the 20 faces" "$tmp/err" || fail "the refusal should name the numbers: $(cat "$tmp/err")"
grep -q -- "--subdivide auto" "$tmp/err" || fail "the refusal should name the remedy: $(cat "$tmp/err")"

# ---- --subdivide auto: 2 levels, exactly 30 vertices, a valid closed mesh
"$cli" coarsen "$tmp/ico.off" -n 30 -o "$tmp/auto.off" --subdivide auto --report "$tmp/auto.json" >"$tmp/out" ||
  fail "coarsen --subdivide auto failed"
grep -q "subdivided 2 times -> 320 faces" "$tmp/out" || fail "summary does not give the subdivision: $(cat "$tmp/out")"
closed_manifold "$tmp/auto.off" 30 || fail "--subdivide auto: output is not a valid closed mesh with 30 vertices"
json_check "$tmp/auto.json" 'd["subdivision_levels"] == 2 and d["input_faces"] == 20 and d["faces"] == 320 and
  d["gradation"] == 0 and d["output"]["vertices"] == 30' || fail "--subdivide auto: report"

# ---- both together: the density of the 20 input faces is handed down to their 320 children
"$cli" coarsen "$tmp/ico.off" -n 30 -o "$tmp/both.off" --subdivide auto --gradation 2 --report "$tmp/both.json" -q ||
  fail "coarsen --subdivide auto --gradation 2 failed"
closed_manifold "$tmp/both.off" 30 || fail "--subdivide auto --gradation 2: not a valid closed mesh with 30 vertices"
json_check "$tmp/both.json" 'd["subdivision_levels"] == 2 and d["gradation"] == 2 and d["faces"] == 320' ||
  fail "--subdivide auto --gradation 2: report"

# ---- --subdivide K: exactly K levels, even when auto would pick another count
"$cli" coarsen "$tmp/ico.off" -n 8 -o "$tmp/k2.off" --subdivide 2 --report "$tmp/k2.json" -q || fail "--subdivide 2 failed"
json_check "$tmp/k2.json" 'd["subdivision_levels"] == 2 and d["faces"] == 320 and d["output"]["vertices"] == 8' ||
  fail "--subdivide 2: report"
"$cli" coarsen "$tmp/ico.off" -n 8 -o "$tmp/auto8.off" --subdivide auto --report "$tmp/auto8.json" -q ||
  fail "--subdivide auto (n = 8) failed"
json_check "$tmp/auto8.json" 'd["subdivision_levels"] == 1 and d["faces"] == 80' ||
  fail "--subdivide auto (n = 8): 20 * 4 = 80 >= 10 * 8 needs exactly 1 level"

# ---- --gradation on a real mesh: exactly n vertices, reported, and it changes the result
elephant=$data/elephant.off
"$cli" coarsen "$elephant" -n 300 -o "$tmp/g0.off" --no-error -q || fail "gradation 0 failed"
"$cli" coarsen "$elephant" -n 300 -o "$tmp/g1.off" --no-error --gradation 1 --report "$tmp/g1.json" >"$tmp/out" ||
  fail "gradation 1 failed"
grep -q "gradation 1" "$tmp/out" || fail "summary does not give the gradation: $(cat "$tmp/out")"
json_check "$tmp/g1.json" 'd["gradation"] == 1 and d["subdivision_levels"] == 0 and d["output"]["vertices"] == 300' ||
  fail "gradation 1: report"
! cmp -s "$tmp/g0.off" "$tmp/g1.off" || fail "--gradation 1 gives the same mesh as --gradation 0"

# ---- bad values: exit 2, a message naming what is accepted, no output
bad() {  # bad PATTERN ARGS...
  local pattern=$1
  shift
  set +e
  "$cli" coarsen "$tmp/ico.off" -n 10 -o "$tmp/bad.off" "$@" >/dev/null 2>"$tmp/err"
  local rc=$?
  set -e
  [ $rc -eq 2 ] || fail "$*: expected exit 2, got $rc"
  grep -q "^meshcvt: error: .*$pattern" "$tmp/err" || fail "$*: message: $(cat "$tmp/err")"
  [ ! -e "$tmp/bad.off" ] || fail "$*: left an output file"
}
bad "auto or a number of levels 0..6, not '7'" --subdivide 7
bad "auto or a number of levels 0..6, not '-1'" --subdivide=-1
bad "auto or a number of levels 0..6, not 'x'" --subdivide x
bad "auto or a number of levels 0..6, not '1.5'" --subdivide 1.5
bad "gradation must be a finite number >= 0" --gradation=-1
bad "gradation must be a finite number >= 0" --gradation nan
bad "gradation must be a finite number >= 0" --gradation inf
bad "gradation" --gradation abc
echo "coarsen_gradation.sh: ok"
