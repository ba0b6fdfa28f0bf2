#!/usr/bin/env bash
# Quality of `meshcvt coarsen` over libcgal-demo's meshes at n = faces / DIV, with extra options (for
# --split-edges R against none): one line per mesh, "name n defects min_angle q_avg angles_below_30
# long_edges" (long_edges: input edges longer than the coarse edge length, from the report), or
# "name n rc" when refused. Results go to bench/RESULTS.md ("Coarsening: long faces").
# usage: bench/split_edges_sweep.sh MESHCVT DIV OUT [OPTIONS...]   (needs bench/fetch_meshes.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
bin=$1 div=$2 out=$3
shift 3
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
: >"$out"
for f in bench/data/meshes/*.off; do
  nf=$("$bin" info "$f" --json 2>/dev/null | python3 -c "import json, sys; print(json.load(sys.stdin)['faces'])") || continue
  n=$((nf / div))
  [ "$n" -ge 4 ] || continue
  if ! "$bin" coarsen "$f" -n "$n" -o "$work/out.off" --no-error -q --report "$work/r.json" "$@" 2>/dev/null; then
    echo "$(basename "$f" .off) $n rc" >>"$out"
    continue
  fi
  python3 - "$work/r.json" "$(basename "$f" .off)" "$n" >>"$out" <<'PY'
import json, sys
r = json.load(open(sys.argv[1])); q = r['quality']
print(sys.argv[2], sys.argv[3], len(r['defects']), round(q['min_angle_deg'], 2), round(q['q_avg'], 4),
      q['angles_below_30'], r['long_edges'])
PY
done
