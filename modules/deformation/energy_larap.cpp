// Linearized ARAP: e_k = sym(F_k) - I (planar, tets); on surfaces (I - Pi_k) vec(F_k - P_k),
// Pi_k the projector onto the infinitesimal rotations {[theta]_x P_k}, the same rule. Linear,
// coordinates coupled; infinitesimal rotations are free, so 2 (planar) or 3 non-collinear (3D)
// handle points pin it.
#include <diffreg/deformation/energy.h>

namespace diffreg {

namespace {

// Row-major vec of a d x d matrix.
Eigen::VectorXd vecOf(const Eigen::MatrixXd& M) {
  Eigen::VectorXd v(M.size());
  for (int a = 0; a < M.rows(); ++a)
    for (int b = 0; b < M.cols(); ++b) v(a * M.cols() + b) = M(a, b);
  return v;
}

Eigen::Matrix3d cross(int i) {
  Eigen::Vector3d e = Eigen::Vector3d::Zero();
  e(i) = 1.0;
  Eigen::Matrix3d C;
  C << 0, -e(2), e(1), e(2), 0, -e(0), -e(1), e(0), 0;
  return C;
}

class Larap final : public EnergyModel {
 public:
  Energy id() const override { return Energy::Larap; }
  bool iterative(MeshKind) const override { return false; }
  bool coupled(MeshKind) const override { return true; }
  int kernelRank(MeshKind kind) const override { return kind == MeshKind::Planar ? 1 : 2; }
  std::vector<Eigen::VectorXd> removedModes(const Eigen::MatrixXd& frame,
                                            MeshKind kind) const override {
    if (kind == MeshKind::Planar) {
      Eigen::Matrix2d J;
      J << 0, -1, 1, 0;
      return {vecOf(J)};
    }
    std::vector<Eigen::VectorXd> modes;
    for (int i = 0; i < 3; ++i) modes.push_back(vecOf(cross(i) * frame));
    return modes;
  }
  // vec(P_k) is Frobenius-orthogonal to every [e_i]_x P_k, so the projected target is P_k.
  Eigen::MatrixXd constantTarget(const Eigen::MatrixXd& frame, MeshKind) const override {
    return frame;
  }
};

}  // namespace

const EnergyModel& larapEnergy() {
  static const Larap model;
  return model;
}

}  // namespace diffreg
