#include <diffreg/deformation/local_step.h>

#include <diffreg/core/error.h>
#include <diffreg/core/parallel.h>
#include <diffreg/deformation/rotation.h>

#include <algorithm>
#include <cmath>

namespace diffreg {

namespace {

constexpr int kGrain = 1024;     // elements per parallel chunk
constexpr int kWeakSweeps = 16;  // sweeps over the weakly anchored elements per local step
constexpr int kWeakRound = 8;    // of them between two turns
constexpr int kWeakGrain = 128;  // their colours are small: chunks that keep both threads busy

// Element k's blend for the exact sweep (local_step.h): C_k^T (row-major, in Ct), its weight
// and the over-relaxation factor of its update.
struct Blend {
  double weight = 1.0;
  double omega = 1.0;
};

// The over-relaxation factor for an element whose neighbours make up the share `coupling` of
// its blend: Young's optimal SOR factor 2 / (1 + sqrt(1 - rho^2)) with that share (the row sum
// of the Jacobi iteration on the targets) standing in for the Jacobi spectral radius rho,
// capped at kMaxCoupling.
double overRelaxation(double coupling) {
  const double rho = std::min(kMaxCoupling, coupling);
  return rho > 0.0 ? 2.0 / (1.0 + std::sqrt(1.0 - rho * rho)) : 1.0;
}

template <int D>
Blend blend(const Regularizer& reg, int k, const Stacked& F, const Stacked& t, double* Ct) {
  // C_k = weight F_k + sum_l w_kl (T_l - F_l), summed in a local array: Ct may alias F and t
  // as far as the compiler knows, which would keep every partial sum in memory.
  constexpr int dd = D * D;
  const double* Fk = F.data() + static_cast<Eigen::Index>(k) * dd;
  const double own = reg.elementWeight()(k);
  double weight = own, sum[dd] = {};
  for (int g = reg.facetBegin(k); g < reg.facetEnd(k); ++g) {
    const double w = reg.neighbourWeight(g);
    if (w == 0.0) continue;
    weight += w;
    const Eigen::Index other = static_cast<Eigen::Index>(reg.neighbour(g)) * dd;
    const double* Fl = F.data() + other;
    const double* Tl = t.data() + other;
    for (int j = 0; j < dd; ++j) sum[j] += w * (Tl[j] - Fl[j]);
  }
  if (!(weight > 0.0)) {  // no energy on this element: any target; keep the plain fit
    for (int j = 0; j < dd; ++j) Ct[j] = Fk[j];
    return {};
  }
  for (int j = 0; j < dd; ++j) Ct[j] = weight * Fk[j] + sum[j];
  return {weight, overRelaxation(1.0 - own / weight)};
}

// The block objective of a target: weight ||T||^2 - 2 tr(T^T C), the terms of eq. 3 in T_k.
template <int D>
double blockObjective(const double* Ct, double weight, const double* Tt) {
  double norm = 0.0, inner = 0.0;
  for (int j = 0; j < D * D; ++j) {
    norm += Tt[j] * Tt[j];
    inner += Tt[j] * Ct[j];
  }
  return weight * norm - 2.0 * inner;
}

// An over-relaxed update, before its fit: keeps the current target in `previous` and writes
// the blend to fit, omega C_k - (omega - 1) weight T_k, to `relaxed` (for a quadratic block the
// point omega of the way from T_k to the block minimizer; for rotations the same turn to first
// order).
template <int D>
void overRelax(const double* Ct, const Blend& b, const double* Tt, double* previous,
               double* relaxed) {
  for (int j = 0; j < D * D; ++j) {
    previous[j] = Tt[j];
    relaxed[j] = b.omega * Ct[j] - (b.omega - 1.0) * b.weight * Tt[j];
  }
}

// After the over-relaxed fit of element k into Tt: where it raised the block objective over the
// previous target's, the block minimizer instead, so eq. 3 does not rise. At settled targets
// the over-relaxed fit ties with the previous target up to rounding and often takes this
// second fit; keeping the previous target on such ties instead made runs at two scales of one
// mesh part by 5e-7 (a rounding-level choice that steers the path), where the block minimizer
// keeps them within 1e-9.
template <int D>
void keepDescent(const ResidualModel& model, int k, const double* Ct, const Blend& b,
                 const double* previous, double* Tt) {
  if (blockObjective<D>(Ct, b.weight, Tt) > blockObjective<D>(Ct, b.weight, previous))
    model.fitElement(Ct, b.weight, k, Tt);
}

// One colour of the exact sweep, in place in t (F and t hold row-major D x D blocks F_k^T and
// T_k^T). Plain: T_k = fit(C_k, weight), the block minimizer. Over-relaxed (`relax`): the fit of
// the over-relaxed blend, kept where it does not raise the block objective (keepDescent). In 3D
// kFitBatch elements at a time: their blends first, then one fitElements call (a row-major C^T
// is the column-major C).
template <int D>
void sweepColour(const ResidualModel& model, const Regularizer& reg, const std::vector<int>& ids,
                 const Stacked& F, Stacked& t, bool relax, int grain = kGrain) {
  constexpr int dd = D * D;
  auto target = [&t](int k) { return t.data() + static_cast<Eigen::Index>(k) * dd; };
  parallel::forChunks(static_cast<int>(ids.size()), grain, [&](int, int begin, int end) {
    if constexpr (D == 3) {
      Eigen::Matrix3d C[kFitBatch], relaxed[kFitBatch];
      Blend b[kFitBatch];
      double weight[kFitBatch], previous[kFitBatch][dd];
      for (int first = begin; first < end; first += kFitBatch) {
        const int count = std::min(kFitBatch, end - first);
        const int* batch = ids.data() + first;
        for (int i = 0; i < count; ++i) {
          b[i] = blend<3>(reg, batch[i], F, t, C[i].data());
          weight[i] = b[i].weight;
          if (relax)
            overRelax<3>(C[i].data(), b[i], target(batch[i]), previous[i], relaxed[i].data());
        }
        model.fitElements(count, batch, relax ? relaxed : C, weight, t);
        if (relax)
          for (int i = 0; i < count; ++i)
            keepDescent<3>(model, batch[i], C[i].data(), b[i], previous[i], target(batch[i]));
      }
    } else {
      double Ct[dd], relaxed[dd], previous[dd];
      for (int i = begin; i < end; ++i) {
        const int k = ids[static_cast<size_t>(i)];
        const Blend b = blend<D>(reg, k, F, t, Ct);
        if (!relax) {
          model.fitElement(Ct, b.weight, k, target(k));
          continue;
        }
        overRelax<D>(Ct, b, target(k), previous, relaxed);
        model.fitElement(relaxed, b.weight, k, target(k));
        keepDescent<D>(model, k, Ct, b, previous, target(k));
      }
    }
  });
}

// `count` sweeps over every colour.
template <int D>
void sweepAll(const ResidualModel& model, const Regularizer& reg, const Stacked& F, Stacked& t,
              int count, bool relax) {
  for (int i = 0; i < count; ++i)
    for (const std::vector<int>& ids : reg.colours()) sweepColour<D>(model, reg, ids, F, t, relax);
}

// Turns each weakly anchored component's targets together by the rotation Q that minimizes the
// energy (eq. 3) over that turn, T_k -> Q T_k for the component's elements (admissible targets
// stay admissible: Q R_k P_k for surfaces). Every term that holds one of those targets has the
// form w ||A - Q B||^2, so Q maximizes tr(Q^T sum w A B^T): the closest rotation to that sum.
// Q = I is a candidate, so the energy never rises. The sweeps alone settle such a turn about one
// element per sweep (with the sweeps of settleWeak: a 26K-vertex planar mesh pulled by a handle
// of magnitude 1 took 1776 L-BFGS iterations instead of 153, docs/benchmarks.md).
template <int D>
void turnWeakComponents(const Regularizer& reg, const Stacked& F, Stacked& t) {
  using Block = Eigen::Matrix<double, D, D, Eigen::RowMajor>;  // stored: F_k^T, T_k^T
  const std::vector<std::vector<int>>& parts = reg.weakComponents();
  if (parts.empty()) return;
  auto stored = [](const Stacked& S, int k) {
    return Eigen::Map<const Block>(S.data() + static_cast<Eigen::Index>(k) * D * D);
  };
  const Eigen::VectorXd& wk = reg.elementWeight();
  for (size_t c = 0; c < parts.size(); ++c) {
    // sum w A B^T; with the stored transposes At = A^T, Bt = B^T that is At^T Bt.
    Eigen::Matrix<double, D, D> M = Eigen::Matrix<double, D, D>::Zero();
    for (int k : parts[c]) {
      const Block Fk = stored(F, k), Tk = stored(t, k);
      M.noalias() += wk(k) * Fk.transpose() * Tk;  // own term: A = F_k, B = T_k
      for (int g = reg.facetBegin(k); g < reg.facetEnd(k); ++g) {
        const double w = reg.neighbourWeight(g);
        const int l = reg.neighbour(g);
        if (w == 0.0) continue;
        if (reg.weak(l)) {      // a weak neighbour is in the same (maximal) component
          if (l < k) continue;  // the facet counted once: A = F_k - F_l, B = T_k - T_l
          const Block A = Fk - stored(F, l), B = Tk - stored(t, l);
          M.noalias() += w * A.transpose() * B;
        } else {  // A = F_k - (F_l - T_l), B = T_k
          const Block A = Fk - stored(F, l) + stored(t, l);
          M.noalias() += w * A.transpose() * Tk;
        }
      }
    }
    Eigen::Matrix<double, D, 1> sigma;
    const Eigen::Matrix<double, D, D> Q = closestRotation<D>(M, sigma);
    // No turn lowers the energy by more than rounding: keep Q = I.
    if (!(sigma.sum() - M.trace() > 1e-14 * sigma.cwiseAbs().sum())) continue;
    for (int k : parts[c]) {
      Eigen::Map<Block> Tk(t.data() + static_cast<Eigen::Index>(k) * D * D);
      Tk = (Tk * Q.transpose()).eval();  // (Q T_k)^T = T_k^T Q^T
    }
  }
}

// The weakly anchored elements settled before the sweeps: turns of their components and sweeps
// over them alone (kWeakSweeps, or fewer when they are more than 1/64 of the mesh: about a
// quarter of a sweep's work at most, at least one sweep), in rounds of kWeakRound sweeps between
// turns. Both only lower the energy. The sweeps are over-relaxed as the others (their elements'
// factor is near the cap): the crocodile pulled by a handle of magnitude 1 (pulls of 10%, 15%,
// 20% of the diagonal) took 79 / 87 / 71 iterations to the default stop instead of 98 / 130 /
// 111 with plain Gauss-Seidel here, ending lower.
template <int D>
void settleWeak(const ResidualModel& model, const Regularizer& reg, const Stacked& F, Stacked& t) {
  const int weak = reg.numWeak();
  if (weak == 0) return;
  const int m = static_cast<int>(F.rows() / D);
  const int total = std::min(kWeakSweeps, std::max(1, m / (4 * weak)));
  for (int done = 0;;) {
    turnWeakComponents<D>(reg, F, t);
    if (done >= total) return;
    for (int end = std::min(total, done + kWeakRound); done < end; ++done)
      for (const std::vector<int>& ids : reg.weakColours())
        sweepColour<D>(model, reg, ids, F, t, true, kWeakGrain);
  }
}

// The exact step's sweeps from the better of the previous targets (if any) and the
// per-element fit: the sweeps then lower the energy further, so the step never raises it, and
// the per-element fit brings the rotations along at once where the shape has turned. The fit
// is not tried where it is unlikely to win (kFitCandidateGap).
template <int D>
double sweeps(const ResidualModel& model, const Regularizer& reg, const Stacked& F,
              const Stacked* previous, Stacked& t, LocalStepScratch& scratch, double reference) {
  Stacked& fit = scratch.fit;
  const RegularizationWeights& w = reg.weights();
  if (!previous) {
    model.fitTargets(F, t);
  } else {
    const double kept = model.energy(F, *previous, w);
    const bool close =
        reference > 0.0 && std::abs(kept - reference) <= kFitCandidateGap * reference;
    const bool skip = close && !scratch.fitWon && scratch.fitSkipped < kFitRetry;
    if (skip) {
      ++scratch.fitSkipped;
      if (previous != &t) t = *previous;
    } else {
      scratch.fitSkipped = 0;
      // The fit wins when it is lower, or finite where the previous targets are not.
      const auto wins = [&](double fitted) {
        return fitted < kept || (!std::isfinite(kept) && std::isfinite(fitted));
      };
      if (previous == &t) {  // in place: the fit goes to scratch space first
        model.fitTargets(F, fit);
        scratch.fitWon = wins(model.energy(F, fit, w));
        if (scratch.fitWon) t.swap(fit);
      } else {
        model.fitTargets(F, t);
        scratch.fitWon = wins(model.energy(F, t, w));
        if (!scratch.fitWon) t = *previous;
      }
    }
  }
  settleWeak<D>(model, reg, F, t);
  sweepAll<D>(model, reg, F, t, kLocalSweeps, true);
  return model.energy(F, t, w);
}

}  // namespace

void sweepTargets(const ResidualModel& model, const Regularizer& reg, const Stacked& F, Stacked& t,
                  int count, bool overRelaxed) {
  if (model.rows() == 3)
    sweepAll<3>(model, reg, F, t, count, overRelaxed);
  else
    sweepAll<2>(model, reg, F, t, count, overRelaxed);
}

double localStep(const ResidualModel& model, const Regularizer& reg, LocalStep step,
                 const Eigen::MatrixXd& X, const Stacked* previous, Stacked& t,
                 LocalStepScratch& scratch, double reference) {
  Stacked& F = scratch.F;
  model.gradients(X, F);
  const bool sweep = model.iterative() && step == LocalStep::Exact && reg.coupling();
  if (!sweep) {
    // Linear energies, the reference step, and the exact step without coupling (C_k = w_k F_k):
    // every target fitted to its own element.
    model.fitTargets(F, t);
    return model.energy(F, t, reg.weights());
  }
  if (previous && (previous->rows() != F.rows() || previous->cols() != F.cols()))
    previous = nullptr;
  return model.rows() == 3 ? sweeps<3>(model, reg, F, previous, t, scratch, reference)
                           : sweeps<2>(model, reg, F, previous, t, scratch, reference);
}

namespace {

// More exact local steps at the same shape (F fixed): the weakly anchored elements and the
// sweeps, until a step gains less than 1e-12 of the energy (at most `steps`). The per-element
// fit is no candidate here: at a fixed shape it does not beat targets already swept.
template <int D>
double relaxFurther(const ResidualModel& model, const Regularizer& reg, const Stacked& F,
                    Stacked& t, double E, int steps) {
  for (int i = 0; i < steps; ++i) {
    settleWeak<D>(model, reg, F, t);
    sweepAll<D>(model, reg, F, t, kLocalSweeps, true);
    const double next = model.energy(F, t, reg.weights());
    const bool settled = E - next <= 1e-12 * E;
    E = next;
    if (settled) break;
  }
  return E;
}

}  // namespace

double relaxedEnergy(const ResidualModel& model, const Regularizer& reg, const Eigen::MatrixXd& X,
                     const Stacked* start) {
  Stacked t;
  LocalStepScratch scratch;
  const double E = localStep(model, reg, LocalStep::Exact, X, start, t, scratch);
  if (!reg.coupling() || !model.iterative()) return E;
  // scratch.F is F at X, from that first step.
  return model.rows() == 3 ? relaxFurther<3>(model, reg, scratch.F, t, E, 100)
                           : relaxFurther<2>(model, reg, scratch.F, t, E, 100);
}

}  // namespace diffreg
