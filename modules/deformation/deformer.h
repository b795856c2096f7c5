// A deformation editing session (the paper's Fig. 5): handles, regularization and targets can
// change between solves, and each change costs only what it must:
//   setHandles                          -> symbolic analysis + numeric factorization next solve
//   setBeta / setWeights / setRegularization -> numeric factorization only
//   setTargets                          -> right-hand side only
#pragma once

#include <diffreg/deformation/anderson.h>
#include <diffreg/deformation/energy.h>
#include <diffreg/deformation/lbfgs.h>
#include <diffreg/deformation/local_step.h>
#include <diffreg/deformation/system.h>
#include <diffreg/solver/solver.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace diffreg {

/// How the iterative energies' local/global iterations are sped up.
enum class Acceleration {
  None,      ///< plain local/global
  Lbfgs,     ///< L-BFGS in the positions, the system matrix as initial Hessian, line search
  Anderson,  ///< Anderson acceleration of the positions with an energy safeguard
};
template <>
struct EnumTable<Acceleration> {
  static constexpr const char* parameter = "acceleration";
  static constexpr const char* noun = "acceleration";
  static constexpr EnumName<Acceleration> names[] = {
      {Acceleration::Lbfgs, "lbfgs"},
      {Acceleration::Anderson, "anderson"},
      {Acceleration::None, "none"},
  };
};

/// The default stationarity tolerance of the exact local step: a run stops when one plain
/// local/global iteration from its shape would lower the energy by less than this fraction.
/// Plain iterations lower the energy less and less, so 30 of them then lower it by less than
/// 30 times this (3e-6 relative).
constexpr double kDefaultTolerance = 1e-7;
/// The default cap on the iterations; converged runs stay far below it.
constexpr int kDefaultIterations = 5000;
/// The uniform beta the front ends (filters, editor) start from.
constexpr double kDefaultUniformBeta = 0.5;
/// The largest cap any front end accepts (filters, editor, Python).
constexpr int kMaxIterations = 100000;

struct DeformationOptions {
  Energy energy = Energy::Arap;
  Regularization regularization = Regularization::None;
  double beta = 0.0;        ///< uniform beta
  Eigen::VectorXd weights;  ///< per-vertex weights in [0, 1] for nonuniform
  /// Exact (block coordinate descent on eq. 3, the default) or the reference code's local step.
  LocalStep localStep = LocalStep::Exact;
  /// L-BFGS (the default), Anderson or none. The reference local step is never accelerated
  /// (it is not a descent method, so no line search or safeguard can hold on to its energy).
  Acceleration acceleration = Acceleration::Lbfgs;
  int history = 8;  ///< L-BFGS pairs, or earlier iterates Anderson combines
  /// Cap on the local/global iterations (ARAP, ASAP in 3D).
  int maxIterations = kDefaultIterations;
  /// Exact local step: stop when one plain local/global iteration from the current shape would
  /// lower the energy by less than this fraction of it (the stationarity criterion,
  /// DeformationResult::criterion). Reference local step: stop when an iteration changes the
  /// energy by less than this fraction.
  double relTolerance = kDefaultTolerance;
  SolverBackend backend = defaultSolverBackend();
  /// Keep the regularizer's couplings in the system's sparsity pattern while the regularization
  /// is none, so that a later setBeta / setWeights costs a numeric factorization only (paper
  /// Fig. 5). false: a session that starts without regularization factors the plain energy's
  /// smaller system (about half the factorization time on surfaces), and its first
  /// regularization then costs one symbolic analysis more.
  bool reserveRegularization = true;
  /// Called after every iteration with its 1-based count, the energy
  /// (DeformationResult::energies) and the stopping criterion's value; linear energies report
  /// one step. Exceptions propagate.
  std::function<void(int iteration, double energy, double criterion)> progress;
};

struct DeformationResult {
  Eigen::MatrixXd positions;  ///< n x d (planar: 2 columns)
  /// Total regularized energy (ResidualModel::energy) after each iteration, with the targets of
  /// its local step; preceded by the energy of the initial guess when one is used (ASAP or
  /// given). Linear energies: one value, at the solution. With the exact local step the values
  /// never rise.
  std::vector<double> energies;
  int iterations = 0;     ///< global steps taken (accepted iterations)
  bool converged = true;  ///< the criterion fell below the tolerance within the cap
  /// The stopping criterion at the end: exact local step, the fraction of the energy one more
  /// plain iteration would remove (measured at the last iteration); reference, the relative
  /// energy change of the last iteration; 0 for the linear energies.
  double criterion = 0.0;
  /// Iterations whose Anderson step was taken (the others took the plain step).
  int accelerated = 0;
  double seconds = 0.0;  ///< wall time of the solve
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
  /// Continues the last solve()/solveFrom()/resume() of the iterative energies where it
  /// stopped, with its targets and acceleration history, for up to `maxIterations` more: runs
  /// in batches equal one long run. initialGuess is "continued"; energies start with the
  /// energy it stopped at. Falls back to solve() when there is nothing to continue (no run yet,
  /// a linear energy, or handles, targets or regularization changed since).
  DeformationResult resume(int maxIterations, double relTolerance);

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
  DeformationResult run(int maxIterations, double relTolerance, const Eigen::MatrixXd* initial,
                        bool resume = false);
  // The first shape of the iterative energies and its local step (t_, e_, the energy).
  double start(const Eigen::MatrixXd* initial, Eigen::MatrixXd& X, DeformationResult& result);
  // Local/global from there: descent (exact local step) or the reference loop.
  void descend(int maxIterations, double tolerance, Eigen::MatrixXd& X, double E,
               DeformationResult& result);
  void descendLbfgs(int maxIterations, double tolerance, Eigen::MatrixXd& X, double E,
                    DeformationResult& result);
  // Makes (next, nextT, nextE) with its energy the current iterate (X, t_, e_, E) and counts it.
  void advance(Eigen::MatrixXd& X, Eigen::MatrixXd& next, Eigen::MatrixXd& nextT,
               Eigen::MatrixXd& nextE, double energy, double& E, DeformationResult& result);
  // The plain step from targets t: the global step into X, then the local step updating t and e.
  // Returns its energy (at most the energy of the shape t was fitted to).
  double plainStep(Eigen::MatrixXd& X, Eigen::MatrixXd& t, Eigen::MatrixXd& e);
  // The energy gradient's direction A X - C t on the free unknowns (0 on the fixed ones).
  Eigen::MatrixXd gradient(const Eigen::MatrixXd& X, const Eigen::MatrixXd& t);
  void iterateReference(int maxIterations, double tolerance, Eigen::MatrixXd& X, double E,
                        DeformationResult& result);
  Eigen::MatrixXd restSolve();
  double local(const Eigen::MatrixXd& X, Eigen::MatrixXd& t, Eigen::MatrixXd& e);
  void report(const DeformationResult& result) const;
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
  Eigen::MatrixXd F_;            // stacked L_k x_k of the local step, scratch
  // Where the last iterative run stopped, for resume(): its shape and energy (with t_) and the
  // acceleration's memory.
  Eigen::MatrixXd lastX_;
  double lastE_ = 0.0;
  bool resumable_ = false;
  LbfgsHistory lbfgs_{1};
  AndersonMixer anderson_{1};
  Eigen::MatrixXd restTargets_;  // targets fitted to the rest shape (first local step), cached
  Eigen::MatrixXd restRhs_;      // C restTargets_ for the current weights (empty: not yet)
  Eigen::MatrixXd initRhs_;      // the same for the ASAP initial guess's system
};

/// One-shot: deforms `disc` with the handle vertices moved to `targets`.
DeformationResult deform(const Discretization& disc, const DeformationOptions& options,
                         const std::vector<int>& handles, const Eigen::MatrixXd& targets);

}  // namespace diffreg
