#!/usr/bin/env bash
# CLI test of `meshcvt coarsen --labels FILE` and `--partition FILE.ply`: one coarse vertex id per input face, in the input's
# face order, checked in Python from the files:
# - the elephant -> 200: one line per face, ids below n, every id used, and each coarse vertex lies
#   near the faces labelled with it (within a mean coarse edge of their centroid, half of them
#   within a quarter; measured: 0.61 and 0.12 at most), so the ids are the output's vertex numbers;
# - the same with --subdivide 1: still one line per input face (the clustered faces are 4x), and
#   --partition writes the input mesh with the same ids per face;
# - an OBJ of quads: one line per triangle the quads expand into;
# - faces with a repeated corner (left out of the clustering): a line each all the same.
# usage: coarsen_labels.sh /path/to/meshcvt /path/to/tests/data
set -euo pipefail
cli=$1
data=$2
source "$(dirname "$0")/prologue.bash"  # $tmp, fail

check() {  # mesh.off coarse.off labels n [check_nearness]
  python3 - "$@" <<'PY' || fail "labels check failed for $3"
import sys
mesh, coarse, labels, n, near = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4]), sys.argv[5] == "1"
def read_off(p):
    t = open(p).read().split()
    nv, nf = int(t[1]), int(t[2])
    v = [tuple(map(float, t[4 + 3 * i:7 + 3 * i])) for i in range(nv)]
    pos, f = 4 + 3 * nv, []
    for _ in range(nf):
        k = int(t[pos]); f.append([int(x) for x in t[pos + 1:pos + 1 + k]]); pos += 1 + k
    return v, f
V, F = read_off(mesh)
CV, CF = read_off(coarse)
L = [int(x) for x in open(labels).read().split()]
assert len(L) == len(F), f"{len(L)} labels for {len(F)} faces"
assert all(0 <= l < n for l in L), "an id out of range"
assert len(set(L)) == n, f"{len(set(L))} of {n} ids used"
if near:
    edges = {(min(a, b), max(a, b)) for f in CF for a, b in zip(f, f[1:] + f[:1])}
    mean_edge = sum(sum((CV[a][d] - CV[b][d]) ** 2 for d in range(3)) ** 0.5 for a, b in edges) / len(edges)
    sums = [[0.0, 0.0, 0.0, 0] for _ in range(n)]
    for f, l in zip(F, L):
        for d in range(3):
            sums[l][d] += sum(V[i][d] for i in f) / len(f)
        sums[l][3] += 1
    dists = []
    for i in range(n):
        c = [sums[i][d] / sums[i][3] for d in range(3)]
        dists.append(sum((c[d] - CV[i][d]) ** 2 for d in range(3)) ** 0.5)
        assert dists[-1] < mean_edge, f"vertex {i} is {dists[-1]} from its faces, mean edge {mean_edge}"
    dists.sort()
    assert dists[n // 2] < 0.25 * mean_edge, f"median distance {dists[n // 2]}, mean edge {mean_edge}"
PY
}

"$cli" coarsen "$data/elephant.off" -n 200 -o "$tmp/e.off" --labels "$tmp/e.txt" --device cpu --no-error -q ||
  fail "coarsen --labels failed"
check "$data/elephant.off" "$tmp/e.off" "$tmp/e.txt" 200 1
"$cli" coarsen "$data/elephant.off" -n 200 -o "$tmp/s.off" --labels "$tmp/s.txt" --subdivide 1 --device cpu --no-error -q \
  --partition "$tmp/s.ply" || fail "coarsen --labels --subdivide 1 failed"
check "$data/elephant.off" "$tmp/s.off" "$tmp/s.txt" 200 1
# --partition: the input mesh (its faces, in order) with the same ids as a per-face property.
ply_face_ids "$tmp/s.ply" >"$tmp/s-ids.txt" || fail "cannot read the partition's ids"
cmp -s "$tmp/s-ids.txt" "$tmp/s.txt" || fail "--partition does not match --labels"

# A 12 x 12 grid of quads in an OBJ: 288 triangles, so 288 lines.
python3 - "$tmp/quads.obj" "$tmp/quads.off" <<'PY'
import sys
k = 12
with open(sys.argv[1], 'w') as obj, open(sys.argv[2], 'w') as off:
    off.write(f"OFF\n{(k + 1) ** 2} {2 * k * k} 0\n")
    for j in range(k + 1):
        for i in range(k + 1):
            obj.write(f"v {i} {j} 0\n")
            off.write(f"{i} {j} 0\n")
    for j in range(k):
        for i in range(k):
            a = j * (k + 1) + i + 1  # OBJ counts from 1
            obj.write(f"f {a} {a + 1} {a + k + 2} {a + k + 1}\n")
            off.write(f"3 {a - 1} {a} {a + k + 1}\n3 {a - 1} {a + k + 1} {a + k}\n")
PY
"$cli" coarsen "$tmp/quads.obj" -n 20 -o "$tmp/q.off" --labels "$tmp/q.txt" --device cpu --no-error -q ||
  fail "coarsen --labels on quads failed"
check "$tmp/quads.off" "$tmp/q.off" "$tmp/q.txt" 20 0

# Two faces with a repeated corner after the elephant's: they get a line each, with an id in range.
off_with_extra "$data/elephant.off" "$tmp/collapsed.off" "" $'3 0 0 1\n3 5 6 6'
"$cli" coarsen "$tmp/collapsed.off" -n 200 -o "$tmp/c.off" --labels "$tmp/c.txt" --device cpu --no-error -q ||
  fail "coarsen --labels with collapsed faces failed"
faces=$(python3 -c "import sys; print(int(open(sys.argv[1]).read().split()[2]))" "$tmp/collapsed.off")
[ "$(wc -l <"$tmp/c.txt")" = "$faces" ] || fail "$(wc -l <"$tmp/c.txt") labels for $faces faces"
# The first faces are the elephant's: the same labels as without the collapsed ones.
cmp -s <(head -n "$(wc -l <"$tmp/e.txt")" "$tmp/c.txt") "$tmp/e.txt" || fail "collapsed faces changed the others' labels"
echo "ok"
