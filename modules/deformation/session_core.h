// The deformation session's machinery (not part of the public API): the residual model, the
// regularized system and its solver, the acceleration's memory and the local/global loop.
// DeformationSession (deformer.h) owns one and forwards to it.
#pragma once

#include <diffreg/core/error.h>
#include <diffreg/deformation/anderson.h>
#include <diffreg/deformation/energy.h>
#include <diffreg/deformation/handle_basis.h>
#include <diffreg/deformation/lbfgs.h>
#include <diffreg/deformation/local_step.h>
#include <diffreg/deformation/options.h>
#include <diffreg/deformation/system.h>
#include <diffreg/solver/solver.h>

#include <chrono>
#include <memory>
#include <string>
#include <vector>

namespace diffreg {

class DeformationCore {
 public:
  // The operations of DeformationSession, documented there.
  DeformationCore(const Discretization& disc, const DeformationOptions& options = {});
  ~DeformationCore();

  void setHandles(const std::vector<int>& vertices);
  void setTargets(const Eigen::MatrixXd& targets);
  void setRegularization(Regularization mode, double beta, const Eigen::VectorXd& weights = {});
  void setBeta(double beta);
  void setWeights(const Eigen::VectorXd& weights);
  void setHandleBasis(bool on);
  void setTimeBudget(double seconds);
  void setProgress(std::function<void(int, double, double)> progress) {
    options_.progress = std::move(progress);
  }

  DeformationResult solve(int maxIterations, double relTolerance);
  DeformationResult solve() { return solve(options_.maxIterations, options_.relTolerance); }
  DeformationResult solveFrom(const Eigen::MatrixXd& initial, int maxIterations,
                              double relTolerance);
  DeformationResult resume(int maxIterations, double relTolerance);

  const DeformationOptions& options() const { return options_; }
  /// In the order of the caller's discretization's elements.
  const RegularizationWeights& regularizationWeights() const;
  ElementTargets lastTargets() const;
  ElementTargets ownResiduals(const Eigen::MatrixXd& positions) const;
  const SparseMatrix& systemMatrix() const { return system_.matrix(); }
  SolverStats stats() const;

 private:
  // solve() (initial = nullptr) and solveFrom().
  DeformationResult run(int maxIterations, double relTolerance, const Eigen::MatrixXd* initial,
                        bool resume = false);
  // run()'s work after its checks: the linear solve, or the first shape and the iterations.
  void runSteps(int maxIterations, double relTolerance, const Eigen::MatrixXd* initial, bool resume,
                Eigen::MatrixXd& X, DeformationResult& result);
  // Rethrows `e` naming the thinnest element (mesh numbering).
  [[noreturn]] void throwWithThinnest(const NonFiniteSolution& e) const;
  // The first shape of the iterative energies and its local step (t_, the energy).
  double start(const Eigen::MatrixXd* initial, Eigen::MatrixXd& X, DeformationResult& result);
  // Local/global from there: descent (exact local step) or the reference loop.
  void descend(int maxIterations, double tolerance, Eigen::MatrixXd& X, double E,
               DeformationResult& result);
  void descendLbfgs(int maxIterations, double tolerance, Eigen::MatrixXd& X, double E,
                    DeformationResult& result);
  // Makes (next, nextT) with its energy the current iterate (X, t_, E) and counts it.
  void advance(Eigen::MatrixXd& X, Eigen::MatrixXd& next, Stacked& nextT, double energy, double& E,
               DeformationResult& result);
  // The plain step from the current targets t_ (whose iterate has energy E): the global step
  // into X, then the local step into t. Returns its energy (at most E).
  double plainStep(Eigen::MatrixXd& X, Stacked& t, double E);
  // The energy gradient's direction A X - C t on the free unknowns (0 on the fixed ones).
  // `afterLocal`: the last local step was at X, so its F (scratch_.F) serves.
  Eigen::MatrixXd gradient(const Eigen::MatrixXd& X, const Stacked& t, bool afterLocal = false);
  void iterateReference(int maxIterations, double tolerance, Eigen::MatrixXd& X, double E,
                        DeformationResult& result);
  Eigen::MatrixXd restSolve();
  // The local step at X into t from `previous` (localStep; `reference`: the energy of the
  // iterate `previous` belongs to, 0 for none).
  double local(const Eigen::MatrixXd& X, const Stacked* previous, Stacked& t,
               double reference = 0.0);
  void report(const DeformationResult& result) const;
  // The energy E is rounding alone: the shape is exact, the run is over (deformer.cpp).
  bool roundingLevel(double E) const;
  // The run's time budget would be overrun by one more iteration as long as the one that began
  // at `iterationBegan` (setTimeBudget; never without one).
  bool outOfTime(std::chrono::steady_clock::time_point iterationBegan) const;
  // The elements in locality order (element_order.h) when the caller's order scatters
  // neighbours and the session may be regularized (DeformationOptions::reserveRegularization):
  // order[i] is the caller's element stored i-th, and ordered_ the copy of the
  // discretization in that order that everything below is built on. Empty and null when the
  // caller's discretization is used as it is. Only the per-element regularization weights
  // leave the session, mapped back (meshOrderWeights_, refilled with every new weights).
  std::vector<int> elementOrder_;
  std::unique_ptr<Discretization> ordered_;
  RegularizationWeights meshOrderWeights_;
  const Discretization& disc_;
  DeformationOptions options_;
  ResidualModel model_;
  RegularizedSystem system_;
  // ARAP on planar meshes starts from the regularized ASAP solution.
  std::unique_ptr<ResidualModel> initModel_;
  std::unique_ptr<RegularizedSystem> initSystem_;
  std::vector<int> handles_;
  Eigen::MatrixXd targets_;
  Stacked t_;                 // targets, reused across iterations
  Stacked trialT_;            // the targets of a trial step (line search, plain step)
  LocalStepScratch scratch_;  // the local step's F and per-element fit
  // Where the last iterative run stopped, for resume(): its shape and energy (with t_) and the
  // acceleration's memory.
  Eigen::MatrixXd lastX_;
  double lastE_ = 0.0;
  bool resumable_ = false;
  // The last run's targets t_ are each element's own fit (no coupled sweeps): ownResiduals().
  bool ownFits_ = false;
  // Stacked per-element blocks in the caller's element order (elementOrder_).
  ElementTargets toCallerOrder(const Stacked& blocks) const;
  // The last L-BFGS step met the tolerance at the iteration cap, before the plain step that
  // decides stationarity: resume() takes that step first, so that a run continued in batches
  // takes the same steps as one run.
  bool stationarityDue_ = false;
  // setTimeBudget(): seconds per run (0: none) and the running run's end.
  double budget_ = 0.0;
  std::chrono::steady_clock::time_point deadline_;
  LbfgsHistory lbfgs_{1};
  AndersonMixer anderson_{1};
  std::unique_ptr<HandleBasis> basis_;  // options_.handleBasis: for these handles and weights
  Eigen::MatrixXd restRhs_;             // C t for the rest shape's targets and the current weights
                                        // (empty: not yet)
  Eigen::MatrixXd initRhs_;             // the same for the ASAP initial guess's system
};

}  // namespace diffreg
