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

using Clock = std::chrono::steady_clock;

// Set once the loops run on the pool; until then the time the outermost loops took on their
// calling threads.
std::atomic<bool> g_pool{false};
std::atomic<long long> g_serialNanoseconds{0};
// Loops of this thread running on it before the pool started (a nested loop's time is its
// outer loop's).
thread_local int t_serialDepth = 0;

// Chunk c of [0, n): [c * grain, min(n, (c + 1) * grain)), without overflow near INT_MAX.
void runChunk(const std::function<void(int, int, int)>& body, int n, int grain, int c) {
  const long long begin = static_cast<long long>(c) * grain;
  body(c, static_cast<int>(begin), static_cast<int>(std::min<long long>(n, begin + grain)));
}

// Chunks [first, last) on the pool, the caller among its threads.
void onPool(const std::function<void(int, int, int)>& body, int n, int grain, int first, int last) {
  static const tbb::global_control cap(tbb::global_control::max_allowed_parallelism,
                                       static_cast<size_t>(threads()));
  // One task per chunk; the caller runs chunks too and never waits for a worker that has not
  // started one (a loaded machine), and a nested loop runs in the same threads. TBB rethrows
  // the first exception of a body here and cancels the chunks not yet started.
  tbb::parallel_for(
      tbb::blocked_range<int>(first, last, 1),
      [&](const tbb::blocked_range<int>& range) {
        for (int c = range.begin(); c < range.end(); ++c) runChunk(body, n, grain, c);
      },
      tbb::simple_partitioner());
}

}  // namespace

int numChunks(int n, int grain) {
  return n <= 0 ? 1 : static_cast<int>((static_cast<long long>(n) + grain - 1) / grain);
}

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

bool poolStarted() { return g_pool.load(std::memory_order_relaxed); }

void forChunks(int n, int grain, const std::function<void(int, int, int)>& body) {
  if (n <= 0) return;
  const int chunks = numChunks(n, grain);
  if (chunks == 1 || threads() == 1 || t_serialDepth > 0) {
    for (int c = 0; c < chunks; ++c) runChunk(body, n, grain, c);
    return;
  }
  if (poolStarted()) {
    onPool(body, n, grain, 0, chunks);
    return;
  }
  // Chunk by chunk on this thread while the process's serial time stays within the budget;
  // the chunks left when it runs out go to the pool.
  const long long budget = static_cast<long long>(serialBudget() * 1e9);
  const Clock::time_point began = Clock::now();
  long long spent = 0;
  int next = 0;
  {
    struct Depth {
      Depth() { ++t_serialDepth; }
      ~Depth() { --t_serialDepth; }
    } depth;
    while (next < chunks) {
      runChunk(body, n, grain, next++);
      spent = std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - began).count();
      if (g_serialNanoseconds.load(std::memory_order_relaxed) + spent > budget) break;
    }
  }
  if (g_serialNanoseconds.fetch_add(spent, std::memory_order_relaxed) + spent > budget)
    g_pool.store(true, std::memory_order_relaxed);
  if (next < chunks) onPool(body, n, grain, next, chunks);
}

}  // namespace diffreg::parallel
