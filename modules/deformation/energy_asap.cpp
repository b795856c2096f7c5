// ASAP: e_k = F_k - closest similarity. Planar: linear, the residual removes span{I, J} from
// vec(F) (coupled layout), so 2 distinct handle points pin it. Surfaces and tets: s_k R_k with
// the rotation of ARAP and the best scale, local/global.
#include <diffreg/deformation/energy.h>
#include <diffreg/deformation/rotation.h>

namespace diffreg {

namespace {

Eigen::VectorXd vec2(const Eigen::Matrix2d& M) {
  return (Eigen::VectorXd(4) << M(0, 0), M(0, 1), M(1, 0), M(1, 1)).finished();
}

class Asap final : public EnergyModel {
 public:
  Energy id() const override { return Energy::Asap; }
  bool iterative(MeshKind kind) const override { return kind != MeshKind::Planar; }
  bool coupled(MeshKind kind) const override { return kind == MeshKind::Planar; }
  int kernelRank(MeshKind kind) const override { return kind == MeshKind::Planar ? 1 : 0; }
  std::vector<Eigen::VectorXd> removedModes(const Eigen::MatrixXd&, MeshKind) const override {
    Eigen::Matrix2d J;
    J << 0, -1, 1, 0;
    return {vec2(Eigen::Matrix2d::Identity()), vec2(J)};
  }
  Eigen::Matrix3d fit(const Eigen::Matrix3d& C, double weight,
                      const Eigen::Vector3d* normal) const override {
    Eigen::Matrix3d T;
    double* out = T.data();
    fitBatch(1, &C, &weight, &normal, &out);
    return T;
  }
  // min over s, R of weight s^2 |R|^2 - 2 s tr(R^T C): R the rotation fit to C and
  // s = tr(R^T C) / (weight |R|^2), |R|^2 = 2 on surfaces (tangent plane), 3 on tets.
  void fitBatch(int count, const Eigen::Matrix3d* C, const double* weight,
                const Eigen::Vector3d* const* normal, double* const* T) const override {
    for (int i = 0; i < count; ++i) {
      double trace = 0.0;
      rotationTarget(C[i], normal[i], trace, T[i]);
      const double scale = trace / (weight[i] * (normal[i] ? 2.0 : 3.0));
      for (int j = 0; j < 9; ++j) T[i][j] *= scale;
    }
  }
};

}  // namespace

const EnergyModel& asapEnergy() {
  static const Asap model;
  return model;
}

}  // namespace diffreg
