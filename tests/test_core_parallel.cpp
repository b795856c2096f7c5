// forChunks (modules/core/parallel.h): every chunk exactly once with its bounds, exceptions
// reach the caller, and the loops of a process stay on the calling thread until they have
// taken the serial budget, then run on the pool's threads.
#include <diffreg/core/file.h>
#include <diffreg/core/parallel.h>

#include <sys/wait.h>
#include <unistd.h>
#include <catch2/catch.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <mutex>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace parallel = diffreg::parallel;

namespace {

constexpr const char* kFreshCase =
    "loops stay on the calling thread until they have taken the serial budget";
constexpr const char* kFreshVariable = "DIFFREG_TEST_FRESH_PROCESS";

// The serial budget and the pool belong to the process, and the other cases spend the one and
// start the other. So the case that needs a process in which no loop has run yet runs in a new
// process of this test program, alone, whatever order the cases run in here (Catch2's
// --order rand, a filter); `true` when this is that process.
bool inFreshProcess() {
  if (std::getenv(kFreshVariable)) return true;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe");
  const std::filesystem::path log = std::filesystem::temp_directory_path() /
                                    ("diffreg-parallel-" + std::to_string(::getpid()) + ".txt");
  // --warn NoTests: a name that matches no case fails instead of passing with nothing run.
  const std::string command = std::string(kFreshVariable) + "=1 '" + self.string() +
                              "' --warn NoTests '" + kFreshCase + "' > '" + log.string() + "' 2>&1";
  const int status = std::system(command.c_str());
  const std::string output =
      diffreg::readFileLimited(log.string(), "test output", diffreg::limits::textBytes);
  std::filesystem::remove(log);
  INFO(output);
  CHECK(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 0);
  return false;
}

}  // namespace

TEST_CASE(kFreshCase, "[core][parallel]") {
  if (!inFreshProcess()) return;
  REQUIRE_FALSE(parallel::poolStarted());
  const std::thread::id caller = std::this_thread::get_id();
  std::vector<int> order;
  parallel::forChunks(100, 10, [&](int chunk, int, int) {
    CHECK(std::this_thread::get_id() == caller);
    order.push_back(chunk);
  });
  CHECK(order == std::vector<int>{0, 1, 2, 3, 4, 5, 6, 7, 8, 9});
  // A loop inside a body as well.
  int inner = 0;
  parallel::forChunks(4, 1, [&](int, int, int) {
    parallel::forChunks(10, 1, [&](int, int, int) {
      CHECK(std::this_thread::get_id() == caller);
      ++inner;
    });
  });
  CHECK(inner == 40);
  CHECK_FALSE(parallel::poolStarted());

  // Forty chunks of an eighth of the budget each: the chunks that run before the budget is
  // spent stay on the caller, the rest go to the pool when there is more than one thread.
  const auto eighth = std::chrono::duration<double>(parallel::serialBudget() / 8.0);
  std::vector<std::atomic<int>> visits(40);
  std::atomic<int> beforePool{0};
  parallel::forChunks(40, 1, [&](int chunk, int, int) {
    if (!parallel::poolStarted()) {
      CHECK(std::this_thread::get_id() == caller);
      ++beforePool;
    }
    ++visits[static_cast<size_t>(chunk)];
    std::this_thread::sleep_for(eighth);
  });
  for (const auto& v : visits) CHECK(v.load() == 1);
  CHECK(parallel::poolStarted() == (parallel::threads() > 1));
  if (parallel::threads() > 1) {
    CHECK(beforePool.load() >= 1);
    CHECK(beforePool.load() <= 9);  // at least an eighth of the budget each
  }
}

TEST_CASE("once the pool runs, chunks run on more than one thread", "[core][parallel]") {
  if (parallel::threads() == 1) return;  // one processor: every loop runs on its caller
  // Start the pool (the budget is the process's: one long loop spends it).
  const auto budget = std::chrono::duration<double>(parallel::serialBudget());
  parallel::forChunks(2, 1, [&](int, int, int) { std::this_thread::sleep_for(budget); });
  REQUIRE(parallel::poolStarted());
  // Two chunks that wait for each other: only two threads finish them before the deadline.
  std::mutex mutex;
  std::set<std::thread::id> ids;
  std::atomic<int> arrived{0};
  parallel::forChunks(2, 1, [&](int, int, int) {
    {
      const std::lock_guard<std::mutex> lock(mutex);
      ids.insert(std::this_thread::get_id());
    }
    ++arrived;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (arrived.load() < 2 && std::chrono::steady_clock::now() < deadline)
      std::this_thread::yield();
  });
  CHECK(ids.size() == 2);
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
  // Near INT_MAX the bounds do not overflow.
  const int most = std::numeric_limits<int>::max(), half = 1 << 30;
  CHECK(parallel::numChunks(most, half) == 2);
  std::vector<std::pair<int, int>> bounds(2);
  parallel::forChunks(most, half, [&](int chunk, int begin, int end) {
    bounds[static_cast<size_t>(chunk)] = {begin, end};
  });
  CHECK(bounds[0] == std::pair<int, int>(0, half));
  CHECK(bounds[1] == std::pair<int, int>(half, most));
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
