// meshcvt: a small persistent worker pool. Work is split into chunks by index range; callers make
// results independent of the split (per-face outputs, or integer sums), so the thread count never
// changes a result.
#pragma once

#include <condition_variable>
#include <cstddef>
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
  /// small) and returns when all are done. `worker` is in [0, size()). An exception thrown by fn is
  /// rethrown here (the first one).
  void run(size_t count, const std::function<void(size_t, size_t, unsigned)>& fn);

 private:
  void worker_loop(unsigned id);
  unsigned threads_;
  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  const std::function<void(size_t, size_t, unsigned)>* job_ = nullptr;
  size_t count_ = 0;
  unsigned generation_ = 0, pending_ = 0;
  bool stop_ = false;
  std::exception_ptr error_;
};

}  // namespace meshcvt
