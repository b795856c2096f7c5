#include "deformation/energy.h"

#include "core/error.h"
#include "deformation/rotation.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <string>
#include <thread>
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

// Local step of the iterative energies: T_k = R_k (ARAP) or s_k R_k (ASAP), R_k the closest
// rotation to F_k with det > 0 (flipping the singular vector of the smallest singular value),
// s_k = tr(Sigma) / 2 (surfaces) or / 3 (tets); surfaces act on the tangent plane: T_k P_k.
// Stored transposed (separable layout: e_k = F_k^T - T_k^T).
template <int D>
void fitRotationRange(const Discretization& disc, bool scaled, const Eigen::MatrixXd& X,
                      Eigen::MatrixXd& t, int begin, int end) {
  using Mat = Eigen::Matrix<double, D, D>;
  using Vec = Eigen::Matrix<double, D, 1>;
  const int s = disc.elementSize();
  const Eigen::MatrixXi& el = disc.elements();
  const bool surface = disc.kind() == MeshKind::Surface;
  const double scaleDivisor = surface ? 2.0 : static_cast<double>(D);
  for (int k = begin; k < end; ++k) {
    const auto G = disc.gradient(k);
    Mat F = Mat::Zero();
    for (int i = 0; i < s; ++i) {
      const Vec x = X.row(el(k, i)).transpose();
      const Vec g = G.row(i).transpose();
      F.noalias() += x * g.transpose();
    }
    Vec sigma;
    Mat T = closestRotation<D>(F, sigma);
    if (scaled) T *= sigma.sum() / scaleDivisor;
    if (surface) {
      const Vec n = disc.normals().row(k).transpose();
      T = T - (T * n) * n.transpose();
    }
    t.block<D, D>(static_cast<Eigen::Index>(k) * D, 0) = T.transpose();
  }
}

// Runs body(begin, end) over [0, n) in a few threads when n is large; each element's work is
// independent and writes only its own rows.
template <class Body>
void parallelFor(int n, const Body& body) {
  const int hardware = static_cast<int>(std::thread::hardware_concurrency());
  const int chunks = n < 8192 ? 1 : std::max(1, std::min(hardware, 8));
  if (chunks == 1) return body(0, n);
  std::vector<std::thread> threads;
  threads.reserve(static_cast<size_t>(chunks - 1));
  const int step = (n + chunks - 1) / chunks;
  for (int c = 1; c < chunks; ++c)
    threads.emplace_back(body, std::min(n, c * step), std::min(n, (c + 1) * step));
  body(0, std::min(n, step));
  for (auto& th : threads) th.join();
}

template <int D>
void fitRotations(const Discretization& disc, bool scaled, const Eigen::MatrixXd& X,
                  Eigen::MatrixXd& t) {
  parallelFor(disc.numElements(),
              [&](int begin, int end) { fitRotationRange<D>(disc, scaled, X, t, begin, end); });
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
  if (d_ == 2)
    fitRotations<2>(disc_, scaled, X, t);
  else
    fitRotations<3>(disc_, scaled, X, t);
}

void ResidualModel::residuals(const Eigen::MatrixXd& X, const Eigen::MatrixXd& t,
                              Eigen::MatrixXd& e) const {
  const int m = disc_.numElements();
  if (e.rows() != t.rows() || e.cols() != c_) e.resize(t.rows(), c_);
  Eigen::MatrixXd xk(u_, c_);
  const Eigen::MatrixXi& el = disc_.elements();
  for (int k = 0; k < m; ++k) {
    for (int i = 0; i < s_; ++i) {
      const int v = el(k, i);
      if (coupled_)
        for (int a = 0; a < d_; ++a) xk(i * d_ + a, 0) = X(v, a);
      else
        xk.row(i) = X.row(v);
    }
    e.block(static_cast<Eigen::Index>(k) * r_, 0, r_, c_).noalias() = local(k) * xk;
  }
  e -= t;
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
  // Physical a_k and c_kl rescaled to the unit-mean-edge mesh: a' = ell^-md a, c' = ell^-(md-1) c
  // (METHOD.md §3).
  const double ell = disc_.meanEdgeLength();
  const double aScale = std::pow(ell, -disc_.measureDim()), cScale = aScale * ell;
  double E = 0.0;
  for (int k = 0; k < disc_.numElements(); ++k)
    E += (1.0 - w.element(k)) * aScale * disc_.measures()(k) *
         e.block(static_cast<Eigen::Index>(k) * r_, 0, r_, c_).squaredNorm();
  const auto& facets = disc_.facets();
  for (size_t f = 0; f < facets.size(); ++f)
    E += w.facet(static_cast<Eigen::Index>(f)) * cScale * facets[f].c *
         (e.block(static_cast<Eigen::Index>(facets[f].k) * r_, 0, r_, c_) -
          e.block(static_cast<Eigen::Index>(facets[f].l) * r_, 0, r_, c_))
             .squaredNorm();
  return E;
}

}  // namespace diffreg
