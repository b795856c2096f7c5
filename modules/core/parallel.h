// Data-parallel loops for the per-element work of the deformation module (local step, residuals,
// energy, right-hand side) and the text writers' formatting (mesh/io.cpp), on oneTBB: its
// workers sleep between loops (they leave the cores to the sparse solver and BLAS), and the
// calling thread works too. OpenMP (libgomp) was measured and rejected: its threads spin at the
// end of every loop (docs/benchmarks.md).
//
// Starting oneTBB's pool (loading its allocator, creating the workers, attaching the calling
// thread) takes 2.3-3 ms here, more than a second thread saves in all the loops of a one-shot
// run on a 10K-vertex mesh. So the loops of a process run on the calling thread, chunk by chunk,
// until they have taken serialBudget() together; the chunks left at that moment and every later
// loop run on the pool. A short run never starts it, a long one loses at most the budget's
// worth of parallel work.
#pragma once

#include <functional>

namespace diffreg::parallel {

/// Number of chunks forChunks() splits n items into with this grain: ceil(n / grain), at least 1.
int numChunks(int n, int grain);

/// Calls body(chunk, begin, end) for every chunk [chunk * grain, min(n, (chunk + 1) * grain)) of
/// [0, n) and returns when all are done. Chunks run concurrently (the caller included) when there
/// is more than one chunk and more than one thread and the pool has started (a loop inside a
/// body shares the threads); before that in order on the calling thread (a loop inside a body
/// too);
/// each chunk runs exactly once, so a body that writes only its chunk's outputs (or its own slot
/// of a per-chunk array) is race-free, and per-chunk partial sums combined in chunk order give the
/// same result for any number of threads. Exceptions thrown by the body are rethrown here (the
/// first one; the remaining chunks are skipped).
/// \pre grain >= 1.
void forChunks(int n, int grain, const std::function<void(int chunk, int begin, int end)>& body);

/// Threads a loop uses, the caller included (the processors of the process's affinity mask, 1 to
/// 8). The first loop that runs chunks concurrently caps oneTBB's parallelism for the whole
/// process at this number (a tbb::global_control kept until exit): a host that only reads and
/// writes meshes gets the cap too, when it writes large ones.
int threads();

/// Seconds the outermost loops of more than one chunk take on their calling threads, all
/// together, before the pool starts.
double serialBudget();

/// Whether the loops run on the pool now (with more than one thread), for tests and reports.
bool poolStarted();

}  // namespace diffreg::parallel
