#!/usr/bin/env bash
# CLI test of `meshcvt cluster`: outputs (PLY with cluster ids, labels file, JSON report), the
# labels' meaning checked independently (exactly n ids, every cluster edge-connected), polygons in
# the input expanded in order, and clean errors for bad options and bad files.
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
echo "cluster CLI: all checks passed"
