# Sourced by the CLI tests (tests/cli/*.sh) after their `set` line: $tmp, a temporary directory
# removed on exit, and `fail MESSAGE` (prints "FAIL: MESSAGE" to stderr and exits 1).
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
# off_with_extra IN OUT VERTICES FACES: writes OUT, the OFF file IN (triangles only, no comments)
# with the lines VERTICES ("x y z" each) after its vertices and FACES ("3 a b c" each) after its
# faces; in FACES, "+k" stands for the k-th extra vertex (IN's vertex count + k).
off_with_extra() {
  python3 - "$@" <<'PY'
import sys
tok = open(sys.argv[1]).read().split()
nv, nf = int(tok[1]), int(tok[2])
body = tok[4:]
verts = [l for l in sys.argv[3].splitlines() if l.strip()]
faces = [' '.join(str(nv + int(t[1:])) if t.startswith('+') else t for t in l.split())
         for l in sys.argv[4].splitlines() if l.strip()]
with open(sys.argv[2], 'w') as out:
    out.write(f"OFF\n{nv + len(verts)} {nf + len(faces)} 0\n")
    for i in range(nv):
        out.write(' '.join(body[3 * i:3 * i + 3]) + '\n')
    out.writelines(v + '\n' for v in verts)
    for k in range(nf):
        out.write(' '.join(body[3 * nv + 4 * k:3 * nv + 4 * k + 4]) + '\n')
    out.writelines(f + '\n' for f in faces)
PY
}
# off_mapped IN OUT X Y Z: writes OUT, the OFF file IN (triangles only, no comments) with each
# vertex moved to the Python expressions X, Y, Z of its coordinates x, y, z (as "%.9g").
off_mapped() {
  python3 - "$@" <<'PY'
import sys
tok = open(sys.argv[1]).read().split()
nv, nf = int(tok[1]), int(tok[2])
fx, fy, fz = (compile(e, "expr", "eval") for e in sys.argv[3:6])
with open(sys.argv[2], "w") as out:
    out.write(f"OFF\n{nv} {nf} 0\n")
    for i in range(nv):
        x, y, z = (float(t) for t in tok[4 + 3 * i:7 + 3 * i])
        out.write("%.9g %.9g %.9g\n" % tuple(eval(f, {"x": x, "y": y, "z": z}) for f in (fx, fy, fz)))
    for k in range(nf):
        out.write(" ".join(tok[4 + 3 * nv + 4 * k:8 + 3 * nv + 4 * k]) + "\n")
PY
}
# ply_face_ids FILE.ply: prints the per-face `cluster` property of a binary PLY as meshcvt writes it
# (vertex float x y z; face list uchar int vertex_indices, int cluster, uchar red green blue), one
# per line, read independently of meshcvt's reader.
ply_face_ids() {
  python3 - "$1" <<'PY'
import struct, sys
data = open(sys.argv[1], 'rb').read()
end = data.index(b"end_header\n") + len(b"end_header\n")
header = data[:end].decode().split("\n")
assert "format binary_little_endian 1.0" in header and "property int cluster" in header, header
nv = int(next(l for l in header if l.startswith("element vertex")).split()[2])
nf = int(next(l for l in header if l.startswith("element face")).split()[2])
pos, out = end + 12 * nv, []
for _ in range(nf):
    k = data[pos]; pos += 1 + 4 * k
    out.append(str(struct.unpack_from("<i", data, pos)[0])); pos += 4 + 3
assert pos == len(data), "trailing bytes"
print("\n".join(out))
PY
}
