#include <diffreg/deformation/energy.h>

#include <diffreg/core/error.h>

#include <array>
#include <string>

namespace diffreg {

// The energies, one per file.
const EnergyModel& arapEnergy();
const EnergyModel& asapEnergy();
const EnergyModel& larapEnergy();
const EnergyModel& dirichletEnergy();

namespace {

struct EnergyEntry {
  Energy id;
  const EnergyModel& (*model)();
};

const std::array<EnergyEntry, 4> kEnergies = {{
    {Energy::Arap, arapEnergy},
    {Energy::Asap, asapEnergy},
    {Energy::Larap, larapEnergy},
    {Energy::Dirichlet, dirichletEnergy},
}};

}  // namespace

const EnergyModel& energyModel(Energy energy) {
  for (const EnergyEntry& e : kEnergies)
    if (e.id == energy) return e.model();
  throw InvalidParameter("energy: unknown energy");
}

bool isIterative(Energy energy, MeshKind kind) { return energyModel(energy).iterative(kind); }

bool isCoupled(Energy energy, MeshKind kind) { return energyModel(energy).coupled(kind); }

std::vector<Eigen::VectorXd> EnergyModel::removedModes(const Eigen::MatrixXd&, MeshKind) const {
  return {};
}

Eigen::MatrixXd EnergyModel::constantTarget(const Eigen::MatrixXd& frame, MeshKind) const {
  return Eigen::MatrixXd::Zero(frame.rows(), frame.cols());
}

Eigen::Matrix2d EnergyModel::fit(const Eigen::Matrix2d&, double) const {
  throw InvalidParameter(std::string("energy: ") + toString(id()) + " has no local fit in 2D");
}

Eigen::Matrix3d EnergyModel::fit(const Eigen::Matrix3d&, double, const Eigen::Vector3d*) const {
  throw InvalidParameter(std::string("energy: ") + toString(id()) + " has no local fit in 3D");
}

void EnergyModel::fitBatch(int count, const Eigen::Matrix3d* C, const double* weight,
                           const Eigen::Vector3d* const* normal, double* const* T) const {
  for (int i = 0; i < count; ++i)
    Eigen::Map<Eigen::Matrix3d>{T[i]} = fit(C[i], weight[i], normal[i]);
}

}  // namespace diffreg
