#include <diffreg/core/parallel.h>

#include <sched.h>
#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <thread>

namespace diffreg::parallel {
namespace {

// Set once the loops run on the pool; until then the time they took on the calling thread.
std::atomic<bool> g_pool{false};
std::atomic<long long> g_serialNanoseconds{0};

}  // namespace

int numChunks(int n, int grain) { return n <= 0 ? 1 : (n + grain - 1) / grain; }

int threads() {
  // The processors this process may run on (as oneTBB counts them), read without starting
  // oneTBB: its own query loads part of it (0.3 ms).
  static const int n = [] {
    cpu_set_t set;
    CPU_ZERO(&set);
    const int count = sched_getaffinity(0, sizeof set, &set) == 0
                          ? CPU_COUNT(&set)
                          : static_cast<int>(std::thread::hardware_concurrency());
    return std::clamp(count, 1, 8);
  }();
  return n;
}

double serialBudget() { return 0.005; }

bool poolStarted() { return g_pool.load(std::memory_order_acquire); }

void forChunks(int n, int grain, const std::function<void(int, int, int)>& body) {
  if (n <= 0) return;
  const int chunks = numChunks(n, grain);
  const auto inOrder = [&] {
    for (int c = 0; c < chunks; ++c) body(c, c * grain, std::min(n, (c + 1) * grain));
  };
  if (chunks == 1 || threads() == 1) {
    inOrder();
    return;
  }
  if (!poolStarted()) {
    const auto began = std::chrono::steady_clock::now();
    inOrder();
    const long long spent = std::chrono::duration_cast<std::chrono::nanoseconds>(
                                std::chrono::steady_clock::now() - began)
                                .count();
    const long long budget = static_cast<long long>(serialBudget() * 1e9);
    if (g_serialNanoseconds.fetch_add(spent) + spent > budget)
      g_pool.store(true, std::memory_order_release);
    return;
  }
  static const tbb::global_control cap(tbb::global_control::max_allowed_parallelism,
                                       static_cast<size_t>(threads()));
  // One task per chunk; the caller runs chunks too and never waits for a worker that has not
  // started one (a loaded machine), and a nested loop runs in the same threads. TBB rethrows
  // the first exception of a body here and cancels the chunks not yet started.
  tbb::parallel_for(
      tbb::blocked_range<int>(0, chunks, 1),
      [&](const tbb::blocked_range<int>& range) {
        for (int c = range.begin(); c < range.end(); ++c)
          body(c, c * grain, std::min(n, (c + 1) * grain));
      },
      tbb::simple_partitioner());
}

}  // namespace diffreg::parallel
