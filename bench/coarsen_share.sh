#!/usr/bin/env bash
# The coarsening's share of the clustering time, as the Table 1 target states it ("coarsening itself
# <= 20% of the clustering time"): `meshcvt coarsen --report` on the Table 1 meshes (default
# placement), the report's cluster and coarsen timings, RUNS runs per binary, the binaries
# alternated run by run so that the VM's drift hits them alike. Prints min and median per mesh.
# Results go to bench/RESULTS.md ("Table 1").
# usage: bench/coarsen_share.sh RUNS MESHCVT [MESHCVT...]   (needs bench/fetch_meshes.sh, and
#        bench/table1_bench.sh once for bench/data/sphere-131k.off)
#        SHARE_CASES="MESH N [MESH N...]" bench/coarsen_share.sh ...   measures those meshes instead
#        (a MESHCVT may be a script that adds options or environment).
set -euo pipefail
cd "$(dirname "$0")/.."
runs=$1
shift
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cases=(bench/data/meshes/bunny00.off 500 bench/data/meshes/fandisk.off 1000
       bench/data/meshes/refined_elephant.off 1000 bench/data/sphere-131k.off 200 bench/data/bunny-1.2M.ply 10000
       bench/data/bunny-4.8M.ply 10000)
if [ -n "${SHARE_CASES:-}" ]; then read -r -a cases <<<"$SHARE_CASES"; fi
for ((i = 0; i < ${#cases[@]}; i += 2)); do
  mesh=${cases[i]} n=${cases[i + 1]}
  [ -f "$mesh" ] || continue
  for ((b = 1; b <= $#; ++b)); do : >"$work/times-$b"; done
  for ((r = 0; r < runs; ++r)); do
    b=0
    for bin in "$@"; do
      b=$((b + 1))
      "$bin" coarsen "$mesh" -n "$n" -o "$work/out.ply" --no-error -q --report "$work/r.json"
      python3 -c "import json, sys; t = json.load(open(sys.argv[1]))['timings_s']; print(t['cluster'], t['coarsen'])" \
        "$work/r.json" >>"$work/times-$b"
    done
  done
  b=0
  for bin in "$@"; do
    b=$((b + 1))
    python3 - "$work/times-$b" "$(basename "$mesh") -> $n, $bin" <<'PY'
import statistics as st, sys
rows = [tuple(map(float, line.split())) for line in open(sys.argv[1])]
cluster, coarsen = [r[0] for r in rows], [r[1] for r in rows]
share = [r[1] / r[0] for r in rows]
print(f"{sys.argv[2]}: cluster median {1e3 * st.median(cluster):.2f} ms, coarsen min {1e3 * min(coarsen):.2f} "
      f"median {1e3 * st.median(coarsen):.2f} ms, share min {100 * min(share):.1f}% median {100 * st.median(share):.1f}%")
PY
  done
done
