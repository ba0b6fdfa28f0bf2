#!/usr/bin/env bash
# CLI test of `meshcvt coarsen --split-edges R`: a closed cylinder whose side is made of long thin
# triangles running its whole height and whose caps are fans (a CAD export's triangulation, made here
# in Python). Without the option the command must print the note naming the long edges; with it the
# report must count the split edges and the refined faces, the output must stay a closed manifold of
# n vertices with chi 2, and its triangles must be better (Q avg) than without. The split is the
# same from run to run (same bytes). A bad ratio is exit 2 with a message naming the option.
# usage: coarsen_split_edges.sh /path/to/meshcvt
set -euo pipefail
cli=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

python3 - "$tmp/cylinder.off" <<'PY'
import math, sys
k, r, h = 48, 1.0, 6.0  # 48 sides, 6 high: each side triangle is 6 x 0.13
v = [(r * math.cos(2 * math.pi * i / k), r * math.sin(2 * math.pi * i / k), z) for z in (0.0, h) for i in range(k)]
v += [(0.0, 0.0, 0.0), (0.0, 0.0, h)]
bottom, top = 2 * k, 2 * k + 1
f = []
for i in range(k):
    j = (i + 1) % k
    f += [(i, j, k + j), (i, k + j, k + i)]      # side, outward
    f += [(bottom, j, i), (top, k + i, k + j)]   # caps, outward
with open(sys.argv[1], 'w') as out:
    out.write(f"OFF\n{len(v)} {len(f)} 0\n")
    out.writelines(f"{x:.7f} {y:.7f} {z:.7f}\n" for x, y, z in v)
    out.writelines(f"3 {a} {b} {c}\n" for a, b, c in f)
PY

n=60
"$cli" coarsen "$tmp/cylinder.off" -n $n -o "$tmp/plain.off" --device cpu --no-error --report "$tmp/plain.json" \
  >/dev/null 2>"$tmp/plain.err" || fail "plain run failed: $(cat "$tmp/plain.err")"
grep -q "edges are longer than the coarse mesh's edges" "$tmp/plain.err" || fail "no note about long edges: $(cat "$tmp/plain.err")"
grep -q -- "--split-edges 1.5" "$tmp/plain.err" || fail "the note does not name the option"
"$cli" coarsen "$tmp/cylinder.off" -n $n -o "$tmp/split.off" --device cpu --no-error --split-edges 1.5 \
  --report "$tmp/split.json" >"$tmp/split.out" 2>"$tmp/split.err" || fail "split run failed: $(cat "$tmp/split.err")"
grep -q "edges are longer" "$tmp/split.err" && fail "note printed although the edges were split"
grep -q "split [0-9]* edges longer than" "$tmp/split.out" || fail "no split line: $(cat "$tmp/split.out")"
"$cli" coarsen "$tmp/cylinder.off" -n $n -o "$tmp/again.off" --device cpu --no-error --split-edges 1.5 -q
cmp -s "$tmp/split.off" "$tmp/again.off" || fail "two runs with --split-edges gave different meshes"

python3 - "$tmp/plain.json" "$tmp/split.json" "$tmp/split.off" $n <<'PY' || fail "report or output check failed"
import json, sys
plain, split = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
n = int(sys.argv[4])
assert plain['split_edges'] == 0 and plain['long_edges'] >= n, (plain['split_edges'], plain['long_edges'])
assert split['split_edges'] > 0 and split['split_edges_ratio'] == 1.5
assert split['faces'] > plain['faces'] == 192, (split['faces'], plain['faces'])
for r in (plain, split):
    o = r['output']
    assert o['vertices'] == n and o['euler_characteristic'] == 2 and o['boundary_loops'] == 0, o
    assert o['nonmanifold_edges'] == 0 and not r['defects'], r['defects']
assert split['quality']['q_avg'] > plain['quality']['q_avg'] + 0.05, (plain['quality'], split['quality'])
assert split['quality']['angles_below_30'] < plain['quality']['angles_below_30'], (plain['quality'], split['quality'])
# the output file: n vertices, closed (every edge twice, once each way)
tok = open(sys.argv[3]).read().split()
nv, nf = int(tok[1]), int(tok[2])
assert nv == n
faces = [tuple(int(x) for x in tok[4 + 3 * nv + 4 * i + 1:4 + 3 * nv + 4 * i + 4]) for i in range(nf)]
directed = {}
for f in faces:
    for i in range(3):
        e = (f[i], f[(i + 1) % 3])
        directed[e] = directed.get(e, 0) + 1
assert all(c == 1 and (b, a) in directed for (a, b), c in directed.items()), "not a closed oriented manifold"
PY

for bad in -1 17 nan; do
  if "$cli" coarsen "$tmp/cylinder.off" -n $n -o "$tmp/bad.off" --split-edges "$bad" 2>"$tmp/bad.err"; then
    fail "--split-edges $bad accepted"
  fi
  grep -q -- "--split-edges" "$tmp/bad.err" || fail "message for --split-edges $bad: $(cat "$tmp/bad.err")"
  [ ! -e "$tmp/bad.off" ] || fail "--split-edges $bad wrote an output"
done
echo "coarsen_split_edges: ok"
