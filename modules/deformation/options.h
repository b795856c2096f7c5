// The options and results of a deformation, and the enums that name its choices: what the
// public API shows of the deformation module (deformer.h's sessions take and return these),
// without the residual operators, systems and solvers behind them.
#pragma once

#include <diffreg/core/names.h>
#include <diffreg/discretization/discretization.h>
#include <diffreg/solver/backend.h>

#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

namespace diffreg {

enum class Energy {
  Arap,       ///< as-rigid-as-possible, F - R (local/global)
  Asap,       ///< as-similar-as-possible, F - closest similarity (linear in 2D)
  Larap,      ///< linearized ARAP, sym(F) - I (linear, coordinates coupled)
  Dirichlet,  ///< F - I
};

enum class Regularization {
  None,        ///< plain energy
  Uniform,     ///< (1 - beta) sum a_k D_k + beta S                          (paper eq. 2)
  Nonuniform,  ///< per-element and per-facet beta from vertex weights       (paper eq. 3)
};

template <>
struct EnumTable<Energy> {
  static constexpr const char* parameter = "energy";
  static constexpr const char* noun = "energy";
  static constexpr EnumName<Energy> names[] = {
      {Energy::Arap, "arap"},
      {Energy::Asap, "asap"},
      {Energy::Larap, "larap"},
      {Energy::Dirichlet, "dirichlet"},
  };
};

template <>
struct EnumTable<Regularization> {
  static constexpr const char* parameter = "regularization";
  static constexpr const char* noun = "mode";
  static constexpr EnumName<Regularization> names[] = {
      {Regularization::None, "none"},
      {Regularization::Uniform, "uniform"},
      {Regularization::Nonuniform, "nonuniform"},
  };
};

enum class LocalStep {
  Exact,      ///< block coordinate descent on eq. 3 (coloured, over-relaxed sweeps)
  Reference,  ///< each target fitted to its own F_k (the reference code; not a descent method)
};

template <>
struct EnumTable<LocalStep> {
  static constexpr const char* parameter = "local_step";
  static constexpr const char* noun = "local step";
  static constexpr EnumName<LocalStep> names[] = {
      {LocalStep::Exact, "exact"},
      {LocalStep::Reference, "reference"},
  };
};

/// beta_k per element and beta_kl per facet (in the order of Discretization::facets()).
struct RegularizationWeights {
  Eigen::VectorXd element;
  Eigen::VectorXd facet;
};

/// Regularization weights for a mode: none -> all 0; uniform -> all `beta`; nonuniform ->
/// beta_k = mean of `vertexWeights` over the element's vertices and beta_kl = mean over the
/// facet's vertices. `beta` is used only by uniform, `vertexWeights` only by nonuniform.
/// \throw InvalidParameter for beta outside [0, 1], or vertex weights of the wrong size, not
/// finite or outside [0, 1] (naming the first bad vertex).
RegularizationWeights makeRegularizationWeights(const Discretization& disc, Regularization mode,
                                                double beta,
                                                const Eigen::VectorXd& vertexWeights = {});

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
  double beta = kDefaultUniformBeta;  ///< uniform beta (none and nonuniform ignore it)
  Eigen::VectorXd weights;  ///< per-vertex weights in [0, 1] for nonuniform (an error with others)
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
  /// DeformationResult::criterion), or when the energy is at rounding level (docs/method.md:
  /// e.g. every handle at rest), also with 0. Reference local step: stop when an iteration changes
  /// the energy by less than this fraction.
  double relTolerance = kDefaultTolerance;
  SolverBackend backend = defaultSolverBackend();
  /// Keep the regularizer's couplings in the system's sparsity pattern while the regularization
  /// is none, so that a later setBeta / setWeights costs a numeric factorization only (paper
  /// Fig. 5). false: a session that starts without regularization factors the plain energy's
  /// smaller system (about half the factorization time on surfaces), and its first
  /// regularization then costs one symbolic analysis more. Such a session also keeps the
  /// caller's element order: the locality order (discretization/element_order.h) speeds up the
  /// regularizer's sweeps, not the plain iteration, and costs about 20 ms of set-up on a
  /// 43K-vertex mesh.
  bool reserveRegularization = true;
  /// With each factorization, also the first global step's response to affine motions of each
  /// group of connected handle vertices (HandleBasis, separable energies, at most 6 groups in
  /// 3D or 8 in 2D): a later handle move whose groups each move affinely (drags, rotations)
  /// starts without a solve. Costs one back-substitution of d+1 columns per group per
  /// factorization and n (d+1) groups doubles. For an editor; a one-shot solve gains nothing.
  bool handleBasis = false;
  /// Called after every iteration with its 1-based count, the energy
  /// (DeformationResult::energies) and the stopping criterion's value (NaN where it is not
  /// measured yet: a first global step from the rest shape or a given shape); linear energies
  /// report one step. Exceptions propagate.
  std::function<void(int iteration, double energy, double criterion)> progress;
};

/// Per-element targets as the iterative deformations (ARAP; ASAP on surfaces and tets) hold
/// them: (m d) x d, d = Discretization::dim(), the d x d block T_k^T of each element in its d
/// rows, in element order (row-major, so each block is contiguous). T_k is the rotation R_k
/// (tets, planar), R_k P_k on surfaces (P_k the projection onto the rest tangent plane), and a
/// scaled rotation for ASAP.
using ElementTargets = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

struct DeformationResult {
  Eigen::MatrixXd positions;  ///< n x d (planar: 2 columns)
  /// Total regularized energy (ResidualModel::energy) after each iteration, with the targets of
  /// its local step; preceded by the energy of the initial guess when one is used (ASAP or
  /// given). Linear energies: one value, at the solution. With the exact local step the values
  /// never rise, but for a given shape's, measured before the first global step puts the
  /// handles at their targets.
  std::vector<double> energies;
  int iterations = 0;     ///< global steps taken (accepted iterations)
  bool converged = true;  ///< the criterion fell below the tolerance within the cap
  /// The stopping criterion at the end: exact local step, the fraction of the energy one more
  /// plain iteration would remove (measured at the last iteration); reference, the relative
  /// energy change of the last iteration; 0 for the linear energies; NaN (null in JSON) when
  /// the run stopped at a first global step from the rest shape or a given shape, which
  /// nothing measured (iterations = 1).
  double criterion = 0.0;
  /// Iterations whose Anderson step was taken (the others took the plain step).
  int accelerated = 0;
  double seconds = 0.0;  ///< wall time of the solve
  /// Where the first local step takes its rotations: "rest" (identities, so the first global
  /// step is the Dirichlet solve) or "asap" (the regularized ASAP solution, used by ARAP on
  /// planar meshes when every component has 2 distinct handle points) or "given" (solveFrom).
  std::string initialGuess = "rest";
};

}  // namespace diffreg
