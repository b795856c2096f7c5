#include "deform/deform.h"

#include "deform/edit.h"
#include "deform/measure.h"
#include "deformation/deformer.h"
#include "deformation/metrics.h"
#include "pipeline/params.h"
#include "plugins.h"

namespace diffreg {

std::string DeformFilter::description() const {
  return "Variational deformation with the handles as hard constraints: ARAP (local/global), "
         "ASAP, linearized ARAP or Dirichlet energy, on planar, surface and tet meshes, with "
         "the energy-smoothness regularizer (Martinez Esturo et al. 2014) off, uniform (one "
         "beta, eq. 2) or non-uniform (per-element beta from the vertex property "
         "diffreg:weight, eq. 3). Writes the deformed positions and the per-element distortion "
         "diffreg:distortion and smoothness diffreg:smoothness. Zhu, Li, Zhang, Song: "
         "Diffusion-based non-uniform regularization for variational shape deformation, "
         "Computer-Aided Design (2016), Sec. 3.1.";
}

std::vector<ParamSpec> DeformFilter::params() const {
  std::vector<ParamSpec> specs(5);
  specs[0].name = "energy";
  specs[0].type = ParamType::Enum;
  specs[0].defaultValue = "arap";
  specs[0].choices = {"arap", "asap", "larap", "dirichlet"};
  specs[0].help = "Deformation energy: arap, asap, larap (linearized ARAP) or dirichlet.";
  specs[1].name = "regularization";
  specs[1].type = ParamType::Enum;
  specs[1].defaultValue = "none";
  specs[1].choices = {"none", "uniform", "nonuniform"};
  specs[1].help =
      "none; uniform (one beta everywhere, eq. 2); nonuniform (per-element beta from the "
      "vertex weights diffreg:weight, eq. 3; run diffuse_weights first).";
  specs[2].name = "beta";
  specs[2].type = ParamType::Float;
  specs[2].defaultValue = "0.5";
  specs[2].min = 0.0;
  specs[2].max = 1.0;
  specs[2].help = "Regularization strength for regularization=uniform.";
  specs[3].name = "iterations";
  specs[3].type = ParamType::Int;
  specs[3].defaultValue = "50";
  specs[3].min = 1;
  specs[3].max = 100000;
  specs[3].help = "Maximum local/global iterations (ARAP, and ASAP on surfaces and solids).";
  specs[4].name = "tolerance";
  specs[4].type = ParamType::Float;
  specs[4].defaultValue = "1e-6";
  specs[4].min = 0.0;
  specs[4].max = 1.0;
  specs[4].help = "Stop when an iteration lowers the energy by less than this fraction.";
  return specs;
}

std::vector<std::string> DeformFilter::requires(const ParamMap& params) const {
  if (params.getString("regularization") == "nonuniform") return {prop::weight};
  return {};
}

std::vector<std::string> DeformFilter::produces(const ParamMap&) const {
  return {prop::distortion, prop::smoothness};
}

FilterResult DeformFilter::apply(Document& doc, const ParamMap& params) const {
  const Discretization disc = restDiscretization(doc);
  DeformationOptions options;
  options.energy = parseEnergy(params.getString("energy"));
  options.regularization = parseRegularization(params.getString("regularization"));
  options.beta = params.getFloat("beta");
  if (options.regularization == Regularization::Nonuniform)
    options.weights = doc.mesh.vertexScalar(prop::weight);
  options.maxIterations = params.getInt("iterations");
  options.relTolerance = params.getFloat("tolerance");
  if (doc.progress)
    options.progress = [&doc](int iteration, double energy) {
      doc.progress("deform", iteration, energy);
    };

  DeformationSession session(disc, options);
  const Edit edit = editOf(doc.handles);
  session.setHandles(edit.vertices);
  session.setTargets(edit.targets);
  const DeformationResult result = session.solve();

  doc.mesh.setPositions(toMeshPositions(doc, result.positions));
  writeElementMaps(doc, disc, options.energy, result.positions);
  for (const auto& [key, value] : params.text()) doc.state["deform." + key] = value;

  FilterResult out;
  out.stats = session.stats();
  out.data = {{"energy", toString(options.energy)},
              {"regularization", toString(options.regularization)},
              {"initial_guess", result.initialGuess},
              {"iterations", result.iterations},
              {"converged", result.converged},
              {"energies", result.energies}};
  if (options.regularization == Regularization::Uniform) out.data["beta"] = options.beta;
  return out;
}

void registerDeformFilters(Registry& registry) {
  registry.add(std::make_unique<DeformFilter>());
  registry.add(std::make_unique<MeasureFilter>());
}

}  // namespace diffreg
