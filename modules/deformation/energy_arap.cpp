// ARAP: e_k = F_k - R_k, R_k the closest proper rotation (surfaces: acting on the tangent plane,
// R_k P_k). Local/global on every kind of mesh; translations are its only free motions.
#include <diffreg/deformation/energy.h>
#include <diffreg/deformation/rotation.h>

namespace diffreg {

namespace {

class Arap final : public EnergyModel {
 public:
  Energy id() const override { return Energy::Arap; }
  bool iterative(MeshKind) const override { return true; }
  bool coupled(MeshKind) const override { return false; }
  int kernelRank(MeshKind) const override { return 0; }
  Eigen::Matrix2d fit(const Eigen::Matrix2d& C, double) const override {
    double trace = 0.0;
    return closestRotation2(C, trace);
  }
  Eigen::Matrix3d fit(const Eigen::Matrix3d& C, double,
                      const Eigen::Vector3d* normal) const override {
    double trace = 0.0;
    return rotationTarget(C, normal, trace);
  }
  void fitBatch(int count, const Eigen::Matrix3d* C, const double*,
                const Eigen::Vector3d* const* normal, double* const* T) const override {
    for (int i = 0; i < count; ++i) {
      double trace = 0.0;
      rotationTarget(C[i], normal[i], trace, T[i]);
    }
  }
};

}  // namespace

const EnergyModel& arapEnergy() {
  static const Arap model;
  return model;
}

}  // namespace diffreg
