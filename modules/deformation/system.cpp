#include "deformation/system.h"

#include "core/error.h"

#include <Eigen/Dense>
#include <algorithm>
#include <string>

namespace diffreg {

RegularizedSystem::RegularizedSystem(const ResidualModel& model, SolverBackend backend)
    : model_(model), solver_(backend) {
  setWeights(makeRegularizationWeights(model.discretization(), Regularization::None, 0.0));
}

void RegularizedSystem::setHandles(const std::vector<int>& vertices) {
  handles_ = vertices;
  partitionDirty_ = true;
}

void RegularizedSystem::setWeights(const RegularizationWeights& weights) {
  weights_ = weights;
  assemble();
  matrixDirty_ = true;
}

void RegularizedSystem::assemble() {
  const Discretization& disc = model_.discretization();
  const int m = disc.numElements(), r = model_.rows(), u = model_.localSize();
  const int N = model_.numUnknowns();
  const auto& facets = disc.facets();
  const double ell = disc.meanEdgeLength();
  std::vector<Eigen::Triplet<double>> a, c;
  const size_t unionSize = static_cast<size_t>(u + model_.dofsPerVertex());
  a.reserve(static_cast<size_t>(m) * u * u + facets.size() * unionSize * unionSize);
  c.reserve(static_cast<size_t>(m) * u * r + 2 * facets.size() * unionSize * r);

  // Elements: (1 - beta_k) a_k L_k^T L_k and its right-hand-side operator.
  std::vector<int> ids(u);
  for (int k = 0; k < m; ++k) {
    const double w = (1.0 - weights_.element(k)) * disc.measures()(k);
    const auto L = model_.local(k);
    const Eigen::MatrixXd LtL = w * L.transpose() * L;
    for (int j = 0; j < u; ++j) ids[j] = model_.unknown(k, j);
    for (int i = 0; i < u; ++i) {
      for (int j = 0; j < u; ++j) a.emplace_back(ids[i], ids[j], LtL(i, j));
      for (int row = 0; row < r; ++row) c.emplace_back(ids[i], k * r + row, w * L(row, i));
    }
  }

  // Facets: ell beta_kl c_kl (L_k - L_l)^T (L_k - L_l) over the union of their unknowns.
  std::vector<int> uni;
  Eigen::MatrixXd M;
  for (size_t f = 0; f < facets.size(); ++f) {
    const Facet& fc = facets[f];
    const double w = ell * weights_.facet(static_cast<Eigen::Index>(f)) * fc.c;
    uni.clear();
    for (int j = 0; j < u; ++j) uni.push_back(model_.unknown(fc.k, j));
    M.setZero(r, u + u);
    M.leftCols(u) = model_.local(fc.k);
    const auto Ll = model_.local(fc.l);
    for (int j = 0; j < u; ++j) {
      const int id = model_.unknown(fc.l, j);
      auto it = std::find(uni.begin(), uni.end(), id);
      const int pos = static_cast<int>(it - uni.begin());
      if (it == uni.end()) uni.push_back(id);
      M.col(pos) -= Ll.col(j);
    }
    const int U = static_cast<int>(uni.size());
    const Eigen::MatrixXd MtM = w * M.leftCols(U).transpose() * M.leftCols(U);
    for (int i = 0; i < U; ++i) {
      for (int j = 0; j < U; ++j) a.emplace_back(uni[i], uni[j], MtM(i, j));
      for (int row = 0; row < r; ++row) {
        c.emplace_back(uni[i], fc.k * r + row, w * M(row, i));
        c.emplace_back(uni[i], fc.l * r + row, -w * M(row, i));
      }
    }
  }
  A_.resize(N, N);
  A_.setFromTriplets(a.begin(), a.end());
  A_.makeCompressed();
  C_.resize(N, static_cast<Eigen::Index>(m) * r);
  C_.setFromTriplets(c.begin(), c.end());
  C_.makeCompressed();
}

namespace {

// Affine rank of a point set (0 for one point, 1 for distinct collinear points, ...).
int affineRank(const Eigen::MatrixXd& P, double tolerance) {
  if (P.rows() <= 1) return 0;
  const Eigen::MatrixXd C = P.rowwise() - P.colwise().mean();
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(C);
  int rank = 0;
  for (Eigen::Index i = 0; i < svd.singularValues().size(); ++i)
    if (svd.singularValues()(i) > tolerance) ++rank;
  return rank;
}

const char* needText(int rank) {
  switch (rank) {
    case 0:
      return "at least 1 handle vertex";
    case 1:
      return "2 distinct handle points";
    case 2:
      return "3 non-collinear handle points";
    default:
      return "4 non-coplanar handle points";
  }
}

}  // namespace

std::string RegularizedSystem::singularity() const {
  const Discretization& disc = model_.discretization();
  const int nc = disc.numComponents(), d = disc.dim();
  const auto& comp = disc.component();
  // What the energy alone pins: translations (1 point), 2D similarities or 2D infinitesimal
  // rotations (2 points), 3D infinitesimal rotations (3 non-collinear points).
  int base = 0;
  if (model_.energy() == Energy::Larap)
    base = disc.kind() == MeshKind::Planar ? 1 : 2;
  else if (model_.energy() == Energy::Asap && disc.kind() == MeshKind::Planar)
    base = 1;
  std::vector<bool> hasEnergy(nc, false);
  for (int k = 0; k < disc.numElements(); ++k)
    if (weights_.element(k) < 1.0) hasEnergy[comp[disc.elements()(k, 0)]] = true;
  std::vector<std::vector<int>> handlesOf(nc);
  for (int v : handles_)
    if (comp[v] >= 0) handlesOf[comp[v]].push_back(v);
  std::vector<int> size(nc, 0), example(nc, -1);
  for (int v = 0; v < disc.numVertices(); ++v)
    if (comp[v] >= 0) {
      ++size[comp[v]];
      if (example[comp[v]] < 0) example[comp[v]] = v;
    }
  const double tolerance = 1e-8 * disc.boundingBoxDiagonal();
  for (int ci = 0; ci < nc; ++ci) {
    // beta = 1 on the whole component: S alone does not pin affine maps (METHOD.md §3).
    const int need = hasEnergy[ci] ? base : d;
    const auto& h = handlesOf[ci];
    Eigen::MatrixXd P(static_cast<Eigen::Index>(h.size()), d);
    for (size_t i = 0; i < h.size(); ++i)
      P.row(static_cast<Eigen::Index>(i)) = disc.rest().row(h[i]);
    if (!h.empty() && affineRank(P, tolerance) >= need) continue;
    return "deformation: mesh component " + std::to_string(ci) + " (" + std::to_string(size[ci]) +
           " vertices, including vertex " + std::to_string(example[ci]) + ") has " +
           std::to_string(h.size()) + " handle vertices; " + toString(model_.energy()) +
           (hasEnergy[ci] ? "" : " with beta = 1 on the whole component") + " needs " +
           needText(need);
  }
  return {};
}

Eigen::MatrixXd RegularizedSystem::solve(const Eigen::MatrixXd& t,
                                         const Eigen::MatrixXd& handlePositions) {
  const Discretization& disc = model_.discretization();
  const int q = model_.dofsPerVertex();
  if (partitionDirty_ || matrixDirty_) {
    const std::string reason = singularity();
    if (!reason.empty()) throw SingularSystem(reason);
  }
  if (partitionDirty_) {
    std::vector<bool> fixed(static_cast<size_t>(model_.numUnknowns()), false);
    for (int v = 0; v < disc.numVertices(); ++v)
      if (!disc.active()[v])
        for (int a = 0; a < q; ++a) fixed[static_cast<size_t>(v * q + a)] = true;
    for (int v : handles_)
      for (int a = 0; a < q; ++a) fixed[static_cast<size_t>(v * q + a)] = true;
    solver_.setPartition(Partition(fixed));
    partitionDirty_ = false;
    matrixDirty_ = true;
  }
  if (matrixDirty_) {
    try {
      solver_.setMatrix(A_);
    } catch (const SingularSystem& e) {
      // E.g. lARAP on a flat surface leaves out-of-plane motion free to first order.
      throw SingularSystem(std::string("deformation: the ") + toString(model_.energy()) +
                           " system has no unique solution with these handles (" + e.what() + ")");
    }
    matrixDirty_ = false;
  }
  Eigen::MatrixXd known = disc.rest();
  for (size_t i = 0; i < handles_.size(); ++i)
    known.row(handles_[i]) = handlePositions.row(static_cast<Eigen::Index>(i));
  const Eigen::MatrixXd xFixed = solver_.partition().gatherFixed(model_.toUnknowns(known));
  b_.noalias() = C_ * t;
  return model_.toPositions(solver_.solve(b_, xFixed));
}

}  // namespace diffreg
