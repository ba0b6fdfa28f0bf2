#!/usr/bin/env bash
# CLI test for `meshcvt stats`: text and JSON output on meshes with known answers (a regular
# tetrahedron; a square against the same square lifted by 0.5), the real elephant mesh, and clean
# failures (missing --ref file, bad --samples).
# usage: stats.sh /path/to/meshcvt /path/to/tests/data
set -euo pipefail
cli=$1
data=$2
source "$(dirname "$0")/prologue.bash"  # $tmp, fail

# Regular tetrahedron: every face equilateral (Q = 1, angles 60), every vertex of valence 3.
cat > "$tmp/tet.off" <<'EOF'
OFF
4 4 0
1 1 1
1 -1 -1
-1 1 -1
-1 -1 1
3 0 1 2
3 0 3 1
3 0 2 3
3 1 3 2
EOF
# The unit square (two triangles) at z = 0 and at z = 0.5.
for z in 0 0.5; do
  cat > "$tmp/square_$z.off" <<EOF
OFF
4 2 0
0 0 $z
1 0 $z
1 1 $z
0 1 $z
3 0 1 2
3 0 2 3
EOF
done

# Text output: exit 0, the counts and the Table 1 columns are there.
"$cli" stats "$tmp/tet.off" > "$tmp/tet.txt" || fail "stats on a tetrahedron exited with $?"
grep -Eq '^faces +4$' "$tmp/tet.txt" || fail "face count missing: $(cat "$tmp/tet.txt")"
grep -Eq '^min angle +60\.0000 deg$' "$tmp/tet.txt" || fail "min angle: $(cat "$tmp/tet.txt")"
grep -Eq '^Q min +1\.000000$' "$tmp/tet.txt" || fail "Q min: $(cat "$tmp/tet.txt")"

# JSON output parses and carries the same numbers.
"$cli" stats "$tmp/tet.off" --json > "$tmp/tet.json"
python3 - "$tmp/tet.json" <<'EOF'
import json, sys
d = json.load(open(sys.argv[1]))
assert d["faces"] == 4 and d["vertices"] == 4, d
q = d["quality"]
assert abs(q["min_angle_deg"] - 60) < 1e-4 and abs(q["q_min"] - 1) < 1e-6 and q["angles_below_30"] == 0, q
assert d["valence_histogram"] == [0, 0, 0, 4], d["valence_histogram"]
assert "error" not in d
EOF

# --ref: the lifted square is 0.5 away everywhere; the reference's diagonal is sqrt(2).
"$cli" stats "$tmp/square_0.off" --ref "$tmp/square_0.5.off" --samples 2000 --json > "$tmp/sq.json"
python3 - "$tmp/sq.json" <<'EOF'
import json, math, sys
e = json.load(open(sys.argv[1]))["error"]
assert abs(e["hausdorff"] - 0.5) < 1e-6 and abs(e["rms"] - 0.5) < 1e-6, e
assert abs(e["ref_bbox_diagonal"] - math.sqrt(2)) < 1e-6, e
assert abs(e["hausdorff_rel"] - 0.5 / math.sqrt(2)) < 1e-6, e
assert e["samples_per_mesh"] == 2000, e
EOF
"$cli" stats "$tmp/square_0.off" --ref "$tmp/square_0.5.off" --samples 2000 > "$tmp/sq.txt"
grep -Eq '^hausdorff +0\.5 ' "$tmp/sq.txt" || fail "text hausdorff: $(cat "$tmp/sq.txt")"

# A real mesh against itself: distance 0 (to rounding), and the threads do not change a digit.
"$cli" stats "$data/elephant.off" --ref "$data/elephant.off" --samples 5000 --threads 1 --json > "$tmp/el1.json"
"$cli" stats "$data/elephant.off" --ref "$data/elephant.off" --samples 5000 --threads 2 --json > "$tmp/el2.json"
python3 - "$tmp/el1.json" "$tmp/el2.json" <<'EOF'
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:3])
assert a["faces"] > 5000 and a["quality"]["q_min"] > 0, a
assert a["error"]["hausdorff_rel"] < 1e-6, a["error"]
for k in ("hausdorff", "rms", "mesh_to_ref_mean"):
    assert a["error"][k] == b["error"][k], k
EOF

# A missing --ref file: exit 1, one error line naming the file, nothing on stdout.
set +e
"$cli" stats "$tmp/tet.off" --ref "$tmp/missing.off" > "$tmp/out" 2> "$tmp/err"
rc=$?
set -e
[ "$rc" -eq 1 ] || fail "missing --ref: exit code $rc"
grep -q "^meshcvt: error: .*missing.off" "$tmp/err" || fail "missing --ref: message $(cat "$tmp/err")"
[ ! -s "$tmp/out" ] || fail "missing --ref: wrote to stdout"

# Bad usage: --samples 0 and no mesh are command-line errors (exit 2).
set +e
"$cli" stats "$tmp/tet.off" --samples 0 > /dev/null 2>&1; rc1=$?
"$cli" stats > /dev/null 2>&1; rc2=$?
set -e
[ "$rc1" -eq 2 ] || fail "--samples 0: exit code $rc1"
[ "$rc2" -eq 2 ] || fail "no mesh: exit code $rc2"
echo "stats: ok"
