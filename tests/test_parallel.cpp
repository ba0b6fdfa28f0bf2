// Tests of the worker pool (src/parallel.h): every index is run exactly once, in the same ranges
// for any number of back-to-back runs, whether the workers were polling or asleep when a run came;
// a worker's exception reaches the caller and leaves the pool usable.
#include <doctest/doctest.h>

#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>
#include <vector>

#include "parallel.h"

using meshcvt::WorkerPool;

namespace {
// Runs `count` items through the pool and checks each was visited once, by contiguous ranges
// whose worker ids are in [0, pool.size()).
void check_cover(WorkerPool& pool, size_t count, size_t min_parallel) {
  std::vector<std::atomic<int>> hits(count);
  std::atomic<bool> bad_worker{false};
  pool.run(count, [&](size_t begin, size_t end, unsigned w) {
    if (w >= pool.size() || begin >= end) bad_worker = true;
    for (size_t i = begin; i < end; ++i) hits[i].fetch_add(1);
  }, min_parallel);
  CHECK_FALSE(bad_worker.load());
  size_t wrong = 0;
  for (auto& h : hits) wrong += h.load() != 1;
  CHECK(wrong == 0);
}
}  // namespace

TEST_CASE("worker pool: every index once, back to back and after the workers fell asleep") {
  for (unsigned threads : {1u, 2u, 3u}) {
    CAPTURE(threads);
    WorkerPool pool(threads);
    for (int run = 0; run < 2000; ++run) check_cover(pool, size_t(run % 7), 2);  // polling handoffs
    check_cover(pool, 100000, 2048);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));  // past the polling time: asleep
    check_cover(pool, 4096, 2);
    check_cover(pool, 1, 2);  // below min_parallel: the caller alone
  }
}

TEST_CASE("worker pool: the same ranges every time") {
  WorkerPool pool(3);
  std::vector<size_t> first(3, 0), again(3, 0);
  auto record = [&](std::vector<size_t>& into) {
    pool.run(1000, [&](size_t begin, size_t, unsigned w) { into[w] = begin; });
  };
  record(first);
  for (int i = 0; i < 100; ++i) {
    record(again);
    CHECK(again == first);
  }
}

TEST_CASE("worker pool: an exception in a worker reaches the caller, the pool goes on") {
  WorkerPool pool(2);
  for (int round = 0; round < 50; ++round) {
    CHECK_THROWS_AS(pool.run(10000, [&](size_t begin, size_t, unsigned) {
      if (begin > 0) throw std::runtime_error("worker");  // only the second range starts above 0
    }), std::runtime_error);
    CHECK_THROWS_AS(pool.run(10000, [&](size_t begin, size_t, unsigned) {
      if (begin == 0) throw std::runtime_error("caller");
    }), std::runtime_error);
    check_cover(pool, 10000, 2);
  }
}

TEST_CASE("worker pool: destroyed while its workers poll or sleep") {
  for (int i = 0; i < 20; ++i) {
    WorkerPool pool(2);
    check_cover(pool, 5000, 2);
    if (i % 2) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }  // each destructor must return: a hang fails the test by its ctest timeout
}
