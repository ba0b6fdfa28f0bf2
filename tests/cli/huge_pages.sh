#!/usr/bin/env bash
# CLI test of the executable's large blocks (src/cli/huge_pages.cpp): each block of 2 MiB or more
# is a mapping of its own, asked to be backed by huge pages, unmapped when freed.
# - The elephant subdivided three times (356k faces) -> 3000 gives byte-identical coarse meshes
#   and labels with and without MESHCVT_HUGE_PAGES=0: the blocks hold what malloc's would.
# - Where the executable has its own operator new (not a sanitizer build) and strace can trace it,
#   the default run asks for huge pages (madvise MADV_HUGEPAGE) and MESHCVT_HUGE_PAGES=0 does not,
#   and (an input below 8 MB) malloc maps no block of its own between 128 KiB and 2 MiB: those come
#   from its heap and are reused there (main.cpp's prepare_allocator), and the heaps are given back
#   (madvise MADV_DONTNEED) no more often than with MESHCVT_HUGE_PAGES=0. Before, glibc's
#   threshold never rose, such arrays were fresh pages each time, and bunny00's clustering took 15%
#   longer; without the trim threshold, 28% longer.
# usage: huge_pages.sh /path/to/meshcvt /path/to/tests/data
set -euo pipefail
cli=$1
data=$2
source "$(dirname "$0")/prologue.bash"  # $tmp, fail

"$cli" subdivide "$data/elephant.off" -k 3 -o "$tmp/fine.ply" >/dev/null || fail "subdivide failed"
run() {  # tag, then environment assignments
  local tag=$1
  shift
  env "$@" "$cli" coarsen "$tmp/fine.ply" -n 3000 -o "$tmp/$tag.ply" --labels "$tmp/$tag.labels" --no-error -q ||
    fail "coarsen ($tag) failed"
}
run huge
run small MESHCVT_HUGE_PAGES=0
cmp -s "$tmp/huge.ply" "$tmp/small.ply" || fail "the coarse meshes differ with and without huge pages"
cmp -s "$tmp/huge.labels" "$tmp/small.labels" || fail "the labels differ with and without huge pages"

nm -C "$cli" >"$tmp/symbols.txt" 2>/dev/null || true
if ! grep -q " T operator new(unsigned long)$" "$tmp/symbols.txt"; then
  echo "note: this build keeps the sanitizer's operator new; madvise not checked"
  exit 0
fi
if ! command -v strace >/dev/null || ! strace -f -o /dev/null true 2>/dev/null; then
  echo "note: strace cannot trace here; madvise not checked"
  exit 0
fi
trace() {  # tag, then environment assignments: a coarsening's madvise and mmap calls in trace-TAG.txt
  # (without GLIBC_TUNABLES: glibc.malloc.hugetlb=1 would make malloc advise too)
  local tag=$1
  shift
  env -u GLIBC_TUNABLES "$@" strace -f -e trace=madvise,mmap -o "$tmp/trace-$tag.txt" "$cli" coarsen "$tmp/fine.ply" \
    -n 3000 -o "$tmp/traced.ply" --no-error -q || fail "coarsen under strace failed ($tag)"
}
trace on
trace off MESHCVT_HUGE_PAGES=0
count() { grep -c "$1" "$tmp/trace-$2.txt" || true; }
on=$(count MADV_HUGEPAGE on)
off=$(count MADV_HUGEPAGE off)
[ "$on" -gt 0 ] || fail "no block was advised to use huge pages"
[ "$off" -eq 0 ] || fail "MESHCVT_HUGE_PAGES=0 still advised $off block(s)"
# MADV_DONTNEED: a thread's stack when it ends, and an arena's heap trimmed above its threshold.
returned_on=$(count MADV_DONTNEED on)
returned_off=$(count MADV_DONTNEED off)
[ "$returned_on" -le "$returned_off" ] ||
  fail "memory given back $returned_on times with huge pages, $returned_off without: trimmed too often"
# Anonymous mappings of 128 KiB to 2 MiB: malloc's blocks of their own (thread stacks, arenas and
# the blocks of huge_pages.cpp are larger; libraries are file mappings).
[ "$(stat -c %s "$tmp/fine.ply")" -lt $((8 << 20)) ] || fail "the test input is not below 8 MB"
own=$(grep -o 'mmap(NULL, [0-9]*, PROT_READ|PROT_WRITE, MAP_PRIVATE|MAP_ANONYMOUS, -1' "$tmp/trace-on.txt" |
  awk -F'[(,]' '$3 + 0 >= 131072 && $3 + 0 < 2097152' | wc -l)
[ "$own" -eq 0 ] || fail "malloc mapped $own block(s) of 128 KiB to 2 MiB on their own: $(count 'mmap(' on) mmaps"
echo "ok: $on blocks advised by default, none with MESHCVT_HUGE_PAGES=0"
