// meshcvt: the worker pool (see parallel.h).
#include "parallel.h"

#include <algorithm>
#include <exception>

namespace meshcvt {

WorkerPool::WorkerPool(unsigned threads) {
  if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
  threads_ = threads;
  for (unsigned i = 1; i < threads_; ++i) workers_.emplace_back([this, i] { worker_loop(i); });
}

WorkerPool::~WorkerPool() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  for (auto& t : workers_) t.join();
}

static void run_range(const std::function<void(size_t, size_t, unsigned)>& fn, size_t count, unsigned parts,
                      unsigned id) {
  size_t begin = count * id / parts, end = count * (id + 1) / parts;
  if (begin < end) fn(begin, end, id);
}

void WorkerPool::worker_loop(unsigned id) {
  unsigned seen = 0;
  for (;;) {
    const std::function<void(size_t, size_t, unsigned)>* job;
    size_t count;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
      if (stop_) return;
      seen = generation_;
      job = job_;
      count = count_;
    }
    try {
      run_range(*job, count, threads_, id);
    } catch (...) {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!error_) error_ = std::current_exception();
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (--pending_ == 0) done_.notify_one();
    }
  }
}

void WorkerPool::run(size_t count, const std::function<void(size_t, size_t, unsigned)>& fn, size_t min_parallel) {
  // Small jobs are not worth waking anybody for.
  if (threads_ == 1 || count < std::max<size_t>(min_parallel, 2)) {
    if (count) fn(0, count, 0);
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    job_ = &fn;
    count_ = count;
    pending_ = threads_ - 1;
    error_ = nullptr;
    ++generation_;
  }
  wake_.notify_all();
  std::exception_ptr mine;
  try {
    run_range(fn, count, threads_, 0);
  } catch (...) {
    mine = std::current_exception();
  }
  std::unique_lock<std::mutex> lock(mutex_);
  done_.wait(lock, [&] { return pending_ == 0; });
  if (mine) std::rethrow_exception(mine);
  if (error_) std::rethrow_exception(error_);
}

}  // namespace meshcvt
