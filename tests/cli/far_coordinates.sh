#!/usr/bin/env bash
# CLI test for meshes far from the origin for their size (a georeferenced scan in UTM metres): the
# elephant scaled to 100 units and moved to (412345, 5312345, 231.5), where 32-bit floats are
# 0.25-0.5 apart. Every command works on it moved near the origin (a note says so) and writes its
# outputs back in place: coarsen's quality equals the same job's on the unmoved elephant, cluster's
# and subdivide's outputs keep the input's coordinates to 1e-5, approximate's outputs are in
# place, info shows the box in place, stats
# measures against a far reference in the same frame. Outputs are read here with plain Python.
# usage: far_coordinates.sh /path/to/meshcvt /path/to/tests/data
set -euo pipefail
cli=$1
data=$2
source "$(dirname "$0")/prologue.bash"  # $tmp, fail

# The two inputs, coordinates written with every digit of the double (Python's repr).
python3 - "$data/elephant.off" "$tmp" <<'PY'
import sys
tok = open(sys.argv[1]).read().split()
nv, nf = int(tok[1]), int(tok[2])
for name, shift in (("near", (0, 0, 0)), ("utm", (412345.0, 5312345.0, 231.5))):
    with open(f"{sys.argv[2]}/{name}.off", "w") as out:
        out.write(f"OFF\n{nv} {nf} 0\n")
        for i in range(nv):
            p = [100 * float(t) + s for t, s in zip(tok[4 + 3 * i:7 + 3 * i], shift)]
            out.write("%r %r %r\n" % tuple(p))
        for k in range(nf):
            out.write(" ".join(tok[4 + 3 * nv + 4 * k:8 + 3 * nv + 4 * k]) + "\n")
PY

# read_vertices FILE: prints "x y z" per vertex of an OFF or a binary little-endian PLY (float or
# double x y z first in the vertex element), read independently of meshcvt.
read_vertices() {
  python3 - "$1" <<'PY'
import struct, sys
path = sys.argv[1]
data = open(path, "rb").read()
if path.endswith(".off"):
    tok = data.decode().split()
    nv = int(tok[1])
    for i in range(nv):
        print(*tok[4 + 3 * i:7 + 3 * i])
    sys.exit(0)
end = data.index(b"end_header\n") + len(b"end_header\n")
header = data[:end].decode().splitlines()
nv = int(next(l.split()[2] for l in header if l.startswith("element vertex")))
kind = next(l.split()[1] for l in header if l.startswith("property") and l.endswith(" x"))
fmt, size = ("<3d", 24) if kind == "double" else ("<3f", 12)
for i in range(nv):
    print(*(repr(v) for v in struct.unpack_from(fmt, data, end + size * i)))
PY
}

# ---- coarsen: the note, the same quality as near the origin, the output in place
"$cli" coarsen "$tmp/utm.off" -n 300 -o "$tmp/c-utm.ply" --report "$tmp/r-utm.json" >"$tmp/out" 2>"$tmp/err"
grep -q "^meshcvt: note: .*utm.off: coordinates reach 5.3124e+06 while the mesh spans 100: held relative to (412300, 5312300, 200)" "$tmp/err" ||
  fail "coarsen: no note on moving the mesh: $(cat "$tmp/err")"
"$cli" coarsen "$tmp/near.off" -n 300 -o "$tmp/c-near.ply" --report "$tmp/r-near.json" -q
python3 - "$tmp/r-utm.json" "$tmp/r-near.json" <<'PY' || fail "coarsen: far output differs from the near one's"
import json, sys
far, near = (json.load(open(p)) for p in sys.argv[1:3])
qf, qn = far["quality"], near["quality"]
# Float rounding differs up there and near 0, so the clustering may differ in a few faces: the
# quality is the same to a few percent (unmoved, the far elephant came out at 22 degrees).
assert qf["min_angle_deg"] > 29 and qf["angles_below_30"] == 0, qf
assert abs(qf["q_avg"] - qn["q_avg"]) < 0.01, (qf, qn)
assert abs(far["error"]["hausdorff_rel"] - near["error"]["hausdorff_rel"]) < 0.01, (far["error"], near["error"])
assert far["timings_s"]["error"] > 0  # the measurement's own time
PY
read_vertices "$tmp/c-utm.ply" >"$tmp/c-utm.xyz"
python3 - "$tmp/c-utm.xyz" <<'PY' || fail "coarsen: output vertices not in place"
import sys
rows = [list(map(float, l.split())) for l in open(sys.argv[1])]
assert len(rows) == 300, len(rows)
lo = (412345.0 - 37, 5312345.0 - 51, 231.5 - 31)
hi = (412345.0 + 37, 5312345.0 + 51, 231.5 + 31)
for r in rows:
    assert all(l <= x <= h for x, l, h in zip(r, lo, hi)), r
PY

# ---- stats against the far input: the coarsen report's error
"$cli" stats "$tmp/c-utm.ply" --ref "$tmp/utm.off" --json >"$tmp/stats.json" 2>/dev/null
python3 - "$tmp/stats.json" "$tmp/r-utm.json" <<'PY' || fail "stats: error against the far reference"
import json, sys
s, r = (json.load(open(p)) for p in sys.argv[1:3])
e = s["error"] if "error" in s else s
assert abs(e["hausdorff_rel"] - r["error"]["hausdorff_rel"]) < 0.002, (e, r["error"])
PY

# ---- cluster and subdivide write the input's vertices where they were
"$cli" cluster "$tmp/utm.off" -n 50 -o "$tmp/k-utm.ply" -q
"$cli" subdivide "$tmp/utm.off" -k 1 -o "$tmp/s-utm.off" -q
read_vertices "$tmp/utm.off" >"$tmp/in.xyz"
read_vertices "$tmp/k-utm.ply" >"$tmp/k.xyz"
read_vertices "$tmp/s-utm.off" >"$tmp/s.xyz"
python3 - "$tmp/in.xyz" "$tmp/k.xyz" "$tmp/s.xyz" <<'PY' || fail "cluster/subdivide: vertices moved"
import sys
rows = [[list(map(float, l.split())) for l in open(p)] for p in sys.argv[1:4]]
src, clustered, fine = rows
assert len(clustered) == len(src)
for name, out in (("cluster", clustered), ("subdivide", fine[:len(src)])):  # subdivision keeps them first
    worst = max(abs(a - b) for p, q in zip(src, out) for a, b in zip(p, q))
    assert worst < 1e-5, (name, worst)
PY

# ---- approximate: its partition holds the input's vertices, its polygons lie in the input's box
"$cli" approximate "$tmp/utm.off" -n 30 -o "$tmp/a-utm.ply" --polygons "$tmp/p-utm.off" --partition "$tmp/part-utm.ply" -q
read_vertices "$tmp/part-utm.ply" >"$tmp/part.xyz"
read_vertices "$tmp/p-utm.off" >"$tmp/p.xyz"
read_vertices "$tmp/a-utm.ply" >"$tmp/a.xyz"
python3 - "$tmp/in.xyz" "$tmp/part.xyz" "$tmp/p.xyz" "$tmp/a.xyz" <<'PY' || fail "approximate: outputs not in place"
import sys
src, part, polygons, triangles = ([list(map(float, l.split())) for l in open(p)] for p in sys.argv[1:5])
assert len(part) == len(src)
assert max(abs(a - b) for p, q in zip(src, part) for a, b in zip(p, q)) < 1e-5
lo = [min(r[k] for r in src) - 1e-3 for k in range(3)]
hi = [max(r[k] for r in src) + 1e-3 for k in range(3)]
for rows in (polygons, triangles):
    assert rows and all(all(l <= x <= h for x, l, h in zip(r, lo, hi)) for r in rows)
PY

# ---- info shows the box in place
"$cli" info "$tmp/utm.off" --json >"$tmp/info.json" 2>/dev/null
python3 - "$tmp/info.json" "$tmp/in.xyz" <<'PY' || fail "info: box not in place"
import json, sys
d = json.load(open(sys.argv[1]))
rows = [list(map(float, l.split())) for l in open(sys.argv[2])]
for k in range(3):
    assert abs(d["bbox_min"][k] - min(r[k] for r in rows)) < 1e-5, d["bbox_min"]
    assert abs(d["bbox_max"][k] - max(r[k] for r in rows)) < 1e-5, d["bbox_max"]
assert d["origin"] == [412300, 5312300, 200], d["origin"]
PY
echo "far_coordinates.sh: ok"
