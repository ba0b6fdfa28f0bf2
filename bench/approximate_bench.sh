#!/usr/bin/env bash
# Benchmark of `meshcvt approximate` (L2,1 shape approximation, issue "Anisotropic shape
# approximation with the L2,1 metric"): partition + meshing times, L2,1 distortion E/A, output size
# and validity on CGAL's demo meshes; the chord rule against CGAL's default on fandisk (surface
# distance to the input, measured by `meshcvt stats --ref`); components and boundaries kept.
# Fetches the meshes itself (Debian libcgal-demo, `apt-get download`, into bench/data/, git-ignored,
# never committed) and makes a ~127k-face mesh by subdividing fandisk_large once.
# usage: bench/approximate_bench.sh [path/to/meshcvt]   (default: builds build-approx-bench/meshcvt)
#        environment: MESHCVT_BENCH_REPEAT (runs per timing row, the fastest is shown; default 5)
set -euo pipefail
cd "$(dirname "$0")/.."
repeat=${MESHCVT_BENCH_REPEAT:-5}
meshcvt=${1:-}
if [ -z "$meshcvt" ]; then
  cmake -S . -B build-approx-bench -G Ninja -DCMAKE_BUILD_TYPE=Release -DMESHCVT_TESTS=OFF >/dev/null
  cmake --build build-approx-bench --target meshcvt_cli >/dev/null
  meshcvt=build-approx-bench/meshcvt
fi

m=bench/data/meshes
if [ ! -f "$m/fandisk.off" ] || [ ! -f "$m/bones.off" ]; then
  echo "== fetching libcgal-demo (sample meshes) into $m" >&2
  tmp=$(mktemp -d)
  (cd "$tmp" && apt-get download libcgal-demo >/dev/null && dpkg-deb -x libcgal-demo_*.deb x)
  tar xzf "$tmp"/x/usr/share/doc/libcgal-dev/data.tar.gz -C "$tmp" data/meshes
  mkdir -p bench/data
  rm -rf "$m"
  mv "$tmp"/data/meshes "$m"
  rm -rf "$tmp"
fi
big=bench/data/fandisk_large-127k.ply
[ -f "$big" ] || "$meshcvt" subdivide "$m/fandisk_large.off" -k 1 -o "$big" -q

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
echo "machine: $(nproc) cores, $(lscpu | sed -n 's/^Model name: *//p'), load average $(cut -d' ' -f1-3 /proc/loadavg)"
echo "meshcvt: $meshcvt; every timing row is the fastest of $repeat runs"
echo

# One timing row: the fastest run by wall-clock partition + meshing; CPU = user + sys of the whole
# process (reading, topology and writing included).
row() {  # mesh args...
  local mesh=$1; shift
  for i in $(seq "$repeat"); do
    /usr/bin/time -f "%U %S" -o "$work/cpu.$i" "$meshcvt" approximate "$mesh" "$@" -o "$work/out.off" \
      --report "$work/r.$i.json" -q
  done
  python3 - "$work" "$repeat" "$mesh" "$*" <<'PY'
import json, sys
work, repeat, mesh, args = sys.argv[1], int(sys.argv[2]), sys.argv[3].split('/')[-1], sys.argv[4]
runs = []
for i in range(1, repeat + 1):
    r = json.load(open(f"{work}/r.{i}.json"))
    u, s = open(f"{work}/cpu.{i}").read().split()[-2:]
    runs.append((r["timings_s"]["partition"] + r["timings_s"]["meshing"], float(u) + float(s), r))
total, cpu, r = min(runs, key=lambda x: x[0])
t, o = r["timings_s"], r["output"]
ms = lambda x: f"{1000 * x:.1f}"
print(f"| {mesh} | {r['faces']} | {args} | {r['partition']['proxies']} / {r['regions']} | {r['relative_error']:.4f} | "
      f"{o['vertices']} | {o['triangles']} | {o['boundary_edges']} / {o['nonmanifold_edges']} / {o['flipped_triangles']} | "
      f"{ms(t['cluster'])} | {ms(t['refine'])} | {ms(t['meshing'])} | {ms(total)} | {ms(min(x[1] for x in runs))} |")
PY
}
echo "### Timings"
echo
echo "| mesh | faces | options | proxies / regions | E/A | V | T | boundary / non-manifold / flipped | cluster ms | teleport+rounds ms | meshing ms | partition+meshing ms | process CPU ms |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|"
row "$m/fandisk.off" -n 32
row "$m/fandisk.off" -n 32 --threads 1
row "$m/fandisk.off" -n 32 --no-teleport
row "$m/fandisk.off" --max-error 0.02
row "$m/bunny00.off" -n 100
row "$m/bunny00.off" -n 100 --no-teleport
row "$m/refined_elephant.off" -n 120
row "$big" -n 120
row "$m/knot2.off" -n 40
row "$m/bones.off" -n 60
row "$m/blobby_3cc.off" -n 30
echo

# Chord rule on fandisk, 32 proxies (the same partition for every row): output size and surface
# distance to the input (symmetric Hausdorff and RMS over 100k area-uniform samples per surface,
# relative to the bounding-box diagonal).
echo "### Chord subdivision on fandisk, 32 proxies: CGAL's default rule against the paper's"
echo
echo "| rule | V | T | Hausdorff / diagonal | RMS / diagonal |"
echo "|---|---|---|---|---|"
for rule in "cgal 5" "paper 0.1" "paper 0.2" "paper 0.3" "paper 0.5" "paper 1"; do
  set -- $rule
  "$meshcvt" approximate "$m/fandisk.off" -n 32 --chord-rule "$1" --chord-error "$2" -o "$work/c.off" \
    --report "$work/c.json" -q
  "$meshcvt" stats "$work/c.off" --ref "$m/fandisk.off" --json > "$work/s.json"
  python3 - "$work/c.json" "$work/s.json" "$1 $2" <<'PY'
import json, sys
r, s = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
o, e = r["output"], s["error"]
print(f"| {sys.argv[3]} | {o['vertices']} | {o['triangles']} | {e['hausdorff_rel']:.6f} | {e['rms_rel']:.6f} |")
PY
done
echo

# Components and boundary loops of input and output (meshcvt info).
echo "### Components and boundaries kept"
echo
echo "| mesh | options | components in / out | boundary loops in / out | output boundary edges (closed input: 0) |"
echo "|---|---|---|---|---|"
for c in "knot2.off -n 40" "bones.off -n 60" "blobby_3cc.off -n 30" "mannequin-devil.off -n 60" "fandisk.off -n 32"; do
  set -- $c
  file=$1; shift
  "$meshcvt" approximate "$m/$file" "$@" -o "$work/k.off" -q
  in_c=$("$meshcvt" info "$m/$file" | awk '/^components/{print $2}')
  in_b=$("$meshcvt" info "$m/$file" | awk '/^boundary loops/{print $3}')
  out_c=$("$meshcvt" info "$work/k.off" | awk '/^components/{print $2}')
  out_b=$("$meshcvt" info "$work/k.off" | awk '/^boundary loops/{print $3}')
  out_e=$("$meshcvt" info "$work/k.off" | awk '/^boundary edges/{print $3}')
  echo "| $file | $* | $in_c / $out_c | $in_b / $out_b | $out_e |"
done
