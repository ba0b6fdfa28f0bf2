#!/usr/bin/env bash
# CLI test of the locality order (meshcvt/mesh_order.h): meshes of 2^18 faces or more are
# clustered in Morton order, and every output still comes in the input's order.
# - the elephant (5558 faces) subdivided 3 times (355,712 faces, children of a face in a row, so the
#   face order is as scattered as the elephant's) is clustered into 30 clusters;
# - the written PLY has the input's vertices and faces byte for byte, in the same order;
# - --labels and the PLY's cluster ids agree, and on the input mesh they give exactly 30 clusters,
#   each edge-connected (checked here in Python, not by meshcvt);
# - `meshcvt approximate --partition` writes the input's faces in order too.
# usage: locality_order.sh /path/to/meshcvt /path/to/tests/data
set -euo pipefail
cli=$1
data=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

"$cli" subdivide "$data/elephant.off" -k 3 -o "$tmp/big.ply" >/dev/null
"$cli" cluster "$tmp/big.ply" -n 30 --lloyd-steps 2 --max-iter 20 -o "$tmp/out.ply" --labels "$tmp/labels.txt" -q
"$cli" approximate "$tmp/big.ply" -n 12 -o "$tmp/approx.obj" --partition "$tmp/partition.ply" -q
python3 - "$tmp" <<'PY'
import struct, sys
tmp = sys.argv[1]

def read_ply(path):
    d = open(path, 'rb').read()
    h = d.index(b'end_header\n') + 11
    header = d[:h].decode().split('\n')
    count = lambda name: int([l for l in header if l.startswith('element ' + name)][0].split()[2])
    nv, nf = count('vertex'), count('face')
    labelled = 'property int cluster' in header
    record = 13 + (7 if labelled else 0)
    vertices = d[h:h + 12 * nv]
    faces, labels = [], []
    o = h + 12 * nv
    for _ in range(nf):
        assert d[o] == 3
        faces.append(d[o + 1:o + 13])
        if labelled:
            labels.append(struct.unpack_from('<i', d, o + 13)[0])
        o += record
    return vertices, faces, labels

def fail(msg):
    print('FAIL:', msg)
    sys.exit(1)

v_in, f_in, _ = read_ply(tmp + '/big.ply')
if len(f_in) < 1 << 18:
    fail('the test mesh has %d faces, below the reordering threshold' % len(f_in))
for name in ('out.ply', 'partition.ply'):
    v, f, labels = read_ply(tmp + '/' + name)
    if v != v_in: fail(name + ': vertices differ from the input or are not in its order')
    if f != f_in: fail(name + ': faces differ from the input or are not in its order')
    if len(labels) != len(f_in): fail(name + ': no per-face ids')
_, _, ply_labels = read_ply(tmp + '/out.ply')
labels = [int(x) for x in open(tmp + '/labels.txt')]
if labels != ply_labels: fail('--labels and the PLY cluster ids differ')
if len(set(labels)) != 30: fail('%d clusters, expected 30' % len(set(labels)))

faces = [struct.unpack('<3i', f) for f in f_in]
edges = {}
for i, t in enumerate(faces):
    for j in range(3):
        a, b = t[j], t[(j + 1) % 3]
        edges.setdefault((min(a, b), max(a, b)), []).append(i)
parent = list(range(len(faces)))
def find(x):
    while parent[x] != x:
        parent[x] = parent[parent[x]]
        x = parent[x]
    return x
for fs in edges.values():
    if len(fs) == 2 and labels[fs[0]] == labels[fs[1]]:
        parent[find(fs[0])] = find(fs[1])
roots = {}
for i in range(len(faces)):
    roots.setdefault(labels[i], set()).add(find(i))
split = [c for c, r in roots.items() if len(r) > 1]
if split: fail('clusters not connected on the input mesh: %s' % split[:5])
print('ok: %d faces, output in input order, 30 connected clusters' % len(faces))
PY
