#!/usr/bin/env bash
# CLI test of the GPU engine: `meshcvt cluster --device gpu` on the scanned elephant writes the same
# labels as `--device cpu` (face for face), for every metric and both topology modes, and reports
# the GPU in its JSON report. Without a Vulkan device it fails, unless MESHCVT_SKIP_GPU_TESTS=1.
# Usage: gpu.sh /path/to/meshcvt /path/to/tests/data
set -u
meshcvt=$1
data=$2
fail() { echo "FAIL: $*" >&2; exit 1; }
[ "${MESHCVT_SKIP_GPU_TESTS:-}" = 1 ] && { echo "skipped: MESHCVT_SKIP_GPU_TESTS=1"; exit 0; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

run() {  # run NAME DEVICE ARGS...
  local name=$1 device=$2
  shift 2
  "$meshcvt" cluster "$data/elephant.off" -o "$tmp/$name-$device.ply" --labels "$tmp/$name-$device.txt" \
    --report "$tmp/$name-$device.json" --device "$device" -q "$@" 2>"$tmp/stderr" ||
    fail "$name on $device failed: $(cat "$tmp/stderr")"
}

for spec in "cvt-preserving:-n 200 --metric cvt" "ccvt-paper:-n 60 --metric ccvt --topology paper" \
            "l21-preserving:-n 30 --metric l21"; do
  name=${spec%%:*}
  args=${spec#*:}
  # shellcheck disable=SC2086
  run "$name" cpu $args
  # shellcheck disable=SC2086
  run "$name" gpu $args
  [ "$(wc -l <"$tmp/$name-cpu.txt")" -eq 5558 ] || fail "$name: expected 5558 labels"
  cmp -s "$tmp/$name-cpu.txt" "$tmp/$name-gpu.txt" || fail "$name: GPU labels differ from the CPU's"
  python3 - "$tmp/$name-cpu.json" "$tmp/$name-gpu.json" <<'PY' || fail "$name: reports differ"
import json, sys
cpu, gpu = (json.load(open(p)) for p in sys.argv[1:])
def find(d, key):
    if isinstance(d, dict):
        if key in d: return d[key]
        for v in d.values():
            r = find(v, key)
            if r is not None: return r
    return None
assert find(cpu, "iterations") == find(gpu, "iterations"), "iteration counts differ"
assert find(cpu, "device") != find(gpu, "device"), "the GPU run did not report a GPU device"
strip = lambda h: [(r.get("energy"), r.get("moves")) for r in h]
assert strip(cpu["history"]) == strip(gpu["history"]), "energy/moves histories differ"
PY
done
