#!/usr/bin/env bash
# Fuzzes the mesh readers with libFuzzer: builds bench/fuzz/fuzz_*.cpp with clang, the whole library
# instrumented for coverage and checked by ASan + UBSan (build dir build-fuzz), then runs each
# reader's fuzzer for SECONDS of wall time, seeded with tests/data/io plus a few generated binary
# files, with a dictionary of the format's keywords. The corpus grows in bench/work/fuzz/<reader>
# (git-ignored) and is reused by the next run; crashes land in bench/work/fuzz/crashes/.
#
# usage: bench/fuzz/run.sh [SECONDS] [READER...]     READER: obj off ply stl (default: all four)
# needs: clang and libclang-rt-14-dev (scripts/install-deps.sh installs both)
set -euo pipefail
cd "$(dirname "$0")/../.."
seconds=${1:-60}
shift || true
readers=("$@")
[ ${#readers[@]} -gt 0 ] || readers=(obj off ply stl)

build=build-fuzz
work=bench/work/fuzz
CC=clang CXX=clang++ cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DMESHCVT_FUZZ=ON -DMESHCVT_TESTS=OFF -DMESHCVT_SANITIZE=ON \
  -DCMAKE_C_FLAGS="-fsanitize=fuzzer-no-link" -DCMAKE_CXX_FLAGS="-fsanitize=fuzzer-no-link" >/dev/null
cmake --build "$build" --target $(printf 'fuzz_%s ' "${readers[@]}")

mkdir -p "$work/seeds" "$work/crashes"
# Binary seeds the fuzzer would take long to invent: little/big-endian PLY with a quad, binary STL.
python3 - "$work/seeds" <<'PY'
import struct, sys
d = sys.argv[1]
for order, name in (("<", "binary_little_endian"), (">", "binary_big_endian")):
    head = ("ply\nformat %s 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
            "element face 2\nproperty list uchar int vertex_indices\nproperty int flags\n"
            "element extra 1\nproperty list ushort double values\nend_header\n" % name).encode()
    body = b"".join(struct.pack(order + "3f", *v) for v in ((0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)))
    body += struct.pack(order + "B4ii", 4, 0, 1, 2, 3, 7) + struct.pack(order + "B3ii", 3, 0, 2, 3, 8)
    body += struct.pack(order + "H2d", 2, 0.5, 1.5)
    open("%s/%s.ply" % (d, name), "wb").write(head + body)
tris = ((0, 0, 0, 1, 0, 0, 1, 1, 0), (0, 0, 0, 1, 1, 0, 0, 1, 0))
stl = b"solid but binary".ljust(80, b" ") + struct.pack("<I", len(tris))
for t in tris:
    stl += struct.pack("<3f9fH", 0, 0, 1, *t, 0)
open("%s/binary.stl" % d, "wb").write(stl)
PY

dictionary() {
  case $1 in
    obj) printf '"v "\n"vn "\n"vt "\n"f "\n"/"\n"//"\n"-1"\n"1e39"\n"nan"\n"#"\n"\\x0d\\x0a"\n"mtllib "\n"usemtl "\n"g "\n"o "\n"s off"\n' ;;
    off) printf '"OFF"\n"COFF"\n"NOFF"\n"STCNOFF"\n"nOFF"\n"4OFF"\n"BINARY"\n"#"\n"\\x0a"\n"1e39"\n"nan"\n"-1"\n' ;;
    ply) printf '"ply\\x0a"\n"format ascii 1.0\\x0a"\n"format binary_little_endian 1.0\\x0a"\n"format binary_big_endian 1.0\\x0a"\n"element "\n"property "\n"list "\n"vertex "\n"face "\n"tristrips "\n"vertex_indices\\x0a"\n"vertex_index\\x0a"\n"end_header\\x0a"\n"comment "\n"uchar "\n"char "\n"short "\n"ushort "\n"int "\n"uint "\n"float "\n"double "\n"int8 "\n"uint32 "\n"float64 "\n"x\\x0a"\n"y\\x0a"\n"z\\x0a"\n' ;;
    stl) printf '"solid "\n"facet normal "\n"outer loop"\n"vertex "\n"endloop"\n"endfacet"\n"endsolid"\n"nan"\n' ;;
  esac
}

root=$PWD
failed=()
for r in "${readers[@]}"; do
  corpus="$work/$r"
  mkdir -p "$corpus"
  dictionary "$r" > "$work/$r.dict"
  echo "== fuzz_$r for ${seconds}s"
  # -timeout: one input taking over 10 s counts as a hang; -rss_limit_mb: a lying header must not
  # make a reader allocate past this; -max_len: room for a few thousand faces.
  status=0
  TIMEFORMAT="cpu time: %U s user + %S s system, %R s wall"
  time { (cd "$work/crashes" && ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    "$root/$build/fuzz_$r" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=65536 \
      -dict="$root/$work/$r.dict" -print_final_stats=1 \
      "$root/$corpus" "$root/tests/data/io" "$root/$work/seeds") > "$work/$r.log" 2>&1 || status=$?; }
  grep -E "INITED|Done [0-9]+ runs|stat::number_of_executed_units|stat::new_units_added|ERROR|SUMMARY|Test unit written" \
    "$work/$r.log" || true
  if [ "$status" -ne 0 ]; then
    failed+=("$r")
    echo "!! fuzz_$r failed (exit $status); log: $work/$r.log"
  fi
done
if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzzers that found a problem: ${failed[*]}"
  exit 1
fi
