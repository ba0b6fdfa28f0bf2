// meshcvt CLI: large allocations asked to be backed by transparent huge pages.
//
// Why: a job on a large mesh allocates a few dozen arrays of tens to hundreds of megabytes (the
// read buffers, the topology, the clustering's per-face arrays) and touches each page once as it
// fills them. With 4 KiB pages that is a page fault per 4 KiB; on a virtual machine whose page
// faults are slow, they were most of the reading, the topology and the subdivision (the 4.8M-face
// bunny -> 10k on the 2-core VM: 368k minor faults and 7.6 s; with this file 78k and 4.5-4.8 s,
// the same output; bench/RESULTS.md, "Table 1"). Linux backs a range with huge pages only where
// the system allows it (/sys/kernel/mm/transparent_hugepage/enabled: "always", or "madvise" and
// the range asked for it with madvise(MADV_HUGEPAGE)). The VM's kernel says "madvise" (its build
// default), and glibc's malloc asks only when GLIBC_TUNABLES sets glibc.malloc.hugetlb=1.
//
// So the CLI's global operator new takes every block of kHugeBlockBytes or more at a huge page's
// boundary and asks for huge pages for it, before anything touches it (a vector's storage is
// allocated, then filled). The block still comes from malloc (posix_memalign) and goes back with
// free, so nothing else changes: the advice is a hint, and where the system says "never" (or the
// call fails) the block is used as it is. MESHCVT_HUGE_PAGES=0 turns it off (with "madvise"
// defrag, a fault in an advised range may wait for the kernel to compact memory). Smaller blocks
// (the hierarchy's per-part arrays) stay on small pages; GLIBC_TUNABLES=glibc.malloc.hugetlb=1
// advises all of malloc's memory instead (57k faults, 4.3 s above). Only the executable does
// this: the library leaves its callers' allocator alone (README). Sanitizer builds keep their own
// operator new.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <new>

#if defined(__linux__) && !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
#include <sys/mman.h>

namespace {

// Blocks smaller than a huge page (2 MiB) are left alone: they cannot fill one.
constexpr std::size_t kHugeBlockBytes = std::size_t(2) << 20;
constexpr std::uintptr_t kHugePageBytes = std::uintptr_t(2) << 20;

void advise_huge_pages(void* block, std::size_t bytes) {
  // The whole huge pages inside the block: only those can be backed by one.
  const std::uintptr_t begin = (reinterpret_cast<std::uintptr_t>(block) + kHugePageBytes - 1) & ~(kHugePageBytes - 1);
  const std::uintptr_t end = (reinterpret_cast<std::uintptr_t>(block) + bytes) & ~(kHugePageBytes - 1);
  if (end > begin) (void)madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
}

// A block that starts on a huge page, so that only its last partial huge page stays on small pages
// (from malloc, a block of a few megabytes lost up to a huge page at each end: the 1.2M bunny's
// job kept 50k faults instead of 37k). Freed by free, as malloc's.
void* aligned_block(std::size_t bytes) {
  void* block = nullptr;
  return posix_memalign(&block, kHugePageBytes, bytes) == 0 ? block : nullptr;
}

bool huge_pages_wanted() {
  static const bool wanted = [] {
    const char* setting = std::getenv("MESHCVT_HUGE_PAGES");
    return !(setting && setting[0] == '0' && setting[1] == '\0');
  }();
  return wanted;
}

}  // namespace

void* operator new(std::size_t bytes) {
  void* block;
  const bool huge = bytes >= kHugeBlockBytes && huge_pages_wanted();
  // As the standard's: on failure the new-handler, else bad_alloc.
  while (!(block = huge ? aligned_block(bytes) : std::malloc(bytes == 0 ? 1 : bytes))) {
    const std::new_handler handler = std::get_new_handler();
    if (!handler) throw std::bad_alloc();
    handler();
  }
  if (huge) advise_huge_pages(block, bytes);
  return block;
}

void operator delete(void* block) noexcept { std::free(block); }
void operator delete(void* block, std::size_t) noexcept { std::free(block); }

#endif
