// meshcvt: the worker pool (see parallel.h).
#include "parallel.h"

#include <algorithm>
#include <chrono>
#include <exception>

namespace meshcvt {

WorkerPool::WorkerPool(unsigned threads) {
  if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
  threads_ = threads;
  for (unsigned i = 1; i < threads_; ++i) workers_.emplace_back([this] { worker_loop(); });
}

WorkerPool::~WorkerPool() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_.store(true);
  }
  wake_.notify_all();
  for (auto& t : workers_) t.join();
}

static void run_range(const std::function<void(size_t, size_t, unsigned)>& fn, size_t count, unsigned parts,
                      unsigned id) {
  size_t begin = count * id / parts, end = count * (id + 1) / parts;
  if (begin < end) fn(begin, end, id);
}

namespace {
// How long a thread polls before it sleeps. Long enough to cover the serial stretch between two
// passes of an iteration (tens of microseconds), short enough that an idle pool stops using a
// core at once to a person's eye. Measured round trip of an empty run() on the 2-core VM: 50 us
// sleeping, 0.3-0.4 us polling.
constexpr auto kSpin = std::chrono::microseconds(300);

void cpu_relax() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#endif
}

// Polls `done` (cheap, checked often) until it holds or kSpin has passed; returns whether it holds.
// The first few polls only pause (the usual handoff within an iteration takes 0.3-0.4 us); after
// that it yields the core between polls. Two reasons: on a machine busy with other work (ctest -j,
// other processes) a polling thread must not hold a core a working thread could use (pure polling
// made the 1.2M bunny 3x slower beside two busy processes on the 2-core VM), and the scheduler
// sometimes starts a new worker on the caller's own core and leaves it there for tens of
// milliseconds (a polling thread always looks cache-hot): then the thread waited for runs only
// when the poller yields. 4096 pure polls (~100 us) before the first yield made fandisk -> 1000
// take 17 instead of 8 ms in about half of the runs (both threads on one core, forced with
// taskset: Lloyd steps 9.6 ms instead of 3.3); 64 polls: 9.5 ms every time, the 1.2M bunny the
// same within noise (785 vs 787 ms, 747 vs 744 ms).
constexpr int kPurePolls = 64;

template <class Done>
bool spin_until(const Done& done) {
  for (int i = 0; i < kPurePolls; ++i) {
    if (done()) return true;
    cpu_relax();
  }
  const auto deadline = std::chrono::steady_clock::now() + kSpin;
  for (;;) {
    for (int i = 0; i < 16; ++i) {
      if (done()) return true;
      cpu_relax();
    }
    if (std::chrono::steady_clock::now() >= deadline) return done();
    std::this_thread::yield();
  }
}
}  // namespace

void WorkerPool::run_claimed(uint32_t generation) {
  for (;;) {
    uint64_t claim = claim_.load(std::memory_order_acquire);
    uint32_t range;
    do {
      range = uint32_t(claim);
      if (claim >> 32 != generation || range >= threads_) return;  // another job, or nothing left
    } while (!claim_.compare_exchange_weak(claim, claim + 1, std::memory_order_acq_rel, std::memory_order_acquire));
    // The claim holds the job: the caller does not return, nor publish another, before this range
    // is finished, so job_ and count_ are this generation's.
    try {
      run_range(*job_, count_, threads_, range);
    } catch (...) {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!error_) error_ = std::current_exception();
    }
    if (pending_.fetch_sub(1, std::memory_order_acq_rel) == 1) {
      std::lock_guard<std::mutex> lock(mutex_);  // (the caller checks pending_ under it before sleeping)
      done_.notify_one();
    }
  }
}

void WorkerPool::worker_loop() {
  unsigned seen = 0;
  for (;;) {
    auto ready = [&] { return stop_.load(std::memory_order_acquire) || generation_.load(std::memory_order_acquire) != seen; };
    if (!spin_until(ready)) {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, ready);
    }
    if (stop_.load(std::memory_order_acquire)) return;
    seen = generation_.load(std::memory_order_acquire);
    run_claimed(seen);
  }
}

void WorkerPool::run(size_t count, const std::function<void(size_t, size_t, unsigned)>& fn, size_t min_parallel) {
  // Small jobs are not worth waking anybody for.
  if (threads_ == 1 || count < std::max<size_t>(min_parallel, 2)) {
    if (count) fn(0, count, 0);
    return;
  }
  uint32_t generation;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    job_ = &fn;
    count_ = count;
    error_ = nullptr;
    pending_.store(threads_, std::memory_order_relaxed);
    generation = generation_.load(std::memory_order_relaxed) + 1;
    claim_.store(uint64_t(generation) << 32, std::memory_order_release);
    generation_.store(generation, std::memory_order_release);
  }
  wake_.notify_all();
  run_claimed(generation);  // the caller takes ranges too, all of them if nobody else comes
  auto finished = [&] { return pending_.load(std::memory_order_acquire) == 0; };
  if (!spin_until(finished)) {
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, finished);
  }
  std::lock_guard<std::mutex> lock(mutex_);  // error_ as the threads left it
  if (error_) std::rethrow_exception(error_);
}

}  // namespace meshcvt
