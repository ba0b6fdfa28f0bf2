#!/usr/bin/env bash
# Clustering benchmark (issue "CPU clustering engine"): real meshes, CPU engine, default options.
# Prints one markdown row per case: faces, clusters, iterations, converged, energies, time per phase,
# peak memory per face; plus hierarchical vs random initialization and 1 vs 2 threads.
# Usage: bench/cluster_bench.sh [path/to/meshcvt]   (run on a quiet machine)
set -euo pipefail
cd "$(dirname "$0")/.."
meshcvt=${1:-build/meshcvt}
bench/fetch_meshes.sh "$meshcvt" >/dev/null
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
row() {  # mesh clusters extra-args...
  local mesh=$1 n=$2; shift 2
  /usr/bin/time -f "%M" -o "$out/mem" "$meshcvt" cluster "$mesh" -n "$n" -o "$out/o.ply" --report "$out/r.json" -q "$@"
  python3 - "$out/r.json" "$out/mem" "$mesh" "$*" <<'PY'
import json, sys
r = json.load(open(sys.argv[1])); kb = int(open(sys.argv[2]).read().split()[-1])
t = r['timings_s']; ms = lambda k: f"{1000 * t[k]:.1f}"
core = t['init'] + t['iterate'] + t['repair']
print(f"| {sys.argv[3].split('/')[-1]} | {r['faces']} | {r['options']['clusters']} | {sys.argv[4] or 'default'} | "
      f"{r['iterations']} | {'yes' if r['converged'] else 'no'} | {r['energy_initial']:.4g} | {r['energy_final']:.4g} | "
      f"{ms('init')} | {ms('iterate')} | {ms('repair')} | {1000 * core:.1f} | {1024 * kb / r['faces']:.0f} |")
PY
}
echo "| mesh | faces | n | options | iterations | converged | E init | E final | init ms | iterate ms | repair ms | init+iter+repair ms | peak B/face |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|"
m=bench/data/meshes
row $m/bunny00.off 1000
row $m/bunny00.off 1000 --init random
row $m/bunny00.off 1000 --threads 1
row $m/refined_elephant.off 1000
row $m/refined_elephant.off 1000 --init random
row $m/fandisk.off 1000
row $m/bunny00.off 1000 --no-accelerate
row bench/data/bunny-1.2M.ply 10000
row bench/data/bunny-1.2M.ply 10000 --threads 1
row bench/data/bunny-4.8M.ply 10000 --max-iter ${MAX_ITER_4M:-1000}
