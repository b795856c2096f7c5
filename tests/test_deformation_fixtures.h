// Small meshes and handle sets shared by the deformation tests.
#pragma once

#include <diffreg/deformation/deformer.h>
#include <diffreg/deformation/energy.h>
#include <diffreg/deformation/residual_model.h>
#include <diffreg/deformation/metrics.h>
#include <diffreg/discretization/discretization.h>
#include <diffreg/mesh/shapes.h>

#include <Eigen/Geometry>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

namespace diffreg::testing {

inline const std::vector<MeshKind> kAllKinds = {MeshKind::Planar, MeshKind::Surface, MeshKind::Tet};
inline const std::vector<Energy> kAllEnergies = {Energy::Arap, Energy::Asap, Energy::Larap,
                                                 Energy::Dirichlet};

/// A bar along x of length 4 (planar 4 x 1, cylinder of radius 0.5 along x, tet box 4 x 1 x 1),
/// scaled by `scale`.
inline std::unique_ptr<Discretization> makeBar(MeshKind kind, double scale = 1.0) {
  Mesh mesh;
  if (kind == MeshKind::Planar) {
    mesh = makeRectangle(4.0, 1.0, 16, 4);
  } else if (kind == MeshKind::Surface) {
    mesh = makeCylinder(0.5, 4.0, 12, 16);
    // Lay the cylinder along x: (x, y, z) -> (z, y, -x).
    Eigen::MatrixXd P = mesh.positions();
    Eigen::MatrixXd Q(P.rows(), 3);
    Q.col(0) = P.col(2);
    Q.col(1) = P.col(1);
    Q.col(2) = -P.col(0);
    mesh.setPositions(Q);
  } else {
    mesh = makeTetBox(4.0, 1.0, 1.0, 8, 2, 2);
  }
  Eigen::MatrixXd P = mesh.positions();
  const MeshKind k = mesh.kind();
  Eigen::MatrixXi el = mesh.elements();
  return std::make_unique<Discretization>(k, P * scale, el);
}

/// Vertices with x within `tol` of the bar's minimum (end 0) or maximum (end 1).
inline std::vector<int> endVertices(const Discretization& disc, int end, double tol) {
  const Eigen::VectorXd x = disc.rest().col(0);
  const double target = end == 0 ? x.minCoeff() : x.maxCoeff();
  std::vector<int> ids;
  for (int v = 0; v < disc.numVertices(); ++v)
    if (std::abs(x(v) - target) <= tol) ids.push_back(v);
  return ids;
}

/// Both ends of the bar.
inline std::vector<int> bothEnds(const Discretization& disc) {
  std::vector<int> ids = endVertices(disc, 0, 1e-9 * disc.boundingBoxDiagonal());
  for (int v : endVertices(disc, 1, 1e-9 * disc.boundingBoxDiagonal())) ids.push_back(v);
  return ids;
}

/// The vertex closest to point p.
inline int nearestVertex(const Discretization& disc, const Eigen::RowVectorXd& p) {
  int best = 0;
  (disc.rest().rowwise() - p).rowwise().squaredNorm().minCoeff(&best);
  return best;
}

inline Eigen::MatrixXd rows(const Eigen::MatrixXd& X, const std::vector<int>& ids) {
  Eigen::MatrixXd R(static_cast<Eigen::Index>(ids.size()), X.cols());
  for (size_t i = 0; i < ids.size(); ++i) R.row(static_cast<Eigen::Index>(i)) = X.row(ids[i]);
  return R;
}

/// A rotation about the axis (1, 2, 3) (3D) or in the plane (2D) by `angle`.
inline Eigen::MatrixXd rotation(int d, double angle) {
  if (d == 2) return Eigen::Rotation2Dd(angle).toRotationMatrix();
  return Eigen::AngleAxisd(angle, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
}

/// Applies x -> s R x + t to every row.
inline Eigen::MatrixXd transform(const Eigen::MatrixXd& X, double s, const Eigen::MatrixXd& R,
                                 const Eigen::RowVectorXd& t) {
  return ((s * X * R.transpose()).rowwise() + t).eval();
}

/// Smooth bump peaking at `peak` on the handle points: x_i = peak max_j exp(-|p_i - h_j|^2 / w^2).
inline Eigen::VectorXd bumpWeights(const Discretization& disc, const std::vector<int>& handles,
                                   double peak, double width) {
  Eigen::VectorXd x = Eigen::VectorXd::Zero(disc.numVertices());
  for (int h : handles)
    for (int v = 0; v < disc.numVertices(); ++v) {
      const double r2 = (disc.rest().row(v) - disc.rest().row(h)).squaredNorm();
      x(v) = std::max(x(v), peak * std::exp(-r2 / (width * width)));
    }
  return x;
}

}  // namespace diffreg::testing
