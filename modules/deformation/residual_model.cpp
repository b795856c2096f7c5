#include <diffreg/deformation/residual_model.h>

#include <diffreg/core/parallel.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <vector>

namespace diffreg {

namespace {

constexpr int kGrain = 2048;  // elements (or facets) per parallel chunk

// Frobenius-orthogonal projector I - Q Q^T removing span{basis} (vectors of length d^2).
Eigen::MatrixXd complementProjector(const std::vector<Eigen::VectorXd>& basis, int size) {
  Eigen::MatrixXd B(size, static_cast<Eigen::Index>(basis.size()));
  for (size_t i = 0; i < basis.size(); ++i) B.col(static_cast<Eigen::Index>(i)) = basis[i];
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(B);
  const Eigen::MatrixXd Q =
      qr.householderQ() * Eigen::MatrixXd::Identity(size, static_cast<Eigen::Index>(basis.size()));
  return Eigen::MatrixXd::Identity(size, size) - Q * Q.transpose();
}

// Sum of per-chunk partial sums in chunk order: the same value for any number of threads.
template <class Body>
double chunkedSum(int n, const Body& body) {
  std::vector<double> partial(static_cast<size_t>(parallel::numChunks(n, kGrain)), 0.0);
  parallel::forChunks(n, kGrain, [&](int chunk, int begin, int end) {
    partial[static_cast<size_t>(chunk)] = body(begin, end);
  });
  double sum = 0.0;
  for (double p : partial) sum += p;
  return sum;
}

// F_k^T = G_k^T X_k for elements [begin, end) (separable layout, d x d blocks).
template <int D, int S>
void gradientRange(const Discretization& disc, const Eigen::MatrixXd& X, Stacked& F, int begin,
                   int end) {
  constexpr int s = S;  // element size: 3 (triangles) or 4 (tets)
  const Eigen::MatrixXi& el = disc.elements();
  const Eigen::MatrixXd& grads = disc.gradients();
  for (int k = begin; k < end; ++k) {
    Eigen::Matrix<double, D, D> Ft = Eigen::Matrix<double, D, D>::Zero();  // Ft(b, a) = F(a, b)
    const Eigen::Index g0 = static_cast<Eigen::Index>(k) * s;
    for (int i = 0; i < s; ++i) {
      const Eigen::Index v = el(k, i);
      for (int b = 0; b < D; ++b) {
        const double g = grads(g0 + i, b);
        for (int a = 0; a < D; ++a) Ft(b, a) += X(v, a) * g;
      }
    }
    F.block<D, D>(static_cast<Eigen::Index>(k) * D, 0) = Ft;
  }
}

}  // namespace

ResidualModel::ResidualModel(const Discretization& disc, Energy energy)
    : disc_(disc),
      energy_(diffreg::energyModel(energy)),
      coupled_(energy_.coupled(disc.kind())),
      iterative_(energy_.iterative(disc.kind())),
      dim_(disc.dim()),
      elementSize_(disc.elementSize()) {
  const int d = dim_;
  dofsPerVertex_ = coupled_ ? d : 1;
  columns_ = coupled_ ? 1 : d;
  rows_ = coupled_ ? d * d : d;
  localSize_ = elementSize_ * dofsPerVertex_;
  const int m = disc.numElements();
  if (coupled_) operators_.resize(static_cast<Eigen::Index>(m) * rows_, localSize_);
  // Constant targets only for the linear energies (the iterative ones fit theirs).
  if (!iterative_) fixedTargets_.setZero(static_cast<Eigen::Index>(m) * rows_, columns_);
  const MeshKind kind = disc.kind();
  for (int k = 0; k < m && (coupled_ || !iterative_); ++k) {
    const auto G = disc.gradient(k);
    const Eigen::MatrixXd frame = disc.restFrame(k);
    const Eigen::MatrixXd T = energy_.constantTarget(frame, kind);
    if (!coupled_) {
      if (!iterative_)
        fixedTargets_.block(static_cast<Eigen::Index>(k) * rows_, 0, rows_, columns_) =
            T.transpose();
      continue;
    }
    auto t = fixedTargets_.block(static_cast<Eigen::Index>(k) * rows_, 0, rows_, columns_);
    // B_k: vec(F_k)[a d + b] = sum_i x_(i,a) G(i,b), local unknown i d + a.
    Eigen::MatrixXd B = Eigen::MatrixXd::Zero(rows_, localSize_);
    for (int i = 0; i < elementSize_; ++i)
      for (int a = 0; a < d; ++a)
        for (int b = 0; b < d; ++b) B(a * d + b, i * d + a) = G(i, b);
    operators_.block(static_cast<Eigen::Index>(k) * rows_, 0, rows_, localSize_) =
        complementProjector(energy_.removedModes(frame, kind), rows_) * B;
    for (int a = 0; a < d; ++a)
      for (int b = 0; b < d; ++b) t(a * d + b, 0) = T(a, b);
  }
}

ResidualModel::Operators ResidualModel::operators() const {
  if (coupled_) {
    const Eigen::Index mr = static_cast<Eigen::Index>(disc_.numElements()) * rows_;
    return {operators_.data(), rows_, 1, mr};
  }
  // L_k(b, j) = G_k(j, b), G stacked column-major (m s) x d.
  const Eigen::MatrixXd& G = disc_.gradients();
  return {G.data(), elementSize_, G.rows(), 1};
}

Eigen::MatrixXd ResidualModel::local(int k) const {
  const Operators L = operators();
  Eigen::MatrixXd out(rows_, localSize_);
  for (int row = 0; row < rows_; ++row)
    for (int j = 0; j < localSize_; ++j) out(row, j) = L(k, row, j);
  return out;
}

Eigen::MatrixXd ResidualModel::toUnknowns(const Eigen::MatrixXd& P) const {
  if (!coupled_) return P;
  Eigen::MatrixXd x(static_cast<Eigen::Index>(P.rows()) * dim_, 1);
  for (Eigen::Index v = 0; v < P.rows(); ++v)
    for (int a = 0; a < dim_; ++a) x(v * dim_ + a, 0) = P(v, a);
  return x;
}

Eigen::MatrixXd ResidualModel::toPositions(const Eigen::MatrixXd& x) const {
  if (!coupled_) return x;
  const Eigen::Index n = x.rows() / dim_;
  Eigen::MatrixXd P(n, dim_);
  for (Eigen::Index v = 0; v < n; ++v)
    for (int a = 0; a < dim_; ++a) P(v, a) = x(v * dim_ + a, 0);
  return P;
}

void ResidualModel::gradients(const Eigen::MatrixXd& X, Stacked& F) const {
  const Eigen::Index rows = static_cast<Eigen::Index>(disc_.numElements()) * rows_;
  if (F.rows() != rows || F.cols() != columns_) F.resize(rows, columns_);
  if (coupled_) {  // vec(F_k) through B_k: the unprojected operators are not kept, so L_k x_k
    const Eigen::MatrixXd x = toUnknowns(X);
    parallel::forChunks(disc_.numElements(), kGrain, [&](int, int begin, int end) {
      Eigen::VectorXd xk(localSize_);
      for (int k = begin; k < end; ++k) {
        for (int j = 0; j < localSize_; ++j) xk(j) = x(unknown(k, j), 0);
        F.block(static_cast<Eigen::Index>(k) * rows_, 0, rows_, 1) = local(k) * xk;
      }
    });
    return;
  }
  parallel::forChunks(disc_.numElements(), kGrain, [&](int, int begin, int end) {
    if (dim_ == 2)
      gradientRange<2, 3>(disc_, X, F, begin, end);
    else if (elementSize_ == 3)
      gradientRange<3, 3>(disc_, X, F, begin, end);
    else
      gradientRange<3, 4>(disc_, X, F, begin, end);
  });
}

void ResidualModel::fitElement(const double* Ct, double weight, int k, double* Tt) const {
  // Ct is the d x d block C_k^T, row-major in the layout's rows (rows_ = d, columns_ = d).
  if (dim_ == 2) {
    Eigen::Matrix2d C;
    for (int a = 0; a < 2; ++a)
      for (int b = 0; b < 2; ++b) C(b, a) = Ct[a * 2 + b];
    Eigen::Map<Eigen::Matrix<double, 2, 2, Eigen::RowMajor>> out(Tt);
    out = energy_.fit(C, weight).transpose();
    return;
  }
  Eigen::Matrix3d C;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) C(b, a) = Ct[a * 3 + b];
  Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> out(Tt);
  out = fit3(C, weight, k).transpose();
}

void ResidualModel::fitElements(int count, const int* ids, const Eigen::Matrix3d* C,
                                const double* weight, Stacked& t) const {
  Eigen::Vector3d normal[kFitBatch];
  const Eigen::Vector3d* normalOf[kFitBatch];
  double* out[kFitBatch];
  const bool surface = disc_.kind() == MeshKind::Surface;
  for (int i = 0; i < count; ++i) {
    const int k = ids[i];
    if (surface) normal[i] = disc_.normals().row(k).transpose();
    normalOf[i] = surface ? &normal[i] : nullptr;
    out[i] = t.data() + static_cast<Eigen::Index>(k) * 9;
  }
  energy_.fitBatch(count, C, weight, normalOf, out);
}

Eigen::Matrix3d ResidualModel::fit3(const Eigen::Matrix3d& C, double weight, int k) const {
  if (disc_.kind() != MeshKind::Surface) return energy_.fit(C, weight, nullptr);
  const Eigen::Vector3d n = disc_.normals().row(k).transpose();
  return energy_.fit(C, weight, &n);
}

void ResidualModel::fitTargets(const Stacked& F, Stacked& t) const {
  const Eigen::Index rows = static_cast<Eigen::Index>(disc_.numElements()) * rows_;
  if (t.rows() != rows || t.cols() != columns_) t.resize(rows, columns_);
  if (!iterative_) {
    t = fixedTargets_;
    return;
  }
  // Block k of F is F_k^T, so C = F_k is its transpose; the target's block is T^T. In 3D
  // kFitBatch elements per fitElements call (a row-major F_k^T is the column-major F_k).
  parallel::forChunks(disc_.numElements(), kGrain, [&](int, int begin, int end) {
    if (dim_ == 2) {
      for (int k = begin; k < end; ++k) {
        const Eigen::Index row = static_cast<Eigen::Index>(k) * 2;
        const Eigen::Matrix2d C = F.block<2, 2>(row, 0).transpose();
        t.block<2, 2>(row, 0) = energy_.fit(C, 1.0).transpose();
      }
      return;
    }
    Eigen::Matrix3d C[kFitBatch];
    int ids[kFitBatch];
    double weight[kFitBatch];
    std::fill_n(weight, kFitBatch, 1.0);
    for (int first = begin; first < end; first += kFitBatch) {
      const int count = std::min(kFitBatch, end - first);
      for (int i = 0; i < count; ++i) {
        ids[i] = first + i;
        C[i] = Eigen::Map<const Eigen::Matrix3d>(F.data() + static_cast<Eigen::Index>(ids[i]) * 9);
      }
      fitElements(count, ids, C, weight, t);
    }
  });
}

void ResidualModel::targets(const Eigen::MatrixXd& X, Stacked& t) const {
  if (!iterative_) {
    t = fixedTargets_;
    return;
  }
  Stacked F;
  gradients(X, F);
  fitTargets(F, t);
}

void ResidualModel::residuals(const Eigen::MatrixXd& X, const Stacked& t, Stacked& e) const {
  gradients(X, e);
  e -= t;
}

Stacked ResidualModel::residuals(const Eigen::MatrixXd& X) const {
  // targets() and residuals(X, t, e) would compute the gradients twice.
  Stacked e, t;
  gradients(X, e);
  fitTargets(e, t);
  e -= t;
  return e;
}

Eigen::VectorXd ResidualModel::distortion(const Stacked& e) const {
  const int m = disc_.numElements();
  Eigen::VectorXd D(m);
  for (int k = 0; k < m; ++k)
    D(k) = e.block(static_cast<Eigen::Index>(k) * rows_, 0, rows_, columns_).squaredNorm();
  return D;
}

Eigen::VectorXd ResidualModel::facetDifference(const Stacked& e) const {
  const auto& facets = disc_.facets();
  Eigen::VectorXd S(static_cast<Eigen::Index>(facets.size()));
  for (size_t f = 0; f < facets.size(); ++f)
    S(static_cast<Eigen::Index>(f)) =
        (e.block(static_cast<Eigen::Index>(facets[f].k) * rows_, 0, rows_, columns_) -
         e.block(static_cast<Eigen::Index>(facets[f].l) * rows_, 0, rows_, columns_))
            .squaredNorm();
  return S;
}

namespace {

// Sum over elements of (1 - beta_k) a_k |block_k|^2 and over facets of beta_kl c_kl
// |block_k - block_l|^2 for blocks given by `block(k, a, b)`, scaled to the unit mean edge.
// Sizes > 0: known at compile time (the separable layouts' d x d blocks), else `rows` and
// `columns` at run time.
template <int Rows, int Columns, class Block>
double blendedEnergySized(const Discretization& disc, const RegularizationWeights& w, int runRows,
                          int runColumns, double aScale, const Block& block) {
  const int rows = Rows > 0 ? Rows : runRows, columns = Columns > 0 ? Columns : runColumns;
  const double elementSum = chunkedSum(disc.numElements(), [&](int begin, int end) {
    double sum = 0.0;
    for (int k = begin; k < end; ++k) {
      double d2 = 0.0;
      for (int b = 0; b < columns; ++b)
        for (int a = 0; a < rows; ++a) {
          const double x = block(k, a, b);
          d2 += x * x;
        }
      sum += (1.0 - w.element(k)) * disc.measures()(k) * d2;
    }
    return sum;
  });
  const auto& facets = disc.facets();
  double facetSum = 0.0;
  if (!facets.empty() && w.facet.size() > 0 && w.facet.cwiseAbs().maxCoeff() > 0.0)
    facetSum = chunkedSum(static_cast<int>(facets.size()), [&](int begin, int end) {
      double sum = 0.0;
      for (int f = begin; f < end; ++f) {
        const double wf = w.facet(f) * facets[f].c;
        if (wf == 0.0) continue;
        double d2 = 0.0;
        for (int b = 0; b < columns; ++b)
          for (int a = 0; a < rows; ++a) {
            const double x = block(facets[f].k, a, b) - block(facets[f].l, a, b);
            d2 += x * x;
          }
        sum += wf * d2;
      }
      return sum;
    });
  // Physical a_k and c_kl rescaled to the unit-mean-edge mesh: a' = ell^-md a,
  // c' = ell^-(md-1) c.
  return aScale * elementSum + aScale * disc.meanEdgeLength() * facetSum;
}

template <class Block>
double blendedEnergy(const Discretization& disc, const RegularizationWeights& w, int rows,
                     int columns, double aScale, const Block& block) {
  if (rows == 3 && columns == 3)
    return blendedEnergySized<3, 3>(disc, w, rows, columns, aScale, block);
  if (rows == 2 && columns == 2)
    return blendedEnergySized<2, 2>(disc, w, rows, columns, aScale, block);
  return blendedEnergySized<-1, -1>(disc, w, rows, columns, aScale, block);
}

}  // namespace

double ResidualModel::energy(const Stacked& e, const RegularizationWeights& w) const {
  const double* data = e.data();
  const int c = columns_, dd = rows_ * columns_;
  return blendedEnergy(disc_, w, rows_, columns_, energyScale(), [=](int k, int a, int b) {
    return data[static_cast<size_t>(k) * dd + static_cast<size_t>(a) * c + b];
  });
}

double ResidualModel::energy(const Stacked& F, const Stacked& t,
                             const RegularizationWeights& w) const {
  const double *f = F.data(), *target = t.data();
  const int c = columns_, dd = rows_ * columns_;
  return blendedEnergy(disc_, w, rows_, columns_, energyScale(), [=](int k, int a, int b) {
    const size_t at = static_cast<size_t>(k) * dd + static_cast<size_t>(a) * c + b;
    return f[at] - target[at];
  });
}

double ResidualModel::energyScale() const {
  return std::pow(disc_.meanEdgeLength(), -disc_.measureDim());
}

}  // namespace diffreg
