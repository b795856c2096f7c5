// A deformation editing session (the paper's Fig. 5): handles, regularization and targets can
// change between solves, and each change costs only what it must:
//   setHandles                          -> symbolic analysis + numeric factorization next solve
//   setBeta / setWeights / setRegularization -> numeric factorization only
//   setTargets                          -> right-hand side only
#pragma once

#include "deformation/energy.h"
#include "deformation/system.h"
#include "solver/solver.h"

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace diffreg {

struct DeformationOptions {
  Energy energy = Energy::Arap;
  Regularization regularization = Regularization::None;
  double beta = 0.0;           ///< uniform beta
  Eigen::VectorXd weights;     ///< per-vertex weights in [0, 1] for nonuniform
  int maxIterations = 50;      ///< local/global iterations (ARAP, ASAP in 3D)
  double relTolerance = 1e-6;  ///< stop when the energy drops by less than this fraction
  SolverBackend backend = defaultSolverBackend();
  /// Keep the regularizer's couplings in the system's sparsity pattern while the regularization
  /// is none, so that a later setBeta / setWeights costs a numeric factorization only (paper
  /// Fig. 5). false: a session that starts without regularization factors the plain energy's
  /// smaller system (about half the factorization time on surfaces), and its first
  /// regularization then costs one symbolic analysis more.
  bool reserveRegularization = true;
  /// Called after every global step with the 1-based iteration count and the energy
  /// (DeformationResult::energies); linear energies report one step. Exceptions propagate.
  std::function<void(int iteration, double energy)> progress;
};

struct DeformationResult {
  Eigen::MatrixXd positions;  ///< n x d (planar: 2 columns)
  /// Total regularized energy (energy.h, ResidualModel::energy) after each global step, with
  /// the rotations refitted to the positions; preceded by the energy of the ASAP initial guess
  /// when one is used. Linear energies: one value, at the solution.
  std::vector<double> energies;
  int iterations = 0;     ///< global steps taken
  bool converged = true;  ///< relative energy change fell below the tolerance
  /// Where the first local step takes its rotations: "rest" (identities, so the first global
  /// step is the Dirichlet solve) or "asap" (the regularized ASAP solution, used by ARAP on
  /// planar meshes when every component has 2 distinct handle points) or "given" (solveFrom).
  std::string initialGuess = "rest";
};

class DeformationSession {
 public:
  /// \throw InvalidParameter for invalid regularization options (see setRegularization).
  DeformationSession(const Discretization& disc, const DeformationOptions& options = {});
  ~DeformationSession();

  /// Constrained vertices; their targets reset to their rest positions.
  /// \throw InvalidParameter for an empty list, an id out of range or a repeated id.
  void setHandles(const std::vector<int>& vertices);
  /// Target positions, one row per handle vertex, d columns (planar meshes accept 3 and ignore z).
  /// \throw InvalidParameter for the wrong shape or non-finite values.
  void setTargets(const Eigen::MatrixXd& targets);
  /// \throw InvalidParameter for beta outside [0, 1] or bad weights (makeRegularizationWeights).
  void setRegularization(Regularization mode, double beta, const Eigen::VectorXd& weights = {});
  /// Uniform regularization with this beta.
  void setBeta(double beta);
  /// Non-uniform regularization with these per-vertex weights.
  void setWeights(const Eigen::VectorXd& weights);

  /// Minimizes the regularized energy with the handles at their targets.
  /// \throw InvalidParameter before any setHandles() or for maxIterations < 1 or a negative
  ///        tolerance. \throw SingularSystem when a component has too few handle points.
  DeformationResult solve(int maxIterations, double relTolerance);
  DeformationResult solve() { return solve(options_.maxIterations, options_.relTolerance); }
  /// Like solve(), but the iterative energies take their first rotations from `initial` (n x d
  /// positions, typically the previous result while a handle is dragged) instead of the rest
  /// shape or the ASAP guess: after a small handle move a few iterations converge. The result
  /// then depends on the starting shape (ARAP has local minima). Linear energies ignore it.
  /// \throw InvalidParameter as solve(), or for `initial` of the wrong size or not finite.
  DeformationResult solveFrom(const Eigen::MatrixXd& initial, int maxIterations,
                              double relTolerance);

  const DeformationOptions& options() const { return options_; }
  const ResidualModel& model() const { return model_; }
  const RegularizationWeights& regularizationWeights() const { return system_.weights(); }
  /// The system matrix A of the energy (n x n separable, d n x d n coupled), for tests.
  const SparseMatrix& systemMatrix() const { return system_.matrix(); }
  /// Counters summed over the factorizations this session owns (the energy's and, for ARAP on
  /// planar meshes, the one of its ASAP initial guess).
  SolverStats stats() const;

 private:
  // solve() (initial = nullptr) and solveFrom().
  DeformationResult run(int maxIterations, double relTolerance, const Eigen::MatrixXd* initial);
  const Discretization& disc_;
  DeformationOptions options_;
  ResidualModel model_;
  RegularizedSystem system_;
  // ARAP on planar meshes starts from the regularized ASAP solution.
  std::unique_ptr<ResidualModel> initModel_;
  std::unique_ptr<RegularizedSystem> initSystem_;
  std::vector<int> handles_;
  Eigen::MatrixXd targets_;
  Eigen::MatrixXd t_, e_;        // targets and residuals, reused across iterations
  Eigen::MatrixXd restTargets_;  // targets fitted to the rest shape (first local step), cached
  Eigen::MatrixXd restRhs_;      // C restTargets_ for the current weights (empty: not yet)
  Eigen::MatrixXd initRhs_;      // the same for the ASAP initial guess's system
};

/// One-shot: deforms `disc` with the handle vertices moved to `targets`.
DeformationResult deform(const Discretization& disc, const DeformationOptions& options,
                         const std::vector<int>& handles, const Eigen::MatrixXd& targets);

}  // namespace diffreg
