// The local step of the iterative energies (docs/method.md, "The local step"): new targets T_k
// for fixed positions.
//  - exact (the default): each T_k minimizes the regularized energy (eq. 3) with the positions
//    and the other targets fixed. The terms in T_k reduce to weight ||T_k||^2 - 2 tr(T_k^T C_k)
//    with C_k = w_k F_k + sum_l w_kl (F_k - F_l + T_l) and weight = w_k + sum_l w_kl, so
//    T_k = EnergyModel::fit(C_k, weight). Swept over the colours of the element adjacency graph
//    (a colour's elements are independent: updated in parallel), kLocalSweeps times, from the
//    better of the previous targets and the per-element fit, each update over-relaxed
//    (kMaxCoupling) where that does not raise the element's terms. Before them the
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

/// Sweeps of one exact local step. The coupling of the targets across facets makes smooth
/// changes of the rotation field travel one element per sweep, and the less settled the
/// targets, the more iterations the L-BFGS descent needs. Measured to the default stop with one
/// end held and the other pulled by 15% of the diagonal (docs/benchmarks.md, 2026-11-24), with
/// plain Gauss-Seidel sweeps, 3 / 4 / 6 sweeps: non-uniform rocker arm 1843 / 1108 / 943
/// iterations (9.6 / 6.4 / 6.4 s), armadillo 2058 / 1517 / 2665 (92 / 77 / 148 s), tet-monkey
/// 50 / 49 / 43 (3.3 / 3.9 / 4.4 s), crocodile > 5000 / 4526 / 3531; 2 sweeps: rocker arm 2235.
/// With the over-relaxed sweeps three were worse than four on 14 runs (2026-11-25).
constexpr int kLocalSweeps = 4;

/// The sweeps are successive over-relaxation on the targets: element k's update is the fit of
/// omega_k C_k - (omega_k - 1) weight T_k (T_k its current target), which moves it past the block
/// minimizer fit(C_k, weight) along the same turn (to first order). omega_k = 2 / (1 + sqrt(1 -
/// rho_k^2)) is Young's optimal factor with rho_k = sum_l w_kl / weight, the share of its
/// neighbours in the blend (the row sum of the Jacobi iteration on the targets), standing in for
/// the Jacobi spectral radius: a heuristic, capped at kMaxCoupling (omega_k <= 1.52), 1 where
/// nothing couples. The update is kept where its block objective weight ||T||^2 - 2 tr(T^T C_k)
/// is at most the current target's, else the block minimizer is taken, so eq. 3 never rises,
/// and the fixed points are those of plain Gauss-Seidel. Gauss-Seidel settles the smooth part of a
/// rotation field by about half per sweep; measured to the default stop on 16 runs (the shared
/// rocker arm, beetle-20k, crocodile and tet-monkey, uniform and non-uniform, one end pulled by 10%
/// or 20% of the diagonal; docs/benchmarks.md), the over-relaxed sweeps took 1.75x less time in all
/// (331 -> 189 s), mostly from uniform beta (up to 3x); on the non-uniform rocker arm and
/// tet-monkey some runs took longer (up to 30%); they ended lower in 14 of the 16. A fixed omega
/// of 1.15 / 1.3 / 1.5 for every element: 299 / 228 / 230 s.
constexpr double kMaxCoupling = 0.95;

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

/// `count` sweeps of the exact step at F = scratch.F of some X, in place on the targets t:
/// over-relaxed (kMaxCoupling) or, with `overRelaxed` false, plain Gauss-Seidel (each update the
/// block minimizer). Neither raises eq. 3. \pre the regularizer couples the targets.
void sweepTargets(const ResidualModel& model, const Regularizer& regularizer, const Stacked& F,
                  Stacked& t, int count, bool overRelaxed = true);

/// Eq. 3 at positions X as a function of the shape alone: its minimum over the targets,
/// approached by exact local steps from the per-element fit, or from `start` when its total
/// energy is lower (the targets a run stopped with at X: already settled, so a step or two do),
/// until one gains less than 1e-12 of the energy (at most 100). Without coupling the
/// per-element fit is the minimum.
double relaxedEnergy(const ResidualModel& model, const Regularizer& regularizer,
                     const Eigen::MatrixXd& X, const Stacked* start = nullptr);

}  // namespace diffreg
