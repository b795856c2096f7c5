// forChunks (modules/core/parallel.h): every chunk exactly once with its bounds, exceptions
// reach the caller, and the loops of a process stay on the calling thread until they have
// taken the serial budget, then run on the pool.
#include <diffreg/core/parallel.h>

#include <catch2/catch.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>
#include <utility>
#include <vector>

namespace parallel = diffreg::parallel;

// First in this file, so in a process of its own under CTest: nothing has run a loop yet.
TEST_CASE("loops stay on the calling thread until they have taken the serial budget",
          "[core][parallel]") {
  REQUIRE_FALSE(parallel::poolStarted());
  const std::thread::id caller = std::this_thread::get_id();
  std::vector<int> order;
  parallel::forChunks(100, 10, [&](int chunk, int, int) {
    CHECK(std::this_thread::get_id() == caller);
    order.push_back(chunk);
  });
  CHECK(order == std::vector<int>{0, 1, 2, 3, 4, 5, 6, 7, 8, 9});
  CHECK_FALSE(parallel::poolStarted());

  // Five chunks of a quarter of the budget each: this loop passes it (and still runs on the
  // caller), and the pool runs the loops from then on when there is more than one thread.
  const auto quarter = std::chrono::duration<double>(parallel::serialBudget() / 4.0);
  parallel::forChunks(5, 1, [&](int, int, int) {
    CHECK(std::this_thread::get_id() == caller);
    std::this_thread::sleep_for(quarter);
  });
  CHECK(parallel::poolStarted() == (parallel::threads() > 1));

  std::vector<std::atomic<int>> visits(1000);
  parallel::forChunks(1000, 7, [&](int, int begin, int end) {
    for (int i = begin; i < end; ++i) ++visits[static_cast<size_t>(i)];
  });
  for (const auto& v : visits) CHECK(v.load() == 1);
}

TEST_CASE("forChunks calls every chunk once with its bounds", "[core][parallel]") {
  for (const auto& [n, grain] : std::vector<std::pair<int, int>>{
           {1, 1}, {5, 10}, {10, 10}, {11, 10}, {1000, 7}, {4096, 1024}, {100000, 333}}) {
    const int chunks = parallel::numChunks(n, grain);
    CHECK(chunks == (n + grain - 1) / grain);
    std::vector<std::atomic<int>> calls(static_cast<size_t>(chunks));
    std::vector<int> begins(static_cast<size_t>(chunks)), ends(static_cast<size_t>(chunks));
    parallel::forChunks(n, grain, [&](int chunk, int begin, int end) {
      ++calls[static_cast<size_t>(chunk)];
      begins[static_cast<size_t>(chunk)] = begin;
      ends[static_cast<size_t>(chunk)] = end;
    });
    for (int c = 0; c < chunks; ++c) {
      CHECK(calls[static_cast<size_t>(c)].load() == 1);
      CHECK(begins[static_cast<size_t>(c)] == c * grain);
      CHECK(ends[static_cast<size_t>(c)] == std::min(n, (c + 1) * grain));
    }
  }
  int called = 0;
  parallel::forChunks(0, 4, [&](int, int, int) { ++called; });
  CHECK(called == 0);
  CHECK(parallel::numChunks(0, 4) == 1);
}

TEST_CASE("per-chunk sums combined in chunk order do not depend on the threads",
          "[core][parallel]") {
  const int n = 200000, grain = 1000;
  std::vector<double> values(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) values[static_cast<size_t>(i)] = 1.0 / (1.0 + i % 977);
  const auto sum = [&] {
    std::vector<double> partial(static_cast<size_t>(parallel::numChunks(n, grain)), 0.0);
    parallel::forChunks(n, grain, [&](int chunk, int begin, int end) {
      for (int i = begin; i < end; ++i)
        partial[static_cast<size_t>(chunk)] += values[static_cast<size_t>(i)];
    });
    double total = 0.0;
    for (double p : partial) total += p;
    return total;
  };
  double inOrder = 0.0;
  for (int c = 0; c < parallel::numChunks(n, grain); ++c) {
    double p = 0.0;
    for (int i = c * grain; i < std::min(n, (c + 1) * grain); ++i)
      p += values[static_cast<size_t>(i)];
    inOrder += p;
  }
  for (int repeat = 0; repeat < 20; ++repeat) CHECK(sum() == inOrder);
}

TEST_CASE("an exception thrown by a body reaches the caller", "[core][parallel]") {
  CHECK_THROWS_AS(parallel::forChunks(64, 1,
                                      [](int chunk, int, int) {
                                        if (chunk == 17) throw std::runtime_error("chunk 17");
                                      }),
                  std::runtime_error);
  // The loops go on working afterwards.
  std::atomic<int> calls{0};
  parallel::forChunks(64, 1, [&](int, int, int) { ++calls; });
  CHECK(calls.load() == 64);
}

TEST_CASE("threads() counts the processors the process may use, 1 to 8", "[core][parallel]") {
  CHECK(parallel::threads() >= 1);
  CHECK(parallel::threads() <= 8);
  CHECK(parallel::threads() <= static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
}
