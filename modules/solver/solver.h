// Sparse SPD solver with separate symbolic analysis, numeric factorization and solve, each
// counted and timed, and Dirichlet (eliminated) unknowns. CHOLMOD (simplicial or supernodal,
// chosen per matrix) when built with it, Eigen's SimplicialLDLT otherwise.
#pragma once

#include <diffreg/solver/backend.h>

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

namespace diffreg {

/// Cholesky of a symmetric positive definite matrix (lower triangle used). CHOLMOD picks the
/// fill-reducing ordering and a simplicial or supernodal factorization by the size of the
/// factor (see solver.cpp); Eigen's SimplicialLDLT is the fallback backend.
class SpdSolver {
 public:
  explicit SpdSolver(SolverBackend backend = defaultSolverBackend());
  ~SpdSolver();
  SpdSolver(SpdSolver&&) noexcept;
  SpdSolver& operator=(SpdSolver&&) noexcept;

  /// Symbolic analysis (fill-reducing ordering) of A's pattern.
  void analyze(const SparseMatrix& A);
  /// Numeric factorization; A must have the analyzed pattern.
  /// \throw SingularSystem when A is not positive definite.
  void factorize(const SparseMatrix& A);
  /// Analyzes when `analyzeAgain` is set or A's pattern differs from the analyzed one, then
  /// factorizes: a new matrix with the same pattern costs one numeric factorization.
  void compute(const SparseMatrix& A, bool analyzeAgain = false);
  /// Solves A X = B for all columns of B at once.
  /// \throw SingularSystem when nothing is factorized or the solution is not finite;
  ///        InvalidParameter when B's row count is not the size of A.
  Eigen::MatrixXd solve(const Eigen::MatrixXd& B);
  bool analyzed() const { return analyzed_; }
  /// Whether analyze() keeps a copy of the pattern (4 bytes per nonzero) for compute() to
  /// compare against (the default). A caller that knows when its pattern changes may turn it
  /// off: compute() then analyzes every time, and factorize() is the numeric-only path.
  void keepPattern(bool keep);
  const SolverStats& stats() const { return stats_; }
  /// Method, ordering and size of the last analysis.
  SolverInfo info() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  SolverStats stats_;
  std::vector<int> pattern_;  // outer then inner indices of the analyzed matrix
  bool analyzedEmpty_ = false, factorized_ = false, analyzed_ = false, keepPattern_ = true;
  Eigen::Index size_ = 0;
};

/// Splits n unknowns into free ones and fixed (Dirichlet, eliminated) ones.
class Partition {
 public:
  Partition() = default;
  explicit Partition(const std::vector<bool>& fixed);
  int size() const { return static_cast<int>(local_.size()); }
  int numFree() const { return static_cast<int>(free_.size()); }
  int numFixed() const { return static_cast<int>(fixed_.size()); }
  const std::vector<int>& freeIds() const { return free_; }
  const std::vector<int>& fixedIds() const { return fixed_; }
  bool isFixed(int i) const { return isFixed_[static_cast<std::size_t>(i)] != 0; }
  /// Position of unknown i among the free (or fixed) ones.
  int local(int i) const { return local_[i]; }
  /// A_FF (free x free) and A_FJ (free x fixed) of an n x n matrix.
  SparseMatrix freeFree(const SparseMatrix& A) const;
  SparseMatrix freeFixed(const SparseMatrix& A) const;
  /// Rows of X at the free (or fixed) unknowns.
  Eigen::MatrixXd gatherFree(const Eigen::MatrixXd& X) const;
  Eigen::MatrixXd gatherFixed(const Eigen::MatrixXd& X) const;
  /// Full n-row matrix from free and fixed rows.
  Eigen::MatrixXd scatter(const Eigen::MatrixXd& xFree, const Eigen::MatrixXd& xFixed) const;

 private:
  std::vector<int> free_, fixed_, local_;
  std::vector<unsigned char> isFixed_;  // bytes: read once per matrix entry by the blocks
};

/// min 1/2 x^T A x - x^T b with x fixed on a partition (libigl's min_quad_with_fixed): solves
/// A_FF x_F = b_F - A_FJ x_J. Keeps the symbolic analysis while the pattern of A_FF is
/// unchanged, so a new matrix with the same pattern costs one numeric factorization and a new
/// right-hand side only a solve.
class EliminatedSolver {
 public:
  explicit EliminatedSolver(SolverBackend backend = defaultSolverBackend());
  /// New split of the unknowns: the next setMatrix() analyzes again.
  void setPartition(Partition partition);
  const Partition& partition() const { return partition_; }
  /// Factorizes A (n x n, symmetric); analyzes only when the partition or A_FF's pattern
  /// changed. \throw SingularSystem when A_FF is not positive definite.
  void setMatrix(const SparseMatrix& A) { setMatrix(A, false); }
  /// After trustPatterns(): `samePattern` is the caller's word that A has the pattern of the
  /// previous call (then one numeric factorization); otherwise A is analyzed again.
  void setMatrix(const SparseMatrix& A, bool samePattern);
  /// The caller will say when A's pattern changes (setMatrix(A, samePattern)): no copy of the
  /// pattern is kept for comparison.
  void trustPatterns();
  /// Full solution (n rows) for right-hand side b (n rows) and fixed values xFixed.
  /// \throw SingularSystem when the solution is not finite.
  Eigen::MatrixXd solve(const Eigen::MatrixXd& b, const Eigen::MatrixXd& xFixed);
  /// The same for b = 0: the free unknowns' response to the fixed values alone.
  Eigen::MatrixXd solveFixedResponse(const Eigen::MatrixXd& xFixed);
  const SolverStats& stats() const { return solver_.stats(); }
  SolverInfo info() const { return solver_.info(); }

 private:
  // The free unknowns for rhs = b_F (taken by value: it becomes b_F - A_FJ xFixed), scattered
  // with the fixed values.
  Eigen::MatrixXd solveFree(Eigen::MatrixXd rhs, const Eigen::MatrixXd& xFixed);

  Partition partition_;
  SpdSolver solver_;
  SparseMatrix AFJ_;
  bool forceAnalyze_ = true, trusted_ = false;
};

}  // namespace diffreg
