#!/usr/bin/env bash
# meshcvt against ACVD (Valette's ACVD and ACVDQ command-line tools) on the Table 1 cases: the same
# mesh and vertex count, every output measured by the same `meshcvt stats --ref INPUT` (area-uniform
# samples both ways, exact point-triangle distances) and `meshcvt info`, and each job timed from
# outside the process. Results go to bench/RESULTS.md ("meshcvt against ACVD").
#
# ACVD is not a Debian package: build it yourself (it needs libvtk9-dev, and qtbase5-dev for
# Debian's VTK CMake config) and pass the folder holding the ACVD and ACVDQ executables.
#   ACVD  in.off N 0 -d 0 -o DIR/ -of NAME.ply : isotropic clustering, then one quadric correction
#   ACVDQ in.off N 0 -d 0 -o DIR/              : clustering against each cluster's quadric-optimal
#                                                point, which is also the output vertex
# Both subdivide the input first when it has fewer than 10 x N vertices (their -s 10 default).
#
# usage: bench/acvd_compare.sh ACVD_BIN_DIR [path/to/meshcvt] [MESH N]...
#        (default cases: bunny00 -> 500, fandisk -> 1000, refined_elephant -> 1000, the 131k-face
#        sphere -> 200, and the 1.2M bunny -> 10000 when bench/data has it)
set -euo pipefail
cd "$(dirname "$0")/.."
acvd=${1:?usage: bench/acvd_compare.sh ACVD_BIN_DIR [meshcvt] [MESH N]...}
meshcvt=$(realpath "${2:-build/meshcvt}")
shift 2 || shift $#
cases=("$@")
if [ ${#cases[@]} -eq 0 ]; then
  bench/fetch_meshes.sh "$meshcvt" >/dev/null
  cases=(bench/data/meshes/bunny00.off 500 bench/data/meshes/fandisk.off 1000
         bench/data/meshes/refined_elephant.off 1000)
  [ -f bench/data/sphere-131k.off ] && cases+=(bench/data/sphere-131k.off 200)
  [ -f bench/data/bunny-1.2M.ply ] && cases+=(bench/data/bunny-1.2M.ply 10000)
fi
for tool in ACVD ACVDQ; do
  [ -x "$acvd/$tool" ] || { echo "acvd_compare: no executable $acvd/$tool" >&2; exit 1; }
done
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

timed() {  # timed SECONDS_FILE CMD...: wall seconds of CMD, its output discarded
  local start end
  start=$(date +%s.%N)
  "${@:2}" >/dev/null 2>&1
  end=$(date +%s.%N)
  python3 -c "print(f'{$end - $start:.3f}')" >"$1"
}

row() {  # row MESH N TOOL OUTPUT SECONDS
  if [ ! -s "$4" ]; then
    echo "| ${1##*/} | $2 | $3 | no output | | | | | | | | | $5 |"
    return
  fi
  "$meshcvt" info "$4" --json >"$out/info.json"
  "$meshcvt" stats "$4" --ref "$1" --json >"$out/stats.json"
  python3 - "$out/info.json" "$out/stats.json" "$1" "$2" "$3" "$5" <<'PY'
import json, sys
i = json.load(open(sys.argv[1])); s = json.load(open(sys.argv[2]))
q = s["quality"]; e = s["error"]
manifold = "yes" if i["nonmanifold_edges"] == 0 and i["nonmanifold_vertices"] == 0 else "no"
print(f"| {sys.argv[3].split('/')[-1]} | {sys.argv[4]} | {sys.argv[5]} | {i['vertices']} | {i['euler_characteristic']} | "
      f"{i['boundary_loops']} | {manifold} | {q['min_angle_deg']:.1f} | {q['angles_below_30']} | {q['q_avg']:.3f} | "
      f"{100 * e['hausdorff_rel']:.3f} | {100 * e['rms_rel']:.4f} | {sys.argv[6]} |")
PY
}

echo "machine: $(nproc) cores, $(uname -m); load average before: $(cut -d' ' -f1-3 /proc/loadavg)"
echo
echo "| mesh | n | tool | V out | chi | loops | manifold | min angle | angles < 30 | Q avg | Hausdorff % diag | RMS % diag | job s |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|"
for ((c = 0; c < ${#cases[@]}; c += 2)); do
  mesh=$(realpath "${cases[c]}") n=${cases[c + 1]}
  rm -f "$out"/*.ply  # a tool that fails must not leave the last case's output to be measured
  # ACVD and ACVDQ write into the current folder's -o prefix; run them inside $out.
  (cd "$out" && timed "$out/t" "$acvd/ACVD" "$mesh" "$n" 0 -d 0 -o "$out/" -of acvd.ply)
  row "$mesh" "$n" "ACVD" "$out/acvd.ply" "$(cat "$out/t")"
  (cd "$out" && timed "$out/t" "$acvd/ACVDQ" "$mesh" "$n" 0 -d 0 -o "$out/")
  row "$mesh" "$n" "ACVDQ" "$out/simplification.ply" "$(cat "$out/t")"
  for v in projected qem; do
    timed "$out/t" "$meshcvt" coarsen "$mesh" -n "$n" --vertex "$v" -o "$out/m.ply" --no-error -q
    row "$mesh" "$n" "meshcvt $v" "$out/m.ply" "$(cat "$out/t")"
  done
done
echo
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
