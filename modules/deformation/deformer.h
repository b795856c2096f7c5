// A deformation editing session (the paper's Fig. 5): handles, regularization and targets can
// change between solves, and each change costs only what it must:
//   setHandles                          -> symbolic analysis + numeric factorization next solve
//   setBeta / setWeights / setRegularization -> numeric factorization only
//   setTargets                          -> right-hand side only
//   (with setHandleBasis on, a move whose handle groups each move affinely: no solve for the
//    first global step)
#pragma once

#include <diffreg/deformation/options.h>
#include <diffreg/discretization/discretization.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace diffreg {

/// How the iterative energies' local/global iterations are sped up.
class DeformationCore;

class DeformationSession {
 public:
  /// The session refers to `disc`, which must outlive it (a temporary does not compile).
  /// \throw InvalidParameter for invalid regularization options (see setRegularization).
  DeformationSession(const Discretization& disc, const DeformationOptions& options = {});
  DeformationSession(Discretization&&, const DeformationOptions& = {}) = delete;
  ~DeformationSession();
  DeformationSession(DeformationSession&&) noexcept;
  DeformationSession& operator=(DeformationSession&&) noexcept;


  /// Constrained vertices; their targets reset to their rest positions.
  /// \throw InvalidParameter for an empty list, an id out of range or a repeated id.
  void setHandles(const std::vector<int>& vertices);
  /// Target positions, one row per handle vertex, d columns (planar meshes accept 3 and ignore z).
  /// \throw InvalidParameter for the wrong shape or non-finite values.
  void setTargets(const Eigen::MatrixXd& targets);
  /// \throw InvalidParameter for beta outside [0, 1], bad weights (makeRegularizationWeights),
  /// or weights given with a mode other than nonuniform (they would be ignored).
  void setRegularization(Regularization mode, double beta, const Eigen::VectorXd& weights = {});
  /// Uniform regularization with this beta.
  void setBeta(double beta);
  /// Non-uniform regularization with these per-vertex weights.
  void setWeights(const Eigen::VectorXd& weights);
  /// DeformationOptions::handleBasis: on, the next solve also computes the first global step's
  /// response to affine motions of each group of handle vertices (again after new handles or
  /// weights), and later moves use it.
  void setHandleBasis(bool on);
  /// Seconds a solve(), solveFrom() or resume() of the iterative energies may take, counted from
  /// the call (a first factorization included; 0, the default: no limit): the run stops after
  /// the first iteration that leaves less of them than it took itself (one iteration at least;
  /// a prediction from the last iteration, so an iteration with more line-search steps than
  /// that one can still overrun them),
  /// unconverged as at its iteration cap, and resume() continues it with the same steps. For
  /// interactive use (the editor answers within it and iterates on while idle); where it stops
  /// depends on the machine's speed.
  /// \throw InvalidParameter for a negative or non-finite budget.
  void setTimeBudget(double seconds);
  /// DeformationOptions::progress for the later solves (an empty function: none). An exception
  /// it throws ends the run and propagates; the session stays usable, with nothing to continue
  /// (resume() then solves afresh).
  void setProgress(std::function<void(int iteration, double energy, double criterion)> progress);

  /// Minimizes the regularized energy with the handles at their targets.
  /// \throw InvalidParameter before any setHandles() or for maxIterations < 1 or a negative
  ///        tolerance. \throw SingularSystem when a component has too few handle points.
  DeformationResult solve(int maxIterations, double relTolerance);
  DeformationResult solve() { return solve(options().maxIterations, options().relTolerance); }
  /// Like solve(), but the iterative energies take their first rotations from `initial` (n x d
  /// positions, typically the previous result while a handle is dragged) instead of the rest
  /// shape or the ASAP guess: after a small handle move a few iterations converge. The result
  /// then depends on the starting shape (ARAP has local minima). Linear energies ignore it.
  /// \throw InvalidParameter as solve(), or for `initial` of the wrong size or not finite.
  DeformationResult solveFrom(const Eigen::MatrixXd& initial, int maxIterations,
                              double relTolerance);
  /// Continues the last solve()/solveFrom()/resume() of the iterative energies where it
  /// stopped, with its targets and acceleration history, for up to `maxIterations` more: runs
  /// in batches equal one long run. initialGuess is "continued"; energies start with the
  /// energy it stopped at. Falls back to solve() when there is nothing to continue (no run yet,
  /// a linear energy, or handles, targets or regularization changed since).
  DeformationResult resume(int maxIterations, double relTolerance);

  const DeformationOptions& options() const;
  /// The targets of the shape the last iterative run stopped at (its last local step's), in the
  /// mesh's element order: where relaxing eq. 3 at that shape can start (measureDeformation).
  /// Empty when there is nothing to continue (as resume(): no run yet, a linear energy, or
  /// handles, targets or regularization changed since).
  ElementTargets lastTargets() const;
  /// The residuals e_k = F_k - t_k at `positions` (n x d) from the last iterative run's targets,
  /// when `positions` is that run's shape and its targets are every element's own fit (its
  /// local step fitted each element alone: no facet coupling, or the reference step): then they
  /// equal ResidualModel::residuals(positions), without fitting the targets again. In the
  /// mesh's element order, for elementMapsFromResiduals. Empty otherwise (no run, another shape,
  /// coupled targets, or a linear energy).
  ElementTargets ownResiduals(const Eigen::MatrixXd& positions) const;
  /// beta_k and beta_kl of the current regularization.
  const RegularizationWeights& regularizationWeights() const;
  /// The system matrix A of the energy (n x n separable, d n x d n coupled), for tests.
  const SparseMatrix& systemMatrix() const;
  /// Counters summed over the factorizations this session owns (the energy's and, for ARAP on
  /// planar meshes, the one of its ASAP initial guess).
  SolverStats stats() const;

 private:
  std::unique_ptr<DeformationCore> core_;
};

/// One-shot: deforms `disc` with the handle vertices moved to `targets`.
DeformationResult deform(const Discretization& disc, const DeformationOptions& options,
                         const std::vector<int>& handles, const Eigen::MatrixXd& targets);

}  // namespace diffreg
