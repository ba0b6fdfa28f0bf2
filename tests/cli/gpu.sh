#!/usr/bin/env bash
# CLI test of the GPU engine: `meshcvt cluster --device gpu` on the scanned elephant writes the same
# labels as `--device cpu` (face for face), for every metric and both topology modes, and reports
# the GPU in its JSON report; a lost device or exhausted device memory (made on demand) stops a job
# cleanly. Without a Vulkan device it fails, unless MESHCVT_SKIP_GPU_TESTS=1.
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

# GPU faults ($MESHCVT_GPU_FAULT makes the healthy device fail on demand): a device lost in the
# middle of the iterations, or device memory running out at setup, stops `coarsen --device gpu`
# with exit 1 and a message naming the failure, and leaves neither the output nor a temporary
# file behind (an earlier file of that name stays as it was).
echo "an older file" >"$tmp/kept.ply"
for fault in lost:6:VK_ERROR_DEVICE_LOST memory:3:VK_ERROR_OUT_OF_DEVICE_MEMORY; do
  setting=${fault%:*}
  result=${fault##*:}
  mkdir "$tmp/$setting"
  MESHCVT_GPU_FAULT=$setting "$meshcvt" coarsen "$data/elephant.off" -n 300 -o "$tmp/$setting/out.ply" \
    --report "$tmp/$setting/report.json" --labels "$tmp/$setting/labels.txt" --device gpu >"$tmp/out" 2>"$tmp/err"
  rc=$?
  [ $rc -eq 1 ] || fail "$setting: expected exit 1, got $rc: $(cat "$tmp/err")"
  grep -q "$result" "$tmp/err" || fail "$setting: the message does not name $result: $(cat "$tmp/err")"
  [ -z "$(ls -A "$tmp/$setting")" ] || fail "$setting: files left behind: $(ls -A "$tmp/$setting")"
  MESHCVT_GPU_FAULT=$setting "$meshcvt" coarsen "$data/elephant.off" -n 300 -o "$tmp/kept.ply" --device gpu \
    2>/dev/null && fail "$setting: the second run succeeded"
  [ "$(cat "$tmp/kept.ply")" = "an older file" ] || fail "$setting: an existing output was overwritten"
done
# A malformed setting is a usage error (exit 2) naming the variable, not a device failure.
MESHCVT_GPU_FAULT=lost "$meshcvt" cluster "$data/elephant.off" -n 300 -o "$tmp/bad.ply" --device gpu 2>"$tmp/err"
[ $? -eq 2 ] || fail "MESHCVT_GPU_FAULT=lost: expected exit 2"
grep -q "MESHCVT_GPU_FAULT=lost" "$tmp/err" || fail "MESHCVT_GPU_FAULT=lost: message: $(cat "$tmp/err")"
