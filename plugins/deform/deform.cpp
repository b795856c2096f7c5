#include "deform/deform.h"

#include <diffreg/core/error.h>
#include <diffreg/core/log.h>
#include <diffreg/core/timer.h>

#include <diffreg/deformation/deformer.h>
#include <diffreg/deformation/energy.h>
#include <diffreg/deformation/metrics.h>
#include <diffreg/engine/edit_engine.h>
#include <diffreg/pipeline/params.h>
#include "deform/measure.h"
#include "plugins.h"

#include <cmath>
#include <cstdio>

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
  // Defaults and choices come from DeformationOptions and the enums' name tables.
  const DeformationOptions defaults;
  return {
      enumParam("energy", defaults.energy,
                "Deformation energy: arap, asap, larap (linearized ARAP) or dirichlet."),
      enumParam("regularization", defaults.regularization,
                "none; uniform (one beta everywhere, eq. 2); nonuniform (per-element beta from "
                "the vertex weights diffreg:weight, eq. 3; run diffuse_weights first)."),
      floatParam("beta", formatNumber(kDefaultUniformBeta), 0.0, 1.0,
                 "Regularization strength for regularization=uniform."),
      enumParam("local_step", defaults.localStep,
                "exact: each rotation minimizes the regularized energy with its neighbours "
                "fixed (coloured Gauss-Seidel), so the energy never rises; reference: each "
                "rotation fitted to its own element, as the paper's reference code (with "
                "regularization not a descent method; for reproducing the paper)."),
      enumParam("acceleration", defaults.acceleration,
                "lbfgs: quasi-Newton steps with the local/global matrix as initial Hessian and "
                "a line search on the energy; anderson: Anderson acceleration of the iterates, "
                "taken only when it lowers the energy; none: plain local/global. Exact local "
                "step only."),
      intParam("iterations", std::to_string(defaults.maxIterations), 1, kMaxIterations,
               "Cap on the local/global iterations (ARAP, and ASAP on surfaces and solids); "
               "converged runs stop well before it."),
      floatParam("tolerance", formatNumber(defaults.relTolerance), 0.0, 1.0,
                 "Stationarity: stop when one more plain local/global iteration would lower the "
                 "energy by less than this fraction (reference local step: when an iteration "
                 "changes it by less)."),
  };
}

std::vector<std::string> DeformFilter::requires(const ParamMap& params) const {
  if (params.getString("regularization") == "nonuniform") return {prop::weight};
  return {};
}

std::vector<std::string> DeformFilter::produces(const ParamMap&) const {
  return {prop::distortion, prop::smoothness};
}

DeformationOptions deformationOptionsOf(const ParamMap& params) {
  DeformationOptions options;
  options.energy = parseEnum<Energy>(params.getString("energy"));
  options.regularization = parseEnum<Regularization>(params.getString("regularization"));
  options.beta = params.getFloat("beta");
  options.localStep = parseEnum<LocalStep>(params.getString("local_step"));
  options.acceleration = parseEnum<Acceleration>(params.getString("acceleration"));
  options.maxIterations = params.getInt("iterations");
  options.relTolerance = params.getFloat("tolerance");
  return options;
}

void warnInapplicable(const ParamMap& params, MeshKind kind) {
  const DeformationOptions options = deformationOptionsOf(params);
  const auto ignored = [&](const char* name, const std::string& why) {
    if (params.given(name))
      warnParameter("deform: " + std::string(name) + "=" + params.text().at(name) +
                    " is ignored: " + why);
  };
  if (options.regularization != Regularization::Uniform)
    ignored("beta", "it is the strength of regularization=uniform (here " +
                        std::string(toString(options.regularization)) + ")");
  if (!energyModel(options.energy).iterative(kind)) {
    const std::string why = "energy=" + std::string(toString(options.energy)) + " on a " +
                            toString(kind) + " mesh is solved in one linear step";
    for (const char* name : {"local_step", "acceleration", "iterations", "tolerance"})
      ignored(name, why);
  } else if (options.localStep == LocalStep::Reference) {
    ignored("acceleration", "it accelerates the exact local step only (local_step=reference)");
  }
}

namespace {

/// The terminal's word that a run ended unconverged (the report has it as `converged`), with
/// how far it is: the criterion, what the last iteration changed.
void warnNotConverged(const DeformationResult& result, const DeformationOptions& options) {
  if (std::isnan(result.criterion)) {
    warn("deform: not converged after " + std::to_string(result.iterations) +
         " iteration: the first global step, with nothing yet to measure convergence by "
         "(raise iterations)");
    return;
  }
  char gain[32];
  std::snprintf(gain, sizeof gain, "%.2g", result.criterion);
  const double tolerance = options.relTolerance;
  const std::string why =
      tolerance == 0.0 ? "tolerance=0 stops only where rounding is all that is left"
      : result.criterion <= tolerance
          // The last iteration gained little enough; the plain step that confirms it did not fit.
          ? "within tolerance=" + formatNumber(tolerance) +
                ", but the cap came before the plain iteration that confirms convergence"
          : "above tolerance=" + formatNumber(tolerance);
  warn("deform: not converged after " + std::to_string(result.iterations) +
       " iterations: the last one changed the energy by " + gain + " of it (" + why +
       "; raise iterations)");
}

}  // namespace

FilterResult DeformFilter::apply(Document& doc, const ParamMap& params) const {
  if (doc.handles.empty()) throw InvalidParameter(doc.missingHandles("deform"));
  Timer timer;
  EditEngine& engine = doc.engine();  // the discretization is built here unless cached
  const double discretization = timer.seconds();
  const DeformationOptions options = deformationOptionsOf(params);
  warnInapplicable(params, doc.mesh.kind());
  EditParams edit = editParamsOf(options);
  if (options.regularization == Regularization::Nonuniform)
    edit.givenWeights = doc.mesh.vertexScalar(prop::weight);

  timer.reset();
  engine.setEdit(doc.handles, std::move(edit));
  const double setup = timer.seconds();
  if (doc.progress)
    engine.setProgress([&doc](int iteration, double energy, double criterion) {
      doc.progress("deform", iteration, energy, criterion);
    });
  UpdateReport report;
  try {
    report = engine.updateOrThrow();
  } catch (...) {
    engine.setProgress(nullptr);
    throw;
  }
  engine.setProgress(nullptr);
  const DeformationResult& result = engine.lastRun();
  if (!result.converged) warnNotConverged(result, options);

  timer.reset();
  doc.mesh.setPositions(engine.positions());
  doc.mesh.setElementScalar(prop::distortion, engine.distortion());
  doc.mesh.setElementScalar(prop::smoothness, engine.smoothness());
  const double maps = timer.seconds() + report.metricsSeconds;
  doc.deformation = options;
  doc.deformation->weights.resize(0);  // the mesh keeps them as diffreg:weight
  doc.deformation->progress = nullptr;

  FilterResult out;
  out.stats = report.deformation;
  out.data = {{"energy", toString(options.energy)},
              {"regularization", toString(options.regularization)},
              {"initial_guess", result.initialGuess},
              {"local_step", toString(options.localStep)},
              {"acceleration", toString(options.acceleration)},
              {"iterations", result.iterations},
              {"accelerated_iterations", result.accelerated},
              {"converged", result.converged},
              {"criterion", result.criterion},
              {"discretization_seconds", discretization},
              {"setup_seconds", setup + report.deformationSeconds - result.seconds},
              {"iteration_seconds", result.seconds},
              {"maps_seconds", maps},
              {"energies", result.energies}};
  if (options.regularization == Regularization::Uniform) out.data["beta"] = options.beta;
  return out;
}

void registerDeformFilters(Registry& registry) {
  registry.add(std::make_unique<DeformFilter>());
  registry.add(std::make_unique<MeasureFilter>());
}

}  // namespace diffreg
