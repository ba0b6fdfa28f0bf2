// meshcvt CLI: large allocations asked to be backed by transparent huge pages.
//
// Why: a job on a large mesh allocates a few dozen arrays of tens to hundreds of megabytes (the
// read buffers, the topology, the clustering's per-face arrays) and touches each page once as it
// fills them. With 4 KiB pages that is a page fault per 4 KiB; on a virtual machine whose page
// faults are slow, they were most of the reading, the topology and the subdivision (the 4.8M-face
// bunny -> 10k on the 2-core VM: 368k minor faults and 7.5-7.9 s; with this file 78k and 4.7-5.6 s,
// the same output; bench/RESULTS.md, "Table 1"). Linux backs a range with huge pages only where
// the system allows it (/sys/kernel/mm/transparent_hugepage/enabled: "always", or "madvise" and
// the range asked for it with madvise(MADV_HUGEPAGE)). The VM's kernel says "madvise" (its build
// default), and glibc's malloc asks only when GLIBC_TUNABLES sets glibc.malloc.hugetlb=1.
//
// So the CLI's global operator new maps every block of kHugeBlockBytes or more on its own, at a
// huge page's boundary, and asks for huge pages for it before anything touches it (a vector's
// storage is allocated, then filled); operator delete unmaps it. Smaller blocks come from malloc
// and go back with free as before. The advice is a hint: where the system says "never" (or the
// call fails) the block is used as it is. MESHCVT_HUGE_PAGES=0 turns all of it off (with
// "madvise" defrag, a fault in an advised range may wait for the kernel to compact memory).
// GLIBC_TUNABLES=glibc.malloc.hugetlb=1 advises all of malloc's memory instead (57k faults, 4.3 s
// above). Only the executable does this: the library leaves its callers' allocator alone
// (README). Sanitizer builds keep their own operator new.
//
// malloc no longer sees these blocks, so its mmap threshold no longer rises past them (glibc
// raises it to the largest mapped block freed): main.cpp's prepare_allocator sets it, and the trim
// threshold, where glibc's own rule would have (bunny00 -> 500's clustering was 15% slower before).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <mutex>
#include <new>

#include "command.h"

namespace {
// Blocks smaller than a huge page (2 MiB) are left alone: they cannot fill one.
constexpr std::size_t kHugeBlockBytes = std::size_t(2) << 20;
}  // namespace

std::size_t meshcvt::cli::huge_page_block_bytes() { return kHugeBlockBytes; }

#if defined(__linux__) && !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
#include <sys/mman.h>
#include <unistd.h>

namespace {

constexpr std::uintptr_t kHugePageBytes = std::uintptr_t(2) << 20;

// The blocks mapped here, for operator delete to tell them from malloc's: few at a time (1024 of
// them would be 2 GiB or more), so a table under a mutex, searched only for pointers on a huge
// page's boundary (malloc's are there only by chance). A full table sends new blocks to malloc.
constexpr std::size_t kMaxBlocks = 1024;
std::mutex blocks_mutex;
std::uintptr_t block_start[kMaxBlocks];
std::size_t block_length[kMaxBlocks];
std::size_t block_count = 0;

bool huge_pages_wanted() {
  static const bool wanted = [] {
    const char* setting = std::getenv("MESHCVT_HUGE_PAGES");
    return !(setting && setting[0] == '0' && setting[1] == '\0');
  }();
  return wanted;
}

// A mapping of its own for the block, starting on a huge page and asked to be backed by huge
// pages before anything touches it; null where none is to be had (malloc's turn then). Not taken
// from malloc: its heap would keep the advice on ranges it later hands out in small pieces, and a
// freed block would stay resident there (a damaged camel -> 5210 with qem peaked at 483 MB instead
// of 426 MB so; mapped, 414 MB). Unmapped when freed, so the memory goes back at once.
void* map_block(std::size_t bytes) {
  static const std::size_t page = std::size_t(sysconf(_SC_PAGESIZE));
  if (bytes > SIZE_MAX - page - kHugePageBytes) return nullptr;  // (malloc fails it then)
  const std::size_t length = (bytes + page - 1) & ~(page - 1);
  const std::size_t span = length + kHugePageBytes;  // room to start on a huge page
  void* raw = mmap(nullptr, span, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (raw == MAP_FAILED) return nullptr;
  const std::uintptr_t first = reinterpret_cast<std::uintptr_t>(raw);
  const std::uintptr_t start = (first + kHugePageBytes - 1) & ~(kHugePageBytes - 1);
  if (start > first) munmap(raw, start - first);
  if (first + span > start + length) munmap(reinterpret_cast<void*>(start + length), first + span - (start + length));
  void* block = reinterpret_cast<void*>(start);
  (void)madvise(block, length, MADV_HUGEPAGE);  // a hint: where it fails the block is used as it is
  {
    std::lock_guard<std::mutex> lock(blocks_mutex);
    if (block_count < kMaxBlocks) {
      block_start[block_count] = start;
      block_length[block_count] = length;
      ++block_count;
      return block;
    }
  }
  munmap(block, length);
  return nullptr;
}

// Unmaps `block` if it is one of map_block's; whether it was.
bool unmap_block(void* block) {
  const std::uintptr_t start = reinterpret_cast<std::uintptr_t>(block);
  if (start & (kHugePageBytes - 1)) return false;
  std::size_t length = 0;
  {
    std::lock_guard<std::mutex> lock(blocks_mutex);
    std::size_t i = 0;
    while (i < block_count && block_start[i] != start) ++i;
    if (i == block_count) return false;
    length = block_length[i];
    --block_count;
    block_start[i] = block_start[block_count];
    block_length[i] = block_length[block_count];
  }
  munmap(block, length);
  return true;
}

}  // namespace

bool meshcvt::cli::maps_large_blocks() { return huge_pages_wanted(); }

void* operator new(std::size_t bytes) {
  if (bytes >= kHugeBlockBytes && huge_pages_wanted())
    if (void* block = map_block(bytes)) return block;
  void* block;
  // As the standard's: on failure the new-handler, else bad_alloc.
  while (!(block = std::malloc(bytes == 0 ? 1 : bytes))) {
    const std::new_handler handler = std::get_new_handler();
    if (!handler) throw std::bad_alloc();
    handler();
  }
  return block;
}

void operator delete(void* block) noexcept {
  if (block && !unmap_block(block)) std::free(block);
}
void operator delete(void* block, std::size_t) noexcept { operator delete(block); }

#else

bool meshcvt::cli::maps_large_blocks() { return false; }

#endif
