// The BLAS's own threads, kept for the work that gains from them.
//
// OpenBLAS (Debian's default BLAS behind CHOLMOD) starts its worker threads when it is loaded and
// lets each of them spin on sched_yield for about 2^28 cycles (0.1 s) after it starts and after
// every threaded call. In a process whose element loops already use every core, those spinning
// workers take a core from the loops: on 2 cores the 10K-vertex one-shot run (read, factorize,
// one iteration, write; a simplicial factor, no BLAS call at all) took about a quarter longer
// than with single-threaded BLAS. Only supernodal factors (CHOLMOD's choice for large, dense
// factors) gain from the threads: the factorization of a 100K-vertex tet system takes 2.8 s with
// two threads against 4.5 s with one, the solves with a million-vertex surface's factor about
// 10% less.
//
// reserveBlasThreads() makes the BLAS single-threaded and stops its workers; a BlasThreadScope
// (the solver holds one around each supernodal factorization and solve) gives the threads back
// and stops them again when it ends. The library does neither on its own: the BLAS is
// process-wide, so the diffreg tools opt in, and a host application that runs BLAS work of its
// own keeps its settings. With another BLAS (reference, BLIS, MKL), an OpenBLAS without these
// controls, or one loaded privately (RTLD_LOCAL, as a Python extension may load it) where the
// process's global symbols do not show it, both do nothing.
#pragma once

namespace diffreg {

/// Whether the process's BLAS is an OpenBLAS whose threads can be set at run time.
bool blasThreadsControllable();

/// Single-threaded BLAS and no idle workers, except inside a BlasThreadScope. The thread count
/// the BLAS started with (OPENBLAS_NUM_THREADS, else its core count) is kept for the scopes.
/// Idempotent.
void reserveBlasThreads();

/// Whether reserveBlasThreads() is in effect (the BLAS is controllable and it was called).
bool blasThreadsReserved();

/// The number of threads the BLAS uses now (1 when it cannot be asked).
int blasThreads();

/// The number of threads a BlasThreadScope gives the BLAS (blasThreads() when nothing is
/// reserved).
int blasScopeThreads();

/// For its lifetime, the BLAS's threads as it started with them, when `wanted` and
/// reserveBlasThreads() is in effect (otherwise nothing). Scopes may nest and may be held on
/// several threads; the last one to end makes the BLAS single-threaded again and stops its workers.
class BlasThreadScope {
 public:
  explicit BlasThreadScope(bool wanted = true);
  ~BlasThreadScope();
  BlasThreadScope(const BlasThreadScope&) = delete;
  BlasThreadScope& operator=(const BlasThreadScope&) = delete;

 private:
  bool active_ = false;
};

}  // namespace diffreg
