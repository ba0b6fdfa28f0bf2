// meshcvt: a small persistent worker pool. Work is split into chunks by index range; callers make
// results independent of the split (per-face outputs, or integer sums), so the thread count never
// changes a result.
#pragma once

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <system_error>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace meshcvt {

class WorkerPool {
 public:
  /// threads = 0: one per core. The calling thread takes part, so threads-1 workers are started.
  explicit WorkerPool(unsigned threads);
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  unsigned size() const { return threads_; }

  /// Runs fn(begin, end, worker) over [0, count) in size() contiguous ranges (fewer when count is
  /// small) and returns when all are done. `worker` is the range's index in [0, size()): each range
  /// runs once, on whichever thread claims it first, the caller's included, so a worker that wakes
  /// late (a halted virtual CPU can take milliseconds) delays nothing: the others take its range.
  /// An exception thrown by fn is rethrown here (the first one). Below `min_parallel` items the
  /// calling thread does all of it: the default suits items of a few nanoseconds (faces); pass
  /// less for heavy items (clusters).
  void run(size_t count, const std::function<void(size_t, size_t, unsigned)>& fn, size_t min_parallel = 2048);

 private:
  void worker_loop();
  // Claims and runs ranges of job `generation` until none is left.
  void run_claimed(uint32_t generation);
  unsigned threads_;
  std::vector<std::thread> workers_;
  // A new job is published by raising generation_ (under mutex_, for the sleepers); workers and
  // the caller first spin on the atomics for a while (kSpin, parallel.cpp) and only then sleep on
  // the condition variables: a sleeping thread takes ~50 us to wake on a VM, and an iteration of
  // the engine runs several short passes in a row.
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  const std::function<void(size_t, size_t, unsigned)>* job_ = nullptr;
  size_t count_ = 0;
  // The job's generation (high 32 bits) and its next unclaimed range (low 32 bits): a claim is a
  // compare-and-swap on both, so a thread still holding an older generation can claim nothing.
  std::atomic<uint64_t> claim_{0};
  std::atomic<unsigned> generation_{0}, pending_{0};  // pending_: ranges not yet finished
  std::atomic<bool> stop_{false};
  std::exception_ptr error_;
};

// Threads for one-shot passes over `count` items (run_ranges), at most kMaxRangeThreads:
// `requested`, or for 0 one per core and at most one per kItemsPerRangeThread items (a thread
// costs ~50 us to start). The passes gain little from more: build_topology on the 4.8M bunny took
// 362 ms on 8 threads and 273 ms on 16 (bench/RESULTS.md).
constexpr unsigned kMaxRangeThreads = 16;
constexpr size_t kItemsPerRangeThread = 32768;
inline unsigned range_threads(size_t count, unsigned requested) {
  if (requested != 0) return std::min(requested, kMaxRangeThreads);
  const size_t by_size = std::max<size_t>(1, count / kItemsPerRangeThread);
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  return unsigned(std::min<size_t>({cores, by_size, kMaxRangeThreads}));
}

// Bounds of `parts` ranges of [0, count) of about equal size, for run_ranges.
inline std::vector<uint32_t> even_bounds(size_t count, unsigned parts) {
  std::vector<uint32_t> bounds;
  for (unsigned p = 0; p <= parts; ++p) bounds.push_back(uint32_t(count * p / parts));
  return bounds;
}

// One-shot alternative to WorkerPool for a single parallel pass with uneven ranges (topology,
// subdivision): runs fn(begin, end, part) for the ranges [bounds[p], bounds[p+1]), part 0 on the calling thread,
// and rethrows the first exception (e.g. bad_alloc) after every thread has finished.
template <class Fn>
void run_ranges(const std::vector<uint32_t>& bounds, const Fn& fn) {
  size_t parts = bounds.size() - 1;
  std::vector<std::exception_ptr> errors(parts);
  auto guarded = [&](size_t p) {
    try {
      fn(bounds[p], bounds[p + 1], p);
    } catch (...) {
      errors[p] = std::current_exception();
    }
  };
  std::vector<std::thread> threads;
  for (size_t p = 1; p < parts; ++p) {
    try {
      threads.emplace_back(guarded, p);
    } catch (const std::system_error&) {
      guarded(p);  // no thread to be had: do that part here
    }
  }
  if (parts > 0) guarded(0);
  for (auto& t : threads) t.join();
  for (auto& e : errors)
    if (e) std::rethrow_exception(e);
}

}  // namespace meshcvt
