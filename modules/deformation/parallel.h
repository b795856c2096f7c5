// Data-parallel loops for the per-element work of the deformation module (local step, residuals,
// energy, right-hand side). One persistent pool of threads, started on first use, serves every
// loop: workers sleep on a condition variable between loops (no spinning, so they leave the
// cores to the sparse solver and BLAS), and the calling thread works too.
#pragma once

#include <functional>

namespace diffreg::parallel {

/// Number of chunks forChunks() splits n items into with this grain: ceil(n / grain), at least 1.
int numChunks(int n, int grain);

/// Calls body(chunk, begin, end) for every chunk [chunk * grain, min(n, (chunk + 1) * grain)) of
/// [0, n) and returns when all are done. Chunks run concurrently on the pool (the caller
/// included) when there is more than one chunk and more than one hardware thread; each chunk
/// runs exactly once, so a body that writes only its chunk's outputs (or its own slot of a
/// per-chunk array) is race-free, and per-chunk partial sums combined in chunk order give the same
/// result for any number of threads. Exceptions thrown by the body are rethrown here (the first
/// one; the remaining chunks are skipped).
/// \pre grain >= 1.
void forChunks(int n, int grain, const std::function<void(int chunk, int begin, int end)>& body);

/// Threads the pool uses, the caller included (hardware concurrency, 1 to 8).
int threads();

}  // namespace diffreg::parallel
