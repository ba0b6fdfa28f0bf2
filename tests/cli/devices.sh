#!/usr/bin/env bash
# CLI test of `meshcvt devices`: lists the Vulkan devices (text and JSON), runs the GPU self-test
# with --check, and exits 1 with an install hint when there is no loader or no device.
# Usage: devices.sh /path/to/meshcvt /path/to/tests/data
set -u
meshcvt=$1
fail() { echo "FAIL: $*" >&2; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# No loader: simulated by pointing meshcvt at a loader that does not exist.
MESHCVT_VULKAN_LIBRARY=/nonexistent/libvulkan.so.1 "$meshcvt" devices >"$tmp/out" 2>"$tmp/err"
[ $? -eq 1 ] || fail "no loader: expected exit 1"
grep -q "no Vulkan loader" "$tmp/err" || fail "no loader: message missing: $(cat "$tmp/err")"
grep -q "install libvulkan1" "$tmp/err" || fail "no loader: install hint missing"
[ ! -s "$tmp/out" ] || fail "no loader: nothing should go to stdout"

# Loader without any driver: the loader's own variables hide every driver.
VK_ICD_FILENAMES=/nonexistent.json VK_DRIVER_FILES=/nonexistent.json "$meshcvt" devices --json >"$tmp/out" 2>"$tmp/err"
[ $? -eq 1 ] || fail "no driver: expected exit 1"
grep -q "no Vulkan device" "$tmp/err" || fail "no driver: message missing: $(cat "$tmp/err")"
grep -q "mesa-vulkan-drivers" "$tmp/err" || fail "no driver: install hint missing"

if [ "${MESHCVT_SKIP_GPU_TESTS:-0}" = 1 ]; then
  echo "skipping the device listing: MESHCVT_SKIP_GPU_TESTS=1"
  exit 0
fi

"$meshcvt" devices >"$tmp/out" 2>"$tmp/err" ||
  fail "meshcvt devices failed (GPU tests need a Vulkan device, e.g. lavapipe from mesa-vulkan-drivers; or set MESHCVT_SKIP_GPU_TESTS=1): $(cat "$tmp/err")"
grep -q "^gpu:0 " "$tmp/out" || fail "text: no gpu:0 line"
grep -q "maxStorageBufferRange" "$tmp/out" || fail "text: no maxStorageBufferRange"
grep -q "^--device auto: " "$tmp/out" || fail "text: no auto selection line"

# JSON: valid, one entry per device, fields typed as documented; --check runs the self-test on
# every usable device (with validation on when the suite sets MESHCVT_VALIDATION=1).
"$meshcvt" devices --json --check >"$tmp/json" 2>"$tmp/err" || fail "devices --json --check failed: $(cat "$tmp/err")"
! grep -q "vulkan validation" "$tmp/err" || fail "devices --check: validation messages: $(cat "$tmp/err")"
python3 - "$tmp/json" <<'PY' || fail "JSON check failed"
import json, sys
doc = json.load(open(sys.argv[1]))
devices = doc["devices"]
assert devices, "no devices"
for i, d in enumerate(devices):
    assert d["index"] == i
    assert d["type"] in ("discrete", "integrated", "virtual", "cpu", "other"), d["type"]
    assert isinstance(d["name"], str) and d["name"]
    assert d["heaps"] and all(h["bytes"] > 0 and isinstance(h["device_local"], bool) for h in d["heaps"])
    assert d["max_storage_buffer_range"] > 0 and d["max_workgroup_count_x"] >= 65535
    assert d["usable"] == (d["missing_features"] == [])
    if d["usable"]:
        assert d["self_test"]["passed"] is True, d["self_test"]
    else:
        assert "self_test" not in d
assert any(d["usable"] for d in devices), "no usable device"
assert doc["selection"]["gpu"].startswith("gpu:")
real = any(d["usable"] and d["type"] in ("discrete", "integrated") for d in devices)
assert doc["selection"]["auto"].startswith("gpu:" if real else "cpu"), doc["selection"]
PY
echo "ok"
