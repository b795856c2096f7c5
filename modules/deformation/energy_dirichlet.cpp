// Dirichlet: e_k = F_k - I (surfaces: F_k - P_k). Linear and separable; translations are its
// only free motions.
#include <diffreg/deformation/energy.h>

namespace diffreg {

namespace {

class Dirichlet final : public EnergyModel {
 public:
  Energy id() const override { return Energy::Dirichlet; }
  bool iterative(MeshKind) const override { return false; }
  bool coupled(MeshKind) const override { return false; }
  int kernelRank(MeshKind) const override { return 0; }
  Eigen::MatrixXd constantTarget(const Eigen::MatrixXd& frame, MeshKind) const override {
    return frame;
  }
};

}  // namespace

const EnergyModel& dirichletEnergy() {
  static const Dirichlet model;
  return model;
}

}  // namespace diffreg
