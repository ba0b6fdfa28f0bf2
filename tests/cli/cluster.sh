#!/usr/bin/env bash
# CLI test of `meshcvt cluster`: outputs (PLY with cluster ids, labels file, JSON report), the
# labels' meaning checked independently (exactly n ids, every cluster edge-connected), polygons in
# the input expanded in order, clean errors for bad options and bad files, and --gradation (more
# clusters where a strip bends).
# Usage: cluster.sh /path/to/meshcvt /path/to/tests/data
set -u
meshcvt=$1
data=$2
fail() { echo "FAIL: $*" >&2; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

"$meshcvt" cluster "$data/elephant.off" -n 50 -o "$tmp/out.ply" --labels "$tmp/labels.txt" \
  --report "$tmp/report.json" --device cpu >"$tmp/stdout" 2>"$tmp/stderr" || fail "cluster failed: $(cat "$tmp/stderr")"
[ -s "$tmp/out.ply" ] || fail "no output mesh"
grep -q "50 clusters" "$tmp/stdout" || fail "summary line missing: $(cat "$tmp/stdout")"
ls "$tmp" | grep -q tmp && fail "a temporary file was left behind"

python3 - "$data/elephant.off" "$tmp/labels.txt" "$tmp/report.json" "$tmp/out.ply" <<'PY' || fail "output check failed"
import json, sys
off, labels_path, report_path, ply = sys.argv[1:]
# faces from the OFF file itself (independent of meshcvt's reader)
tokens = [t for line in open(off) for t in line.split('#')[0].split()]
assert tokens[0] == 'OFF'
nv, nf = int(tokens[1]), int(tokens[2])
pos = 4 + 3 * nv
faces = []
for _ in range(nf):
    k = int(tokens[pos]); faces.append([int(x) for x in tokens[pos + 1:pos + 1 + k]]); pos += 1 + k
labels = [int(l) for l in open(labels_path)]
assert len(labels) == nf, (len(labels), nf)
assert sorted(set(labels)) == list(range(50)), "not exactly 50 cluster ids"
# every cluster edge-connected (across edges shared by exactly two faces)
edges = {}
for f, fv in enumerate(faces):
    for i in range(3):
        e = tuple(sorted((fv[i], fv[(i + 1) % 3])))
        edges.setdefault(e, []).append(f)
parent = list(range(nf))
def find(x):
    while parent[x] != x:
        parent[x] = parent[parent[x]]; x = parent[x]
    return x
for fs in edges.values():
    if len(fs) == 2 and labels[fs[0]] == labels[fs[1]]:
        parent[find(fs[0])] = find(fs[1])
pieces = len({(labels[f], find(f)) for f in range(nf)})
assert pieces == 50, f"{pieces} pieces for 50 clusters"
r = json.load(open(report_path))
assert r['faces'] == nf and r['options']['clusters'] == 50
assert r['iterations'] == len(r['history']) - 1
energies = [h['energy'] for h in r['history'] if h['round'] == 0]
assert all(b <= a * (1 + 1e-9) for a, b in zip(energies, energies[1:])), "energy rose"
assert r['device'].startswith('cpu')
t = r['timings_s']
assert 0 < t['init_lloyd'] <= t['init'] <= t['cluster_total'], t  # the elephant takes Lloyd steps
assert t['topology'] > 0, t
head = open(ply, 'rb').read(400).decode('latin1')
assert 'property int cluster' in head and 'property uchar red' in head, head
PY

# polygons: a quad mesh gives one label per triangle, in the input's order (quad -> 2 triangles)
cat >"$tmp/quads.obj" <<'OBJ'
v 0 0 0
v 1 0 0
v 2 0 0
v 0 1 0
v 1 1 0
v 2 1 0
v 0 2 0
v 1 2 0
v 2 2 0
f 1 2 5 4
f 2 3 6 5
f 4 5 8 7
f 5 6 9 8
OBJ
"$meshcvt" cluster "$tmp/quads.obj" -n 2 -o "$tmp/q.ply" --labels "$tmp/q.txt" -q || fail "quad mesh failed"
[ "$(wc -l <"$tmp/q.txt")" -eq 8 ] || fail "quad mesh: expected 8 triangle labels"

# same result with 1 and 2 threads
"$meshcvt" cluster "$data/elephant.off" -n 50 -o "$tmp/t1.ply" --labels "$tmp/t1.txt" --threads 1 -q || fail "threads 1"
cmp -s "$tmp/t1.txt" "$tmp/labels.txt" || fail "labels differ between 1 and default threads"

# errors: exit 2 for bad usage, 1 for bad files; messages name the problem; no output left behind
"$meshcvt" cluster "$data/elephant.off" -n 0 -o "$tmp/bad.ply" 2>"$tmp/err"; rc=$?
[ $rc -eq 2 ] || fail "-n 0: expected exit 2, got $rc"
grep -q "^meshcvt: error:" "$tmp/err" || fail "-n 0: no error line"
"$meshcvt" cluster "$data/elephant.off" -n 99999999 -o "$tmp/bad.ply" 2>"$tmp/err"; rc=$?
[ $rc -eq 2 ] || fail "-n too large: expected exit 2, got $rc"
grep -q "^meshcvt: error: .*elephant.off: cannot make 99999999 clusters" "$tmp/err" ||
  fail "-n too large: the message does not name the file: $(cat "$tmp/err")"
grep -q "5558 faces" "$tmp/err" || fail "-n too large: message should name the face count: $(cat "$tmp/err")"
"$meshcvt" cluster "$data/elephant.off" -n 10 --metric nonsense -o "$tmp/bad.ply" 2>"$tmp/err"; rc=$?
[ $rc -eq 2 ] || fail "bad metric: expected exit 2, got $rc"
"$meshcvt" cluster "$tmp/missing.off" -n 10 -o "$tmp/bad.ply" 2>"$tmp/err"; rc=$?
[ $rc -eq 1 ] || fail "missing file: expected exit 1, got $rc"
grep -q "missing.off" "$tmp/err" || fail "missing file: message should name the file"
[ ! -e "$tmp/bad.ply" ] || fail "an output was written despite the error"
# Faces with a repeated corner (welded slivers): left out with a note; all n clusters are the
# surface's, and each collapsed face takes the cluster of a face at one of its corners.
python3 "$(dirname "$0")/with_collapsed_faces.py" "$data/elephant.off" "$tmp/collapsed.off" 7
"$meshcvt" cluster "$tmp/collapsed.off" -n 50 -o "$tmp/collapsed.ply" --labels "$tmp/collapsed.txt" --device cpu \
  >/dev/null 2>"$tmp/err" || fail "collapsed faces: $(cat "$tmp/err")"
grep -q "note: .*collapsed.off: left out 7 faces with a repeated corner" "$tmp/err" ||
  fail "no note on the collapsed faces: $(cat "$tmp/err")"
python3 - "$tmp/collapsed.off" "$tmp/collapsed.txt" <<'PY' || fail "collapsed faces: labels"
import sys
tok = open(sys.argv[1]).read().split()
nv, nf = int(tok[1]), int(tok[2])
faces = [tuple(int(x) for x in tok[4 + 3 * nv + 4 * k + 1: 4 + 3 * nv + 4 * k + 4]) for k in range(nf)]
labels = [int(x) for x in open(sys.argv[2]).read().split()]
assert len(labels) == nf
surface = nf - 7
assert len(set(labels[:surface])) == 50, len(set(labels[:surface]))  # every cluster has faces with area
for f in range(surface, nf):
    corners = set(faces[f])
    assert any(labels[g] == labels[f] and corners & set(faces[g]) for g in range(surface)), f
PY
# --gradation g: a strip whose first half is flat and whose second half bends through half a turn
# (the same length: area of each half 1 x 1). Uniform, the halves get about the same clusters; at
# g = 2 the bent half gets more. The report carries the value; l21 and bad values are refused.
python3 - "$tmp/bend.off" <<'PY'
import math, sys
nx, ny = 60, 20
r = 1 / math.pi
v = []
for i in range(nx + 1):
    u = 2 * i / nx
    x, z = (u, 0.0) if u <= 1 else (1 + r * math.sin((u - 1) * math.pi), r * (1 - math.cos((u - 1) * math.pi)))
    for j in range(ny + 1):
        v.append((x, j / ny, z))
f = []
for i in range(nx):  # faces of column i, in order: the first nx / 2 columns are flat
    for j in range(ny):
        a, b, c, d = i * (ny + 1) + j, (i + 1) * (ny + 1) + j, (i + 1) * (ny + 1) + j + 1, i * (ny + 1) + j + 1
        f += [(a, b, c), (a, c, d)]
with open(sys.argv[1], 'w') as out:
    out.write(f"OFF\n{len(v)} {len(f)} 0\n")
    out.writelines(f"{x:.7f} {y:.7f} {z:.7f}\n" for x, y, z in v)
    out.writelines(f"3 {a} {b} {c}\n" for a, b, c in f)
PY
for g in 0 2; do
  "$meshcvt" cluster "$tmp/bend.off" -n 40 -o "$tmp/bend-$g.ply" --labels "$tmp/bend-$g.txt" --gradation $g \
    --report "$tmp/bend-$g.json" --device cpu -q || fail "--gradation $g failed"
done
python3 - "$tmp/bend-0.txt" "$tmp/bend-2.txt" "$tmp/bend-2.json" <<'PY' || fail "--gradation: clusters not denser where the strip bends"
import json, sys
def bent_clusters(path):
    labels = [int(x) for x in open(path)]
    half = len(labels) // 2  # faces of the bent half come last
    count = {}
    for f, l in enumerate(labels):
        count.setdefault(l, [0, 0])[f >= half] += 1
    assert len(count) == 40
    return sum(1 for flat, bent in count.values() if bent > flat)
uniform, graded = bent_clusters(sys.argv[1]), bent_clusters(sys.argv[2])
print(f"clusters on the bent half: uniform {uniform}, g = 2 {graded}")
assert 14 <= uniform <= 26, uniform
assert graded >= uniform + 5, (uniform, graded)
assert json.load(open(sys.argv[3]))['options']['gradation'] == 2
PY
for bad in "--gradation -1" "--gradation nan" "--gradation 1 --metric l21"; do
  "$meshcvt" cluster "$tmp/bend.off" -n 40 -o "$tmp/bad.ply" $bad 2>"$tmp/err" && fail "accepted: $bad"
  grep -q -- "--gradation" "$tmp/err" || fail "message for $bad: $(cat "$tmp/err")"
  [ ! -e "$tmp/bad.ply" ] || fail "$bad wrote an output"
done

echo "cluster CLI: all checks passed"
