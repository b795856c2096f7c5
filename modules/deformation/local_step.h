// The local step of the iterative energies (docs/method.md, "The local step"): new targets T_k
// for fixed positions.
//  - exact (the default): each T_k minimizes the regularized energy (eq. 3) with the positions
//    and the other targets fixed. The terms in T_k reduce to weight ||T_k||^2 - 2 tr(T_k^T C_k)
//    with C_k = w_k F_k + sum_l w_kl (F_k - F_l + T_l) and weight = w_k + sum_l w_kl, so
//    T_k = EnergyModel::fit(C_k, weight). Swept Gauss-Seidel over the colours of the element
//    adjacency graph (a colour's elements are independent: updated in parallel), kLocalSweeps
//    times, from the better of the previous targets and the per-element fit. Before them the
//    weakly anchored elements (Regularizer::weakComponents) are settled: each connected set's
//    targets turned together by the best rotation, and swept on their own. Every update lowers
//    eq. 3 or leaves it; without regularization it is the plain per-element fit.
//  - reference: T_k fitted to F_k alone, as the paper's reference code does. With the
//    regularizer this is not a minimization in T_k and local/global is not a descent method.
#pragma once

#include <diffreg/deformation/options.h>
#include <diffreg/deformation/regularizer.h>
#include <diffreg/deformation/residual_model.h>

#include <string>

namespace diffreg {

/// Gauss-Seidel sweeps of one exact local step. The coupling of the targets across facets
/// makes smooth changes of the rotation field travel one element per sweep, and the less
/// settled the targets, the more iterations the L-BFGS descent needs. Measured to the default
/// stop with one end held and the other pulled by 15% of the diagonal (docs/benchmarks.md,
/// 2026-11-24), 3 / 4 / 6 sweeps: non-uniform rocker arm 1843 / 1108 / 943 iterations
/// (9.6 / 6.4 / 6.4 s), armadillo 2058 / 1517 / 2665 (92 / 77 / 148 s), tet-monkey 50 / 49 / 43
/// (3.3 / 3.9 / 4.4 s), crocodile > 5000 / 4526 / 3531; 2 sweeps: rocker arm 2235.
constexpr int kLocalSweeps = 4;

/// Arrays the local step fills and reuses from call to call (kept by the caller, so that a
/// million-element step does not fault in fresh pages each time).
struct LocalStepScratch {
  Stacked F;           ///< L_k x_k at the positions of the last step
  Stacked fit;         ///< the per-element fit, when the step updates its targets in place
  bool fitWon = true;  ///< the per-element fit won the last time it was tried
  int fitSkipped = 0;  ///< steps since it was last tried (kFitRetry)
};

/// The exact step's per-element fit candidate (a fit of every element and an energy: about a
/// sixth of a regularized L-BFGS iteration) is skipped when it is unlikely to win: the previous
/// targets' energy at the new positions is within kFitCandidateGap (relative) of `reference`,
/// the energy of the iterate they belong to, and the fit lost the last time it was tried; it
/// is tried again after kFitRetry such skips. Measured with the fit always tried (one end held,
/// the other pulled): on the rocker arm (non-uniform) it won 92 of 1490 L-BFGS trials, none
/// within 1% of the reference (it lost 1290 of those); on the crocodile (uniform) it won 19 of
/// 26, mostly within 1e-4, hence the retry after a loss only.
constexpr double kFitCandidateGap = 1e-2;
constexpr int kFitRetry = 3;

/// The local step at positions X: new targets `t` and their energy (ResidualModel::energy).
/// The exact step starts from the better of the per-element fit and `previous` (the targets of
/// the last step, null for none; may be &t, then t is updated in place), or from `previous`
/// alone as kFitCandidateGap says when `reference` > 0. Leaves scratch.F = L_k x_k at X (and
/// the fit candidate's record). Linear energies keep their constant targets.
double localStep(const ResidualModel& model, const Regularizer& regularizer, LocalStep step,
                 const Eigen::MatrixXd& X, const Stacked* previous, Stacked& t,
                 LocalStepScratch& scratch, double reference = 0.0);

/// Eq. 3 at positions X as a function of the shape alone: its minimum over the targets,
/// approached by exact local steps from the per-element fit until one gains less than 1e-12
/// of the energy (at most 100). Without coupling the per-element fit is the minimum.
double relaxedEnergy(const ResidualModel& model, const Regularizer& regularizer,
                     const Eigen::MatrixXd& X);

}  // namespace diffreg
