#!/usr/bin/env bash
# CLI test of the boundary step of `meshcvt coarsen` (CoarsenOptions::boundary_onto_input): a flat
# 40 x 40 square of quads (written here) -> 80 vertices.
# - By default every vertex of the coarse boundary lies on the square's boundary, its four corners
#   among them; the report counts them (boundary_vertices_moved, boundary_corners = 4) and stdout
#   says so; the Hausdorff distance to the input is (almost) 0: the coarse mesh covers the square.
# - With --no-boundary-snap the boundary runs inside: some boundary vertex is off the square's
#   boundary, no corner is kept, the counts are 0 and the Hausdorff distance is larger.
# usage: coarsen_boundary.sh /path/to/meshcvt /path/to/tests/data
set -euo pipefail
cli=$1
source "$(dirname "$0")/prologue.bash"  # $tmp, fail

python3 - "$tmp/square.off" <<'PY'
import sys
n = 40
with open(sys.argv[1], "w") as f:
    f.write("OFF\n%d %d 0\n" % ((n + 1) ** 2, 2 * n * n))
    for j in range(n + 1):
        for i in range(n + 1):
            f.write("%d %d 0\n" % (i, j))
    for j in range(n):
        for i in range(n):
            a, b, c, d = j * (n + 1) + i, j * (n + 1) + i + 1, (j + 1) * (n + 1) + i + 1, (j + 1) * (n + 1) + i
            f.write("3 %d %d %d\n3 %d %d %d\n" % (a, b, c, a, c, d))
PY

check() {  # coarse.off report.json expect(on|off)
  local why
  why=$(python3 - "$@" <<'PY'

import json, sys
coarse, report, mode = sys.argv[1], sys.argv[2], sys.argv[3]
t = open(coarse).read().split()
nv, nf = int(t[1]), int(t[2])
V = [tuple(map(float, t[4 + 3 * i:7 + 3 * i])) for i in range(nv)]
pos, uses = 4 + 3 * nv, {}
for _ in range(nf):
    k = int(t[pos]); f = [int(x) for x in t[pos + 1:pos + 1 + k]]; pos += 1 + k
    for a, b in zip(f, f[1:] + f[:1]):
        e = (min(a, b), max(a, b)); uses[e] = uses.get(e, 0) + 1
boundary = {v for e, c in uses.items() if c == 1 for v in e}
side = lambda x: abs(x) < 1e-4 or abs(x - 40) < 1e-4
on_square = [v for v in boundary if side(V[v][0]) or side(V[v][1])]
corners = [v for v in boundary if side(V[v][0]) and side(V[v][1])]
r = json.load(open(report))
h = r["error"]["hausdorff_rel"]
if mode == "on":
    ok = (len(boundary) >= 12 and len(on_square) == len(boundary) and len(corners) == 4 and r["boundary_corners"] == 4
          and r["boundary_vertices_moved"] == len(boundary) and r["boundary_left_inside"] == 0 and h < 1e-6)
else:
    ok = (len(on_square) < len(boundary) and not corners and r["boundary_vertices_moved"] == 0 and h > 1e-3)
print("boundary vertices", len(boundary), "on the square", len(on_square), "corners", len(corners),
      "report: moved", r["boundary_vertices_moved"], "corners", r["boundary_corners"], "Hausdorff", h)
sys.exit(0 if ok else 1)
PY
) || fail "boundary check ($3): $why"
}

"$cli" coarsen "$tmp/square.off" -n 80 -o "$tmp/on.off" --report "$tmp/on.json" --device cpu >"$tmp/out.txt" ||
  fail "coarsen of the square failed"
check "$tmp/on.off" "$tmp/on.json" on
grep -Eq "^boundary: [0-9]+ vertices onto the input's boundary, 4 of them onto its corners$" "$tmp/out.txt" ||
  fail "no boundary line: $(cat "$tmp/out.txt")"
"$cli" coarsen "$tmp/square.off" -n 80 -o "$tmp/off.off" --report "$tmp/off.json" --device cpu --no-boundary-snap -q ||
  fail "coarsen --no-boundary-snap failed"
check "$tmp/off.off" "$tmp/off.json" off
echo "ok"
