#!/usr/bin/env bash
# CLI test of the executable's large blocks (src/cli/huge_pages.cpp): each block of 2 MiB or more
# is a mapping of its own, asked to be backed by huge pages, unmapped when freed.
# - The elephant subdivided three times (356k faces) -> 3000 gives byte-identical coarse meshes
#   and labels with and without MESHCVT_HUGE_PAGES=0: the blocks hold what malloc's would.
# - Where the executable has its own operator new (not a sanitizer build) and strace can trace it,
#   the default run asks for huge pages (madvise MADV_HUGEPAGE) and MESHCVT_HUGE_PAGES=0 does not.
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
advised() {  # the madvise(MADV_HUGEPAGE) calls of a coarsening, with environment assignments
  # (without GLIBC_TUNABLES: glibc.malloc.hugetlb=1 would make malloc advise too)
  env -u GLIBC_TUNABLES "$@" strace -f -e trace=madvise -o "$tmp/trace.txt" "$cli" coarsen "$tmp/fine.ply" -n 3000 \
    -o "$tmp/traced.ply" --no-error -q || fail "coarsen under strace failed"
  grep -c MADV_HUGEPAGE "$tmp/trace.txt" || true
}
on=$(advised)
off=$(advised MESHCVT_HUGE_PAGES=0)
[ "$on" -gt 0 ] || fail "no block was advised to use huge pages"
[ "$off" -eq 0 ] || fail "MESHCVT_HUGE_PAGES=0 still advised $off block(s)"
echo "ok: $on blocks advised by default, none with MESHCVT_HUGE_PAGES=0"
