// What every solver reports and which backend it runs on: the light part of solver.h, for
// headers of the public API that show counters (SolverStats) but not the solvers.
#pragma once

#include <Eigen/SparseCore>
#include <string>

namespace diffreg {

using SparseMatrix = Eigen::SparseMatrix<double>;

/// What a solver has done: counts and seconds of each phase.
struct SolverStats {
  int symbolic = 0, numeric = 0, solves = 0;
  double symbolicSeconds = 0.0, numericSeconds = 0.0, solveSeconds = 0.0;
  SolverStats& operator+=(const SolverStats& o);
};
SolverStats operator-(const SolverStats& a, const SolverStats& b);

/// What the last symbolic analysis chose, for reports and benchmarks.
struct SolverInfo {
  std::string method;           ///< e.g. "CHOLMOD supernodal LL^T", "CHOLMOD simplicial LDL^T"
  std::string ordering;         ///< fill-reducing ordering: "AMD", "METIS", ...
  double factorNonZeros = 0.0;  ///< nnz(L) (CHOLMOD only, else 0)
  double flops = 0.0;           ///< flops of the numeric factorization (CHOLMOD only, else 0)
};

enum class SolverBackend { Cholmod, Eigen };
/// The backend this build uses by default.
SolverBackend defaultSolverBackend();
const char* toString(SolverBackend backend);

}  // namespace diffreg
