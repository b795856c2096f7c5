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

// Copies stacked (m d x d) into `out` (m x d^2), which must have that size (in parallel: at a
// million elements the copies are as long as a sweep's colour).
template <int D>
void toBlocks(const Eigen::MatrixXd& stacked, Blocks& out) {
  const int m = static_cast<int>(stacked.rows() / D);
  parallel::forChunks(m, 4 * kGrain, [&](int, int begin, int end) {
    for (Eigen::Index k = begin; k < end; ++k)
      for (int a = 0; a < D; ++a)
        for (int b = 0; b < D; ++b) out(k, a * D + b) = stacked(k * D + a, b);
  });
}

template <int D>
Blocks toBlocks(const Eigen::MatrixXd& stacked) {
  Blocks out(stacked.rows() / D, D * D);
  toBlocks<D>(stacked, out);
  return out;
}

// Every element's target fitted to its own F_k alone (ResidualModel::fitTargets), as blocks.
Blocks fitBlocks(const ResidualModel& model, const Blocks& F) {
  Blocks t(F.rows(), F.cols());
  parallel::forChunks(static_cast<int>(F.rows()), kGrain, [&](int, int begin, int end) {
    for (int k = begin; k < end; ++k)
      model.fitElement(F.data() + static_cast<Eigen::Index>(k) * F.cols(), 1.0, k,
                       t.data() + static_cast<Eigen::Index>(k) * t.cols());
  });
  return t;
}

template <int D>
void fromBlocks(const Blocks& blocks, Eigen::MatrixXd& stacked) {
  parallel::forChunks(static_cast<int>(blocks.rows()), 4 * kGrain, [&](int, int begin, int end) {
    for (Eigen::Index k = begin; k < end; ++k)
      for (int a = 0; a < D; ++a)
        for (int b = 0; b < D; ++b) stacked(k * D + a, b) = blocks(k, a * D + b);
  });
}

// One colour of the exact sweep: T_k = fit(C_k, weight) for its elements (D x D blocks).
template <int D>
void sweepColour(const ResidualModel& model, const Regularizer& reg, const std::vector<int>& ids,
                 const Blocks& F, Blocks& t) {
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

// The exact step's sweeps from F (released) and the previous targets t (if any).
template <int D>
double sweeps(const ResidualModel& model, const Regularizer& reg, Eigen::MatrixXd& t,
              Eigen::MatrixXd& F) {
  const Eigen::Index rows = F.rows(), cols = F.cols();
  const Blocks Fb = toBlocks<D>(F);
  F.resize(0, 0);
  // Start from the previous targets or from the per-element fit, whichever is lower: the
  // sweeps then lower the energy further, so the step never raises it, and the per-element fit
  // brings the rotations along at once where the shape has turned. Without previous targets
  // the sweeps start from the fit.
  Blocks tb = fitBlocks(model, Fb);
  if (t.rows() == rows && t.cols() == cols &&
      !(model.blockEnergy(Fb.data(), tb.data(), reg.weights()) <
        model.blockEnergy(Fb.data(), t, reg.weights())))
    toBlocks<D>(t, tb);
  t.resize(0, 0);
  for (int i = 0; i < kLocalSweeps; ++i)
    for (const std::vector<int>& ids : reg.colours()) sweepColour<D>(model, reg, ids, Fb, tb);
  t.resize(rows, cols);
  fromBlocks<D>(tb, t);
  return model.blockEnergy(Fb.data(), tb.data(), reg.weights());
}

}  // namespace

double localStep(const ResidualModel& model, const Regularizer& reg, LocalStep step,
                 const Eigen::MatrixXd& X, Eigen::MatrixXd& t, Eigen::MatrixXd& F) {
  model.gradients(X, F);
  const bool sweep = model.iterative() && step == LocalStep::Exact && reg.coupling();
  if (!sweep) {
    // Linear energies, the reference step, and the exact step without coupling (C_k = w_k F_k):
    // every target fitted to its own element.
    model.fitTargets(F, t);
    return model.energy(F, t, reg.weights());
  }
  // The sweeps work on row-major copies of F and t. F (scratch) and t are released meanwhile,
  // so the step holds at most three such arrays at once.
  return model.rows() == 3 ? sweeps<3>(model, reg, t, F) : sweeps<2>(model, reg, t, F);
}

double relaxedEnergy(const ResidualModel& model, const Regularizer& reg,
                     const Eigen::MatrixXd& X) {
  Eigen::MatrixXd t, F;
  double E = localStep(model, reg, LocalStep::Exact, X, t, F);
  for (int i = 0; i < 100 && reg.coupling() && model.iterative(); ++i) {
    const double next = localStep(model, reg, LocalStep::Exact, X, t, F);
    const bool settled = E - next <= 1e-12 * E;
    E = next;
    if (settled) break;
  }
  return E;
}

}  // namespace diffreg
