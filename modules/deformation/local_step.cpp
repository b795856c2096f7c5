#include <diffreg/deformation/local_step.h>

#include <diffreg/core/error.h>
#include <diffreg/deformation/parallel.h>

#include <algorithm>

namespace diffreg {

namespace {

constexpr int kGrain = 1024;  // elements per parallel chunk

// One colour of the exact sweep: T_k = fit(C_k, weight) for its elements, in place in t (F and
// t hold row-major D x D blocks F_k^T and T_k^T).
template <int D>
void sweepColour(const ResidualModel& model, const Regularizer& reg, const std::vector<int>& ids,
                 const Stacked& F, Stacked& t) {
  constexpr int dd = D * D;
  const Eigen::VectorXd& wk = reg.elementWeight();
  parallel::forChunks(static_cast<int>(ids.size()), kGrain, [&](int, int begin, int end) {
    double Ct[9];
    for (int i = begin; i < end; ++i) {
      const int k = ids[static_cast<size_t>(i)];
      const double* Fk = F.data() + static_cast<Eigen::Index>(k) * dd;
      double weight = wk(k);
      for (int j = 0; j < dd; ++j) Ct[j] = wk(k) * Fk[j];
      for (int g = reg.facetBegin(k); g < reg.facetEnd(k); ++g) {
        const double w = reg.neighbourWeight(g);
        if (w == 0.0) continue;
        weight += w;
        const Eigen::Index other = static_cast<Eigen::Index>(reg.neighbour(g)) * dd;
        const double* Fl = F.data() + other;
        const double* Tl = t.data() + other;
        for (int j = 0; j < dd; ++j) Ct[j] += w * (Fk[j] - Fl[j] + Tl[j]);
      }
      if (!(weight > 0.0)) {  // no energy on this element: any target; keep the plain fit
        weight = 1.0;
        for (int j = 0; j < dd; ++j) Ct[j] = Fk[j];
      }
      model.fitElement(Ct, weight, k, t.data() + static_cast<Eigen::Index>(k) * dd);
    }
  });
}

// The exact step's sweeps from the better of the previous targets (if any) and the
// per-element fit: the sweeps then lower the energy further, so the step never raises it, and
// the per-element fit brings the rotations along at once where the shape has turned.
template <int D>
double sweeps(const ResidualModel& model, const Regularizer& reg, const Stacked& F,
              const Stacked* previous, Stacked& t, Stacked& fit) {
  const RegularizationWeights& w = reg.weights();
  if (!previous) {
    model.fitTargets(F, t);
  } else if (previous == &t) {  // in place: the fit goes to scratch space first
    model.fitTargets(F, fit);
    if (model.energy(F, fit, w) < model.energy(F, t, w)) t.swap(fit);
  } else {
    model.fitTargets(F, t);
    if (!(model.energy(F, t, w) < model.energy(F, *previous, w))) t = *previous;
  }
  for (int i = 0; i < kLocalSweeps; ++i)
    for (const std::vector<int>& ids : reg.colours()) sweepColour<D>(model, reg, ids, F, t);
  return model.energy(F, t, w);
}

}  // namespace

double localStep(const ResidualModel& model, const Regularizer& reg, LocalStep step,
                 const Eigen::MatrixXd& X, const Stacked* previous, Stacked& t,
                 LocalStepScratch& scratch) {
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
  return model.rows() == 3 ? sweeps<3>(model, reg, F, previous, t, scratch.fit)
                           : sweeps<2>(model, reg, F, previous, t, scratch.fit);
}

double relaxedEnergy(const ResidualModel& model, const Regularizer& reg,
                     const Eigen::MatrixXd& X) {
  Stacked t;
  LocalStepScratch scratch;
  double E = localStep(model, reg, LocalStep::Exact, X, nullptr, t, scratch);
  for (int i = 0; i < 100 && reg.coupling() && model.iterative(); ++i) {
    const double next = localStep(model, reg, LocalStep::Exact, X, &t, t, scratch);
    const bool settled = E - next <= 1e-12 * E;
    E = next;
    if (settled) break;
  }
  return E;
}

}  // namespace diffreg
