#include "deformation/energy.h"

#include "core/error.h"
#include "deformation/parallel.h"
#include "deformation/rotation.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace diffreg {

const char* toString(Energy energy) {
  switch (energy) {
    case Energy::Arap:
      return "arap";
    case Energy::Asap:
      return "asap";
    case Energy::Larap:
      return "larap";
    case Energy::Dirichlet:
      return "dirichlet";
  }
  return "?";
}

const char* toString(Regularization regularization) {
  switch (regularization) {
    case Regularization::None:
      return "none";
    case Regularization::Uniform:
      return "uniform";
    case Regularization::Nonuniform:
      return "nonuniform";
  }
  return "?";
}

Energy parseEnergy(const std::string& name) {
  for (Energy e : {Energy::Arap, Energy::Asap, Energy::Larap, Energy::Dirichlet})
    if (name == toString(e)) return e;
  throw InvalidParameter("energy: unknown energy '" + name +
                         "' (valid: arap, asap, larap, dirichlet)");
}

Regularization parseRegularization(const std::string& name) {
  for (Regularization r :
       {Regularization::None, Regularization::Uniform, Regularization::Nonuniform})
    if (name == toString(r)) return r;
  throw InvalidParameter("regularization: unknown mode '" + name +
                         "' (valid: none, uniform, nonuniform)");
}

bool isIterative(Energy energy, MeshKind kind) {
  return energy == Energy::Arap || (energy == Energy::Asap && kind != MeshKind::Planar);
}

bool isCoupled(Energy energy, MeshKind kind) {
  return energy == Energy::Larap || (energy == Energy::Asap && kind == MeshKind::Planar);
}

RegularizationWeights makeRegularizationWeights(const Discretization& disc, Regularization mode,
                                                double beta, const Eigen::VectorXd& x) {
  const int m = disc.numElements();
  const auto& facets = disc.facets();
  const int nf = static_cast<int>(facets.size());
  RegularizationWeights w;
  switch (mode) {
    case Regularization::None:
      w.element.setZero(m);
      w.facet.setZero(nf);
      break;
    case Regularization::Uniform:
      if (!(beta >= 0.0 && beta <= 1.0))
        throw InvalidParameter("regularization: beta = " + std::to_string(beta) +
                               " is outside [0, 1]");
      w.element.setConstant(m, beta);
      w.facet.setConstant(nf, beta);
      break;
    case Regularization::Nonuniform: {
      if (x.size() != disc.numVertices())
        throw InvalidParameter("regularization: " + std::to_string(x.size()) +
                               " vertex weights for a mesh of " +
                               std::to_string(disc.numVertices()) + " vertices");
      for (int i = 0; i < x.size(); ++i)
        if (!(x(i) >= 0.0 && x(i) <= 1.0))
          throw InvalidParameter("regularization: the weight of vertex " + std::to_string(i) +
                                 " is " + std::to_string(x(i)) + ", outside [0, 1]");
      const Eigen::MatrixXi& el = disc.elements();
      w.element.resize(m);
      for (int k = 0; k < m; ++k) {
        double sum = 0.0;
        for (int i = 0; i < el.cols(); ++i) sum += x(el(k, i));
        w.element(k) = sum / static_cast<double>(el.cols());
      }
      w.facet.resize(nf);
      for (int f = 0; f < nf; ++f) {
        double sum = 0.0;
        for (int i = 0; i < facets[f].size; ++i) sum += x(facets[f].vertices[i]);
        w.facet(f) = sum / static_cast<double>(facets[f].size);
      }
      break;
    }
  }
  return w;
}

namespace {

constexpr int kGrain = 2048;  // elements (or facets) per parallel chunk

// Local step of the iterative energies: T_k = R_k (ARAP) or s_k R_k (ASAP), R_k the closest
// rotation to F_k with det > 0, s_k = tr(R_k^T F_k) / 2 (surfaces) or / 3 (tets) (the sum of the
// singular values, the smallest negated for a reflection); surfaces act on the tangent plane:
// T_k P_k. Stored transposed (separable layout: e_k = F_k^T - T_k^T). Closed forms (planar,
// surface) and the polar Newton iteration (tets) give the rotation of the SVD to rounding; the
// SVD remains for degenerate and inverted elements. With `e`, also writes the residuals and,
// with `beta`, returns sum_k (1 - beta_k) a_k D_k (else 0).
template <int D>
double fitRotationRange(const Discretization& disc, bool scaled, const Eigen::MatrixXd& X,
                        Eigen::MatrixXd& t, Eigen::MatrixXd* e, const Eigen::VectorXd* beta,
                        int begin, int end) {
  using Mat = Eigen::Matrix<double, D, D>;
  using Vec = Eigen::Matrix<double, D, 1>;
  constexpr int S = D == 2 ? 3 : -1;  // element size known at compile time for planar meshes
  const int s = S > 0 ? S : disc.elementSize();
  const Eigen::MatrixXi& el = disc.elements();
  const Eigen::MatrixXd& grads = disc.gradients();
  const bool surface = disc.kind() == MeshKind::Surface;
  const double scaleDivisor = surface ? 2.0 : static_cast<double>(D);
  double weighted = 0.0;
  for (int k = begin; k < end; ++k) {
    Mat F = Mat::Zero();
    const Eigen::Index g0 = static_cast<Eigen::Index>(k) * s;
    for (int i = 0; i < s; ++i) {
      const Eigen::Index v = el(k, i);
      for (int b = 0; b < D; ++b) {
        const double g = grads(g0 + i, b);
        for (int a = 0; a < D; ++a) F(a, b) += X(v, a) * g;
      }
    }
    Mat T;
    double trace = 0.0;
    bool done = false;
    if constexpr (D == 2) {
      T = closestRotation2(F, trace);
      done = true;
    } else if (surface) {
      const Eigen::Vector3d n = disc.normals().row(k).transpose();
      done = tangentRotation(F, n, T, trace);
      if (!done) {
        Vec sigma;
        T = closestRotation<D>(F, sigma);
        trace = sigma.sum();
        T = T - (T * n) * n.transpose();
        done = true;
      }
    } else {
      done = polarRotation3(F, T, trace);
    }
    if (!done) {
      Vec sigma;
      T = closestRotation<D>(F, sigma);
      trace = sigma.sum();
    }
    if (scaled) T *= trace / scaleDivisor;
    const Eigen::Index row = static_cast<Eigen::Index>(k) * D;
    for (int a = 0; a < D; ++a)
      for (int b = 0; b < D; ++b) t(row + a, b) = T(b, a);
    if (e) {
      double d2 = 0.0;
      for (int a = 0; a < D; ++a)
        for (int b = 0; b < D; ++b) {
          const double r = F(b, a) - T(b, a);
          (*e)(row + a, b) = r;
          d2 += r * r;
        }
      if (beta) weighted += (1.0 - (*beta)(k)) * disc.measures()(k) * d2;
    }
  }
  return weighted;
}

// Residuals e_k = L_k x_k - t_k of elements [begin, end) and, with `beta`,
// sum_k (1 - beta_k) a_k D_k.
double residualRange(const Discretization& disc, const Eigen::MatrixXd& L, int q, int r, int u,
                     const Eigen::MatrixXd& X, const Eigen::MatrixXd& t, Eigen::MatrixXd& e,
                     const Eigen::VectorXd* beta, int begin, int end) {
  const int c = static_cast<int>(t.cols()), s = disc.elementSize(), d = disc.dim();
  const Eigen::MatrixXi& el = disc.elements();
  const bool coupled = q > 1;
  Eigen::MatrixXd xk(u, c), ek(r, c);
  double weighted = 0.0;
  for (int k = begin; k < end; ++k) {
    for (int i = 0; i < s; ++i) {
      const int v = el(k, i);
      if (coupled)
        for (int a = 0; a < d; ++a) xk(i * d + a, 0) = X(v, a);
      else
        xk.row(i) = X.row(v);
    }
    const Eigen::Index row = static_cast<Eigen::Index>(k) * r;
    ek.noalias() = L.block(row, 0, r, u) * xk;
    ek -= t.block(row, 0, r, c);
    e.block(row, 0, r, c) = ek;
    if (beta) weighted += (1.0 - (*beta)(k)) * disc.measures()(k) * ek.squaredNorm();
  }
  return weighted;
}

// sum_f beta_f c_f ||e_k - e_l||^2 over facets [begin, end).
double facetRange(const std::vector<Facet>& facets, const Eigen::VectorXd& beta, int r,
                  const Eigen::MatrixXd& e, int begin, int end) {
  const int c = static_cast<int>(e.cols());
  double sum = 0.0;
  for (int f = begin; f < end; ++f) {
    const double w = beta(f) * facets[f].c;
    if (w == 0.0) continue;
    const Eigen::Index k = static_cast<Eigen::Index>(facets[f].k) * r;
    const Eigen::Index l = static_cast<Eigen::Index>(facets[f].l) * r;
    double d2 = 0.0;
    for (int b = 0; b < c; ++b)
      for (int a = 0; a < r; ++a) {
        const double x = e(k + a, b) - e(l + a, b);
        d2 += x * x;
      }
    sum += w * d2;
  }
  return sum;
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

// Row-major vec of a d x d matrix: index a * d + b.
Eigen::VectorXd vecOf(const Eigen::MatrixXd& M) {
  Eigen::VectorXd v(M.size());
  for (int a = 0; a < M.rows(); ++a)
    for (int b = 0; b < M.cols(); ++b) v(a * M.cols() + b) = M(a, b);
  return v;
}

// Frobenius-orthogonal projector I - Q Q^T removing span{basis} (vectors of length d^2).
Eigen::MatrixXd complementProjector(const std::vector<Eigen::VectorXd>& basis, int size) {
  Eigen::MatrixXd B(size, static_cast<Eigen::Index>(basis.size()));
  for (size_t i = 0; i < basis.size(); ++i) B.col(static_cast<Eigen::Index>(i)) = basis[i];
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(B);
  const Eigen::MatrixXd Q =
      qr.householderQ() * Eigen::MatrixXd::Identity(size, static_cast<Eigen::Index>(basis.size()));
  return Eigen::MatrixXd::Identity(size, size) - Q * Q.transpose();
}

Eigen::Matrix3d cross(int i) {
  Eigen::Vector3d e = Eigen::Vector3d::Zero();
  e(i) = 1.0;
  Eigen::Matrix3d C;
  C << 0, -e(2), e(1), e(2), 0, -e(0), -e(1), e(0), 0;
  return C;
}

}  // namespace

ResidualModel::ResidualModel(const Discretization& disc, Energy energy)
    : disc_(disc),
      energy_(energy),
      coupled_(isCoupled(energy, disc.kind())),
      iterative_(isIterative(energy, disc.kind())),
      d_(disc.dim()),
      s_(disc.elementSize()) {
  q_ = coupled_ ? d_ : 1;
  c_ = coupled_ ? 1 : d_;
  r_ = coupled_ ? d_ * d_ : d_;
  u_ = s_ * q_;
  const int m = disc.numElements();
  L_.resize(static_cast<Eigen::Index>(m) * r_, u_);
  fixedT_.setZero(static_cast<Eigen::Index>(m) * r_, c_);
  const bool planar = disc.kind() == MeshKind::Planar;
  Eigen::Matrix2d J2;
  J2 << 0, -1, 1, 0;
  for (int k = 0; k < m; ++k) {
    const auto G = disc.gradient(k);
    const Eigen::MatrixXd frame = disc.restFrame(k);
    auto L = L_.block(static_cast<Eigen::Index>(k) * r_, 0, r_, u_);
    auto t = fixedT_.block(static_cast<Eigen::Index>(k) * r_, 0, r_, c_);
    if (!coupled_) {
      L = G.transpose();
      if (energy == Energy::Dirichlet) t = frame.transpose();
      continue;
    }
    // B_k: vec(F_k)[a d + b] = sum_i x_(i,a) G(i,b), local unknown i d + a.
    Eigen::MatrixXd B = Eigen::MatrixXd::Zero(r_, u_);
    for (int i = 0; i < s_; ++i)
      for (int a = 0; a < d_; ++a)
        for (int b = 0; b < d_; ++b) B(a * d_ + b, i * d_ + a) = G(i, b);
    std::vector<Eigen::VectorXd> removed;
    if (energy == Energy::Asap) {  // planar only: similarities span{I, J}
      removed = {vecOf(Eigen::Matrix2d::Identity()), vecOf(J2)};
    } else if (planar) {  // lARAP: infinitesimal rotations
      removed = {vecOf(J2)};
      t = vecOf(frame);
    } else {  // lARAP on tets and surfaces: span{[e_i]_x P_k} (METHOD.md §2)
      for (int i = 0; i < 3; ++i) removed.push_back(vecOf(cross(i) * frame));
      // vec(P_k) is Frobenius-orthogonal to every [e_i]_x P_k, so the projected target is P_k.
      t = vecOf(frame);
    }
    L = complementProjector(removed, r_) * B;
  }
}

int ResidualModel::unknown(int k, int j) const {
  const int v = disc_.elements()(k, j / q_);
  return v * q_ + j % q_;
}

Eigen::MatrixXd ResidualModel::toUnknowns(const Eigen::MatrixXd& P) const {
  if (!coupled_) return P;
  Eigen::MatrixXd x(static_cast<Eigen::Index>(P.rows()) * d_, 1);
  for (Eigen::Index v = 0; v < P.rows(); ++v)
    for (int a = 0; a < d_; ++a) x(v * d_ + a, 0) = P(v, a);
  return x;
}

Eigen::MatrixXd ResidualModel::toPositions(const Eigen::MatrixXd& x) const {
  if (!coupled_) return x;
  const Eigen::Index n = x.rows() / d_;
  Eigen::MatrixXd P(n, d_);
  for (Eigen::Index v = 0; v < n; ++v)
    for (int a = 0; a < d_; ++a) P(v, a) = x(v * d_ + a, 0);
  return P;
}

void ResidualModel::targets(const Eigen::MatrixXd& X, Eigen::MatrixXd& t) const {
  if (t.rows() != fixedT_.rows() || t.cols() != c_) t.resize(fixedT_.rows(), c_);
  if (!iterative_) {
    t = fixedT_;
    return;
  }
  const bool scaled = energy_ == Energy::Asap;
  parallel::forChunks(disc_.numElements(), kGrain, [&](int, int begin, int end) {
    if (d_ == 2)
      fitRotationRange<2>(disc_, scaled, X, t, nullptr, nullptr, begin, end);
    else
      fitRotationRange<3>(disc_, scaled, X, t, nullptr, nullptr, begin, end);
  });
}

void ResidualModel::residuals(const Eigen::MatrixXd& X, const Eigen::MatrixXd& t,
                              Eigen::MatrixXd& e) const {
  if (e.rows() != t.rows() || e.cols() != c_) e.resize(t.rows(), c_);
  parallel::forChunks(disc_.numElements(), kGrain, [&](int, int begin, int end) {
    residualRange(disc_, L_, q_, r_, u_, X, t, e, nullptr, begin, end);
  });
}

double ResidualModel::fit(const Eigen::MatrixXd& X, const RegularizationWeights& w,
                          Eigen::MatrixXd& t, Eigen::MatrixXd& e) const {
  const Eigen::Index rows = fixedT_.rows();
  if (t.rows() != rows || t.cols() != c_) t.resize(rows, c_);
  if (e.rows() != rows || e.cols() != c_) e.resize(rows, c_);
  const bool scaled = energy_ == Energy::Asap;
  const double elementSum = chunkedSum(disc_.numElements(), [&](int begin, int end) {
    if (!iterative_) {
      t.middleRows(static_cast<Eigen::Index>(begin) * r_,
                   static_cast<Eigen::Index>(end - begin) * r_) =
          fixedT_.middleRows(static_cast<Eigen::Index>(begin) * r_,
                             static_cast<Eigen::Index>(end - begin) * r_);
      return residualRange(disc_, L_, q_, r_, u_, X, t, e, &w.element, begin, end);
    }
    if (d_ == 2) return fitRotationRange<2>(disc_, scaled, X, t, &e, &w.element, begin, end);
    return fitRotationRange<3>(disc_, scaled, X, t, &e, &w.element, begin, end);
  });
  return scaledEnergy(elementSum, facetEnergy(e, w));
}

double ResidualModel::facetEnergy(const Eigen::MatrixXd& e, const RegularizationWeights& w) const {
  const auto& facets = disc_.facets();
  if (facets.empty() || w.facet.size() == 0 || w.facet.cwiseAbs().maxCoeff() == 0.0) return 0.0;
  return chunkedSum(static_cast<int>(facets.size()), [&](int begin, int end) {
    return facetRange(facets, w.facet, r_, e, begin, end);
  });
}

double ResidualModel::scaledEnergy(double elementSum, double facetSum) const {
  // Physical a_k and c_kl rescaled to the unit-mean-edge mesh: a' = ell^-md a, c' = ell^-(md-1) c
  // (METHOD.md §3).
  const double ell = disc_.meanEdgeLength();
  const double aScale = std::pow(ell, -disc_.measureDim()), cScale = aScale * ell;
  return aScale * elementSum + cScale * facetSum;
}

Eigen::MatrixXd ResidualModel::residuals(const Eigen::MatrixXd& X) const {
  Eigen::MatrixXd t, e;
  targets(X, t);
  residuals(X, t, e);
  return e;
}

Eigen::VectorXd ResidualModel::distortion(const Eigen::MatrixXd& e) const {
  const int m = disc_.numElements();
  Eigen::VectorXd D(m);
  for (int k = 0; k < m; ++k)
    D(k) = e.block(static_cast<Eigen::Index>(k) * r_, 0, r_, c_).squaredNorm();
  return D;
}

Eigen::VectorXd ResidualModel::facetDifference(const Eigen::MatrixXd& e) const {
  const auto& facets = disc_.facets();
  Eigen::VectorXd S(static_cast<Eigen::Index>(facets.size()));
  for (size_t f = 0; f < facets.size(); ++f)
    S(static_cast<Eigen::Index>(f)) =
        (e.block(static_cast<Eigen::Index>(facets[f].k) * r_, 0, r_, c_) -
         e.block(static_cast<Eigen::Index>(facets[f].l) * r_, 0, r_, c_))
            .squaredNorm();
  return S;
}

double ResidualModel::energy(const Eigen::MatrixXd& e, const RegularizationWeights& w) const {
  const double elementSum = chunkedSum(disc_.numElements(), [&](int begin, int end) {
    double sum = 0.0;
    for (int k = begin; k < end; ++k)
      sum += (1.0 - w.element(k)) * disc_.measures()(k) *
             e.block(static_cast<Eigen::Index>(k) * r_, 0, r_, c_).squaredNorm();
    return sum;
  });
  return scaledEnergy(elementSum, facetEnergy(e, w));
}

}  // namespace diffreg
