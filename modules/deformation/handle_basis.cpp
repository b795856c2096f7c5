#include <diffreg/deformation/handle_basis.h>

#include <Eigen/Dense>
#include <algorithm>
#include <limits>
#include <numeric>

namespace diffreg {

namespace {

int findRoot(std::vector<int>& parent, int i) {
  while (parent[static_cast<size_t>(i)] != i) {
    parent[static_cast<size_t>(i)] = parent[static_cast<size_t>(parent[static_cast<size_t>(i)])];
    i = parent[static_cast<size_t>(i)];
  }
  return i;
}

}  // namespace

HandleBasis::HandleBasis(const Discretization& disc, const std::vector<int>& handles)
    : disc_(disc), handles_(handles) {
  // Union-find over the handle rows, joined by the elements' edges.
  std::vector<int> rowOf(static_cast<size_t>(disc.numVertices()), -1);
  for (size_t i = 0; i < handles.size(); ++i) rowOf[static_cast<size_t>(handles[i])] = static_cast<int>(i);
  std::vector<int> parent(handles.size());
  std::iota(parent.begin(), parent.end(), 0);
  const Eigen::MatrixXi& el = disc.elements();
  for (Eigen::Index k = 0; k < el.rows(); ++k)
    for (Eigen::Index a = 0; a < el.cols(); ++a)
      for (Eigen::Index b = a + 1; b < el.cols(); ++b) {
        const int i = rowOf[static_cast<size_t>(el(k, a))], j = rowOf[static_cast<size_t>(el(k, b))];
        if (i < 0 || j < 0) continue;
        const int ri = findRoot(parent, i), rj = findRoot(parent, j);
        if (ri != rj) parent[static_cast<size_t>(std::max(ri, rj))] = std::min(ri, rj);
      }
  std::vector<int> groupOfRoot(handles.size(), -1);
  for (size_t i = 0; i < handles.size(); ++i) {
    const int r = findRoot(parent, static_cast<int>(i));
    if (groupOfRoot[static_cast<size_t>(r)] < 0) {
      groupOfRoot[static_cast<size_t>(r)] = groups_++;
      members_.emplace_back();
    }
    members_[static_cast<size_t>(groupOfRoot[static_cast<size_t>(r)])].push_back(static_cast<int>(i));
  }
  // The decomposition of each group's [p 1] for the moves' affine fits.
  if (!usable()) return;
  for (int g = 0; g < groups_; ++g) fits_.emplace_back(restCoordinates(g));
}

Eigen::MatrixXd HandleBasis::restCoordinates(int g) const {
  const std::vector<int>& rows = members_[static_cast<size_t>(g)];
  const int d = disc_.dim();
  Eigen::MatrixXd P(static_cast<Eigen::Index>(rows.size()), d + 1);
  for (size_t i = 0; i < rows.size(); ++i) {
    const Eigen::Index at = static_cast<Eigen::Index>(i);
    P.block(at, 0, 1, d) = disc_.rest().row(handles_[static_cast<size_t>(rows[i])]);
    P(at, d) = 1.0;
  }
  return P;
}

bool HandleBasis::usable() const {
  return groups_ > 0 && (disc_.dim() + 1) * groups_ <= kMaxColumns;
}

void HandleBasis::build(RegularizedSystem& system, const Eigen::MatrixXd& restRhs) {
  const int d = disc_.dim(), c = d + 1;
  const Eigen::Index h = static_cast<Eigen::Index>(handles_.size());
  x0_ = system.solveRightHandSide(restRhs, Eigen::MatrixXd::Zero(h, d));
  // Columns g (d+1) + a: coordinate a of group g's rest points (a = d: 1), 0 off the group;
  // one group at a time, so that the solve's scratch stays that of d+1 columns.
  phi_.resize(disc_.numVertices(), static_cast<Eigen::Index>(c) * groups_);
  for (int g = 0; g < groups_; ++g) {
    const std::vector<int>& rows = members_[static_cast<size_t>(g)];
    const Eigen::MatrixXd P = restCoordinates(g);
    Eigen::MatrixXd values = Eigen::MatrixXd::Zero(h, c);
    for (size_t i = 0; i < rows.size(); ++i) values.row(rows[i]) = P.row(static_cast<Eigen::Index>(i));
    phi_.middleCols(static_cast<Eigen::Index>(g) * c, c) = system.handleResponse(values);
  }
  built_ = true;
}

bool HandleBasis::solve(const Eigen::MatrixXd& targets, Eigen::MatrixXd& X) const {
  const int d = disc_.dim(), c = d + 1;
  if (targets.rows() != static_cast<Eigen::Index>(handles_.size()) || targets.cols() < d)
    return false;
  Eigen::MatrixXd coefficients(static_cast<Eigen::Index>(c) * groups_, d);
  for (int g = 0; g < groups_; ++g) {
    const std::vector<int>& rows = members_[static_cast<size_t>(g)];
    const Eigen::MatrixXd P = restCoordinates(g);
    Eigen::MatrixXd T(P.rows(), d);
    for (size_t i = 0; i < rows.size(); ++i)
      T.row(static_cast<Eigen::Index>(i)) = targets.row(rows[i]).leftCols(d);
    // Least squares (any solution reproduces T when it is affine, even for collinear points).
    const Eigen::MatrixXd M = fits_[static_cast<size_t>(g)].solve(T);
    // 1e-12 of the mesh's size, plus the round-off of coordinates this far from the origin.
    const double magnitude =
        std::max(T.cwiseAbs().maxCoeff(), P.leftCols(d).cwiseAbs().maxCoeff());
    const double tolerance = 1e-12 * disc_.boundingBoxDiagonal() +
                             16.0 * std::numeric_limits<double>::epsilon() * magnitude;
    if (!((P * M - T).cwiseAbs().maxCoeff() <= tolerance)) return false;
    coefficients.block(static_cast<Eigen::Index>(g) * c, 0, c, d) = M;
  }
  X = x0_;
  X.noalias() += phi_ * coefficients;
  for (size_t i = 0; i < handles_.size(); ++i)
    X.row(handles_[i]) = targets.row(static_cast<Eigen::Index>(i)).leftCols(d);
  return true;
}

}  // namespace diffreg
