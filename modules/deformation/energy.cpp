#include "deformation/energy.h"

#include "core/error.h"

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
  const char* name;
  const EnergyModel& (*model)();
};

const std::array<EnergyEntry, 4> kEnergies = {{
    {Energy::Arap, "arap", arapEnergy},
    {Energy::Asap, "asap", asapEnergy},
    {Energy::Larap, "larap", larapEnergy},
    {Energy::Dirichlet, "dirichlet", dirichletEnergy},
}};

std::string energyNames() {
  std::string names;
  for (const EnergyEntry& e : kEnergies) names += (names.empty() ? "" : ", ") + std::string(e.name);
  return names;
}

}  // namespace

const char* toString(Energy energy) {
  for (const EnergyEntry& e : kEnergies)
    if (e.id == energy) return e.name;
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
  for (const EnergyEntry& e : kEnergies)
    if (name == e.name) return e.id;
  throw InvalidParameter("energy: unknown energy '" + name + "' (valid: " + energyNames() + ")");
}

Regularization parseRegularization(const std::string& name) {
  for (Regularization r :
       {Regularization::None, Regularization::Uniform, Regularization::Nonuniform})
    if (name == toString(r)) return r;
  throw InvalidParameter("regularization: unknown mode '" + name +
                         "' (valid: none, uniform, nonuniform)");
}

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

}  // namespace diffreg
