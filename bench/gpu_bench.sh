#!/usr/bin/env bash
# Benchmark of the GPU clustering engine next to the CPU engine: `meshcvt cluster -n 10000` on
# bunny00 (75k faces, CGAL's demo mesh) and on bunny00 subdivided 2 and 3 times (1.2M, 4.8M faces),
# --device cpu and --device gpu, printing iterations, iterate time, time per iteration, the
# initialization (and its Lloyd steps), the setup not hidden by it, the clustering's total and the
# topology built before it, from the JSON report, and whether the labels are identical.
# Builds meshcvt (release) in build-gpu-bench/; fetches bunny00 with `apt-get download libcgal-demo`
# into bench/data/ (git-ignored, never committed).
# usage: bench/gpu_bench.sh [--quick]   (--quick: skip the 4.8M-face mesh)
#        environment: MESHCVT_BENCH_CLUSTERS (default 10000), MESHCVT_BENCH_DEVICE (default gpu),
#        MESHCVT_BENCH_BIN (a meshcvt binary already built in release; skips the build),
#        MESHCVT_BENCH_PEAK_GBPS (the device's peak memory bandwidth in GB/s: also runs
#        gpu_kernel_bench on each mesh, the boundary kernel's GPU time and its share of that peak),
#        MESHCVT_BENCH_KERNEL_BIN (gpu_kernel_bench already built; default: built beside meshcvt)
set -euo pipefail
cd "$(dirname "$0")/.."
quick=0
[ "${1:-}" = "--quick" ] && quick=1
clusters=${MESHCVT_BENCH_CLUSTERS:-10000}
gpu=${MESHCVT_BENCH_DEVICE:-gpu}

meshcvt=${MESHCVT_BENCH_BIN:-}
if [ -z "$meshcvt" ]; then
  cmake -S . -B build-gpu-bench -G Ninja -DCMAKE_BUILD_TYPE=Release -DMESHCVT_TESTS=OFF >/dev/null
  cmake --build build-gpu-bench --target meshcvt_cli gpu_kernel_bench >/dev/null
  meshcvt=build-gpu-bench/meshcvt
fi
kernel_bench=${MESHCVT_BENCH_KERNEL_BIN:-$(dirname "$meshcvt")/bench/gpu_kernel_bench}

data=bench/data
mkdir -p "$data"
if [ ! -f "$data/bunny00.off" ]; then
  echo "== fetching libcgal-demo (sample meshes) into $data"
  tmp=$(mktemp -d)
  (
    cd "$tmp"
    apt-get download libcgal-demo >/dev/null
    dpkg-deb -x libcgal-demo_*.deb x
    tar xzf x/usr/share/doc/libcgal-dev/data.tar.gz data/meshes/bunny00.off
  )
  cp "$tmp/data/meshes/bunny00.off" "$data/bunny00.off"
  rm -rf "$tmp"
fi
[ -f "$data/bunny-1.2M.ply" ] || "$meshcvt" subdivide "$data/bunny00.off" -k 2 -o "$data/bunny-1.2M.ply" -q
meshes=("$data/bunny00.off" "$data/bunny-1.2M.ply")
if [ "$quick" = 0 ]; then
  [ -f "$data/bunny-4.8M.ply" ] || "$meshcvt" subdivide "$data/bunny00.off" -k 3 -o "$data/bunny-4.8M.ply" -q
  meshes+=("$data/bunny-4.8M.ply")
fi

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
echo "machine: $(nproc) cores, $(uname -sr); $clusters clusters, metric cvt, topology preserving"
printf '%-16s %-7s %10s %6s %11s %12s %9s %8s %8s %9s %10s\n' mesh device faces iter iterate_s ms_per_iter init_s lloyd_s setup_s total_s topology_s
for mesh in "${meshes[@]}"; do
  name=$(basename "$mesh")
  for device in cpu "$gpu"; do
    "$meshcvt" cluster "$mesh" -n "$clusters" -o "$work/out.ply" --labels "$work/labels-$device.txt" \
      --report "$work/report.json" --device "$device" -q
    python3 - "$work/report.json" "$name" "$device" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
t = r["timings_s"]
it = max(r["iterations"], 1)
print(f'{sys.argv[2]:<16} {sys.argv[3]:<7} {r["faces"]:>10} {r["iterations"]:>6} {t["iterate"]:>11.3f} '
      f'{1000 * t["iterate"] / it:>12.2f} {t["init"]:>9.3f} {t["init_lloyd"]:>8.3f} {t["setup"]:>8.3f} '
      f'{t["cluster_total"]:>9.3f} {t["topology"]:>10.3f}   [{r["device"]}]')
PY
  done
  if cmp -s "$work/labels-cpu.txt" "$work/labels-$gpu.txt"; then echo "  labels identical"; else echo "  LABELS DIFFER"; fi
  if [ -n "${MESHCVT_BENCH_PEAK_GBPS:-}" ]; then
    device_index=
    case "$gpu" in gpu:*) device_index=${gpu#gpu:} ;; esac
    # shellcheck disable=SC2086
    "$kernel_bench" "$mesh" "$clusters" "$MESHCVT_BENCH_PEAK_GBPS" $device_index || echo "  KERNEL BENCH FAILED"
  fi
done
