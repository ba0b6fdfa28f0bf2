#!/usr/bin/env bash
# CLI test of `meshcvt info` (text and --json, --no-weld) and `meshcvt subdivide`: counts are
# compared with numbers computed here independently (OFF header read with awk; edges, boundary,
# components, area, bbox with a few lines of plain Python), on the real elephant mesh and on small
# meshes written here (bow-tie, split vertices, two parts touching along an edge). Also: a missing
# file fails with exit 1 and a message naming the file; too many subdivision levels exit 2 and
# write nothing.
# usage: info.sh /path/to/meshcvt /path/to/tests/data
set -euo pipefail
cli=$1
data=$2
source "$(dirname "$0")/prologue.bash"  # $tmp, fail

# check NAME INFO_JSON OFF_FILE|- [PYTHON_ASSERTS]: the JSON parses; when OFF_FILE is given, every
# count info reports equals the one measured here from the file; then the asserts run with d = the
# info JSON.
check() {
  python3 - "$@" <<'PY'
import json, math, sys
name, info_file, off = sys.argv[1], sys.argv[2], sys.argv[3]
extra = sys.argv[4] if len(sys.argv) > 4 else ""
d = json.load(open(info_file))
def measure(path):
    tok = []
    for line in open(path):
        tok += line.split('#')[0].split()
    nv, nf = int(tok[1]), int(tok[2])
    p = [tuple(float(x) for x in tok[4 + 3 * i: 7 + 3 * i]) for i in range(nv)]
    t, k = [], 4 + 3 * nv
    for _ in range(nf):
        n = int(tok[k]); t.append(tuple(int(x) for x in tok[k + 1: k + 1 + n])); k += n + 1
    edges = {}
    for f, (a, b, c) in enumerate(t):
        for u, v in ((a, b), (b, c), (c, a)):
            edges.setdefault((min(u, v), max(u, v)), []).append(f)
    parent = list(range(nf))
    def find(x):
        while parent[x] != x:
            parent[x] = parent[parent[x]]; x = parent[x]
        return x
    for fs in edges.values():
        if len(fs) == 2:
            parent[find(fs[0])] = find(fs[1])
    used = sorted({v for f in t for v in f})
    area = 0.0
    for a, b, c in t:
        u = [p[b][i] - p[a][i] for i in range(3)]; w = [p[c][i] - p[a][i] for i in range(3)]
        x = (u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0])
        area += 0.5 * math.sqrt(sum(q * q for q in x))
    return {"vertices": len(used), "faces": nf, "edges": len(edges),
            "boundary_edges": sum(len(fs) == 1 for fs in edges.values()),
            "nonmanifold_edges": sum(len(fs) > 2 for fs in edges.values()),
            "components": len({find(f) for f in range(nf)}),
            "euler_characteristic": len(used) - len(edges) + nf, "total_area": area,
            "bbox_min": [min(p[v][i] for v in used) for i in range(3)],
            "bbox_max": [max(p[v][i] for v in used) for i in range(3)]}
if off != "-":
    for key, value in measure(off).items():
        g = d[key]
        if isinstance(value, list):
            ok = all(abs(a - b) <= 1e-6 * max(1.0, abs(b)) for a, b in zip(g, value))
        elif isinstance(value, float):
            ok = abs(g - value) <= 1e-6 * abs(value)
        else:
            ok = g == value
        if not ok:
            sys.exit(f"{name}: {key} is {g}, measured {value}")
t = d["timings_ms"]
if not (t["read"] >= 0 and t["topology"] >= 0):
    sys.exit(f"{name}: bad timings {t}")
if extra and not eval("(" + extra + ")"):
    sys.exit(f"{name}: not true: {extra}\n{json.dumps(d)}")
PY
}

# ---- elephant: header counts with awk, the rest measured in Python
elephant=$data/elephant.off
header_faces=$(awk 'NR == 2 { print $2; exit }' "$elephant")
header_vertices=$(awk 'NR == 2 { print $1; exit }' "$elephant")
"$cli" info "$elephant" >"$tmp/text" || fail "info elephant failed"
grep -Eq "^faces +$header_faces\$" "$tmp/text" || fail "text output lacks 'faces $header_faces': $(cat "$tmp/text")"
grep -Eq "^vertices +$header_vertices\$" "$tmp/text" || fail "text output lacks 'vertices $header_vertices'"
grep -Eq "^format +off\$" "$tmp/text" || fail "text output lacks the format"
grep -Eq "^topology ms +[0-9.]+\$" "$tmp/text" || fail "text output lacks the topology time"
grep -Eq "^read ms +[0-9.]+\$" "$tmp/text" || fail "text output lacks the read time"
"$cli" info "$elephant" --json >"$tmp/json" || fail "info --json elephant failed"
python3 -c 'import json,sys; json.load(sys.stdin)' <"$tmp/json" || fail "--json output does not parse"
# A closed surface: no boundary, genus from chi.
check elephant "$tmp/json" "$elephant" \
  'd["boundary_loops"] == 0 and d["genus"] == (2 - d["euler_characteristic"]) // 2 and
   d["read"]["format"] == "off" and d["read"]["file_polygons"] == d["faces"]' ||
  fail "elephant: info disagrees with the independent count"

# ---- bow-tie: two triangles sharing only vertex 0
cat >"$tmp/bowtie.off" <<'EOF'
OFF
5 2 0
0 0 0
1 0 0
1 1 0
-1 0 0
-1 -1 0
3 0 1 2
3 0 3 4
EOF
"$cli" info "$tmp/bowtie.off" --json >"$tmp/json" || fail "info bowtie failed"
check bowtie "$tmp/json" "$tmp/bowtie.off" \
  'd["nonmanifold_vertices"] == 1 and d["boundary_loops"] == 2 and d["genus"] == -1' || fail "bowtie"
"$cli" info "$tmp/bowtie.off" | grep -Eq "^genus +undefined \(non-manifold\)\$" || fail "bowtie: text genus"

# ---- split vertices: a square of two triangles whose diagonal vertices are stored twice
cat >"$tmp/split.off" <<'EOF'
OFF
6 2 0
0 0 0
1 0 0
1 1 0
0 0 0
1 1 0
0 1 0
3 0 1 2
3 3 4 5
EOF
"$cli" info "$tmp/split.off" --json >"$tmp/json" || fail "info split failed"
check split "$tmp/json" - 'd["components"] == 1 and d["vertices"] == 4 and d["read"]["welded_vertices"] == 2' ||
  fail "split: welding not applied or not reported"
"$cli" info "$tmp/split.off" --json --no-weld >"$tmp/json" || fail "info --no-weld failed"
check split-no-weld "$tmp/json" "$tmp/split.off" \
  'd["components"] == 2 and d["read"]["welded_vertices"] == 0 and d["read"]["weld"] is False' ||
  fail "split --no-weld"

# ---- two closed tetrahedra whose edges 0-1 and 4-5 lie at the same place: welding would make one
# edge of four faces out of two manifold edges of the file, so those vertices are kept apart
cat >"$tmp/touching.off" <<'EOF'
OFF
8 8 0
0 0 0
1 0 0
0.5 1 0.2
0.5 0.3 1
0 0 0
1 0 0
0.5 -1 0.2
0.5 -0.3 -1
3 0 1 2
3 0 3 1
3 0 2 3
3 1 3 2
3 4 6 5
3 4 5 7
3 4 7 6
3 5 6 7
EOF
"$cli" info "$tmp/touching.off" --json >"$tmp/json" || fail "info touching failed"
check touching "$tmp/json" "$tmp/touching.off" \
  'd["components"] == 2 and d["nonmanifold_edges"] == 0 and d["read"]["welded_vertices"] == 0 and d["read"]["kept_apart_vertices"] == 2' ||
  fail "touching: the weld made a non-manifold edge, or the vertices kept apart were not reported"
"$cli" info "$tmp/touching.off" | grep -q "^kept apart (weld) *2$" || fail "touching: no 'kept apart' row in the text output"

# ---- a PLY whose header has a line without a keyword before its elements (as Blender 2.4x wrote
# them): read, with a note naming the file and the line, and the count in the report
printf 'ply\nformat ascii 1.0\nCreated by Blender3D 247 - www.blender.org, source file: \nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n' >"$tmp/banner.ply"
"$cli" info "$tmp/banner.ply" --json >"$tmp/json" 2>"$tmp/err" || fail "info on a PLY with a banner line failed: $(cat "$tmp/err")"
grep -q "^meshcvt: note: $tmp/banner.ply: skipped 1 PLY header line .*(line 3)\$" "$tmp/err" || fail "banner: no note: $(cat "$tmp/err")"
check banner "$tmp/json" - 'd["faces"] == 1 and d["read"]["skipped_header_lines"] == 1' || fail "banner: count"
"$cli" subdivide "$tmp/banner.ply" -k 1 -o "$tmp/banner-fine.off" -q >/dev/null 2>"$tmp/err" || fail "subdivide banner failed"
[ ! -s "$tmp/err" ] || fail "subdivide -q printed the note: $(cat "$tmp/err")"

# ---- subdivide: faces x 4^k, same chi, still closed; a small mesh checked independently
"$cli" subdivide "$tmp/bowtie.off" -k 2 -o "$tmp/fine.off" >"$tmp/out" || fail "subdivide bowtie failed"
grep -q "$tmp/fine.off" "$tmp/out" || fail "subdivide does not say what it wrote"
"$cli" info "$tmp/fine.off" --json >"$tmp/json" || fail "info on the subdivided bowtie failed"
check fine-bowtie "$tmp/json" "$tmp/fine.off" \
  'd["faces"] == 2 * 16 and d["boundary_edges"] == 6 * 4 and d["euler_characteristic"] == 1' ||
  fail "subdivided bowtie"
"$cli" subdivide "$elephant" -k 1 -o "$tmp/fine.ply" -q >"$tmp/out" || fail "subdivide elephant failed"
[ ! -s "$tmp/out" ] || fail "subdivide -q printed something"
"$cli" info "$tmp/fine.ply" --json >"$tmp/json" || fail "info on the subdivided elephant failed"
# Closed: E = 3F/2, so one new vertex per edge gives V + 3F/2 vertices and chi = V - F/2 stays.
f=$header_faces v=$header_vertices
check fine-elephant "$tmp/json" - \
  "d['faces'] == 4 * $f and d['vertices'] == $v + 3 * $f // 2 and d['euler_characteristic'] == $v - $f // 2 and
   d['boundary_edges'] == 0 and d['nonmanifold_edges'] == 0 and d['components'] == 1" || fail "subdivided elephant"
# Too many levels: refused before writing anything (exit 2: the option is the problem).
set +e
"$cli" subdivide "$elephant" -k 14 -o "$tmp/huge.off" >/dev/null 2>"$tmp/err"
rc=$?
set -e
[ $rc -eq 2 ] || fail "subdivide -k 14: expected exit 2, got $rc"
grep -q "^meshcvt: error: " "$tmp/err" || fail "subdivide -k 14: no error message"
[ ! -e "$tmp/huge.off" ] || fail "subdivide -k 14 left an output file"

# ---- missing file: exit 1, one message naming the file, nothing on stdout
set +e
"$cli" info "$tmp/no-such-mesh.off" >"$tmp/out" 2>"$tmp/err"
rc=$?
set -e
[ $rc -eq 1 ] || fail "missing file: expected exit 1, got $rc"
grep -q "^meshcvt: error: .*no-such-mesh.off" "$tmp/err" || fail "missing file: message: $(cat "$tmp/err")"
[ ! -s "$tmp/out" ] || fail "missing file: something on stdout"

# ---- coordinates far from the origin for the mesh's size: the mesh is held relative to a point
# near it, and a note says which (the elephant, about 1 across, moved to x = 4e3: float spacing
# 2.4e-4 > 1e-5 of its size; at x = 40 the spacing is 3.8e-6, well within, and nothing is said;
# tests/cli/far_coordinates.sh has the rest)
for shift in 4000 40; do
  off_mapped "$data/elephant.off" "$tmp/far.off" "x + $shift" y z
  "$cli" info "$tmp/far.off" >"$tmp/out" 2>"$tmp/err"
  if [ "$shift" = 4000 ]; then
    grep -q "^meshcvt: note: .*far.off: coordinates reach 4000.36 while the mesh spans 1: held relative to (4000, 0, 0) to keep their precision as 32-bit floats" "$tmp/err" ||
      fail "far coordinates: no note: $(cat "$tmp/err")"
  else
    [ ! -s "$tmp/err" ] || fail "coordinates near the origin: unexpected note: $(cat "$tmp/err")"
  fi
done
"$cli" info "$data/elephant.off" >"$tmp/out" 2>"$tmp/err"
[ ! -s "$tmp/err" ] || fail "elephant: unexpected note: $(cat "$tmp/err")"
echo "info.sh: ok"
