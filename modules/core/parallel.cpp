#include <diffreg/core/parallel.h>

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>

#include <algorithm>

namespace diffreg::parallel {

int numChunks(int n, int grain) { return n <= 0 ? 1 : (n + grain - 1) / grain; }

int threads() {
  static const int n = std::clamp(tbb::info::default_concurrency(), 1, 8);
  return n;
}

void forChunks(int n, int grain, const std::function<void(int, int, int)>& body) {
  if (n <= 0) return;
  const int chunks = numChunks(n, grain);
  if (chunks == 1 || threads() == 1) {
    for (int c = 0; c < chunks; ++c) body(c, c * grain, std::min(n, (c + 1) * grain));
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
