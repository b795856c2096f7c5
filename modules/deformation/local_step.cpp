#include <diffreg/deformation/local_step.h>

#include <diffreg/core/error.h>
#include <diffreg/deformation/parallel.h>

#include <algorithm>

namespace diffreg {

namespace {

constexpr int kGrain = 1024;  // elements per parallel chunk

// Row-major stacked d x d blocks: block k's entries are contiguous, so an element and its
// neighbours are a few cache lines each (the sweeps visit a colour's elements all over the mesh).
using Blocks = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

Blocks toBlocks(const Eigen::MatrixXd& stacked, int d) {
  const Eigen::Index m = stacked.rows() / d;
  Blocks out(m, d * d);
  for (Eigen::Index k = 0; k < m; ++k)
    for (int a = 0; a < d; ++a)
      for (int b = 0; b < d; ++b) out(k, a * d + b) = stacked(k * d + a, b);
  return out;
}

void fromBlocks(const Blocks& blocks, int d, Eigen::MatrixXd& stacked) {
  for (Eigen::Index k = 0; k < blocks.rows(); ++k)
    for (int a = 0; a < d; ++a)
      for (int b = 0; b < d; ++b) stacked(k * d + a, b) = blocks(k, a * d + b);
}

// One colour of the exact sweep: T_k = fit(C_k, weight) for its elements.
void sweepColour(const ResidualModel& model, const Regularizer& reg, const std::vector<int>& ids,
                 const Blocks& F, Blocks& t) {
  const int d = model.rows();  // separable layout: d x d blocks
  const int dd = d * d;
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

}  // namespace

double localStep(const ResidualModel& model, const Regularizer& reg, LocalStep step,
                 const Eigen::MatrixXd& X, Eigen::MatrixXd& t, Eigen::MatrixXd& e,
                 Eigen::MatrixXd& F) {
  model.gradients(X, F);
  const bool sweep = model.iterative() && step == LocalStep::Exact && reg.coupling();
  if (!sweep || t.rows() != F.rows() || t.cols() != F.cols()) {
    // Linear energies, the reference step, and the exact step without coupling (C_k = w_k F_k):
    // every target fitted to its own element. Without previous targets the sweeps start there.
    model.fitTargets(F, t);
  } else {
    // Start from the previous targets or from the per-element fit, whichever is lower: the
    // sweeps then lower the energy further, so the step never raises it, and the per-element
    // fit brings the rotations along at once where the shape has turned.
    Eigen::MatrixXd fitted;
    model.fitTargets(F, fitted);
    if (model.energy(F, fitted, reg.weights()) < model.energy(F, t, reg.weights()))
      t.swap(fitted);
  }
  if (sweep) {
    const int d = model.rows();
    const Blocks Fb = toBlocks(F, d);
    Blocks tb = toBlocks(t, d);
    for (int i = 0; i < kLocalSweeps; ++i)
      for (const std::vector<int>& ids : reg.colours()) sweepColour(model, reg, ids, Fb, tb);
    fromBlocks(tb, d, t);
  }
  e = F - t;
  return model.energy(e, reg.weights());
}

double relaxedEnergy(const ResidualModel& model, const Regularizer& reg,
                     const Eigen::MatrixXd& X) {
  Eigen::MatrixXd t, e, F;
  double E = localStep(model, reg, LocalStep::Exact, X, t, e, F);
  for (int i = 0; i < 100 && reg.coupling() && model.iterative(); ++i) {
    const double next = localStep(model, reg, LocalStep::Exact, X, t, e, F);
    const bool settled = E - next <= 1e-12 * E;
    E = next;
    if (settled) break;
  }
  return E;
}

}  // namespace diffreg
