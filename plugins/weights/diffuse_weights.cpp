#include "weights/diffuse_weights.h"

#include <diffreg/discretization/discretization.h>
#include <diffreg/engine/edit_engine.h>
#include "plugins.h"
#include <diffreg/weights/diffusion.h>
#include "weights/rbf_weights.h"

#include <algorithm>
#include <limits>

namespace diffreg {

std::string DiffuseWeightsFilter::description() const {
  return "Shape-aware regularization weights: heat diffuses from the handles (Dirichlet value "
         "m_j at each handle, per-handle range r_j) for a time t, solved in one step with the "
         "first-order scheme (eq. 7), the Dirichlet-consistent second-order scheme (eq. 8) or "
         "n implicit Euler steps (eq. 6, the reference). The weights are stored as the vertex "
         "property diffreg:weight. Zhu, Li, Zhang, Song: Diffusion-based non-uniform "
         "regularization for variational shape deformation, Computer-Aided Design (2016), "
         "Sec. 3.2-3.3.";
}

std::vector<ParamSpec> DiffuseWeightsFilter::params() const {
  // Defaults, choices and limits come from DiffusionParams and weights/diffusion.h.
  const DiffusionParams defaults;
  return {
      floatParam("t", formatNumber(defaults.t), kMinDiffusionTime, kMaxDiffusionTime,
                 "Diffusion time, in the unit t_unit; larger t spreads the weights further."),
      enumParam("t_unit", defaults.unit,
                "Unit of t: absolute (length^2), diagonal (squared bounding-box diagonal; "
                "independent of scale and nearly of resolution) or mean_edge2 (squared mean edge "
                "length, the paper's)."),
      enumParam("order", defaults.order,
                "Time discretization: first (eq. 7), second (eq. 8, Dirichlet-consistent) or "
                "implicit_euler (eq. 6 with `steps` steps, the reference)."),
      intParam("steps", std::to_string(defaults.steps), 1, kMaxDiffusionSteps,
               "Number of implicit Euler steps (order=implicit_euler only)."),
      enumParam("solve", defaults.solve,
                "How the second-order system is solved (order=second only): pcg (conjugate "
                "gradients preconditioned by one factorization with the mesh's 1-ring pattern) "
                "or direct (Cholesky of the second-order matrix, whose 2-ring pattern is several "
                "times slower to factor; for comparison)."),
  };
}

std::vector<std::string> DiffuseWeightsFilter::produces(const ParamMap&) const {
  return {prop::weight};
}

DiffusionParams diffusionParamsOf(const ParamMap& params) {
  DiffusionParams p;
  p.t = params.getFloat("t");
  p.unit = parseEnum<TimeUnit>(params.getString("t_unit"));
  p.order = parseEnum<DiffusionOrder>(params.getString("order"));
  p.steps = params.getInt("steps");
  p.solve = parseEnum<DiffusionSolve>(params.getString("solve"));
  return p;
}

FilterResult DiffuseWeightsFilter::apply(Document& doc, const ParamMap& params) const {
  EditParams edit;
  edit.scheme = WeightScheme::Diffusion;
  edit.diffusion = diffusionParamsOf(params);
  WeightsRun run = engineWeights(doc, std::move(edit));
  const UpdateReport& report = run.report;

  FilterResult result;
  result.stats = report.weights;
  result.data = std::move(run.summary);
  result.data["t_absolute"] = report.absoluteTime;
  result.data["cg_iterations"] = report.diffusionSolve.cgIterations;
  result.data["cg_residual"] = report.diffusionSolve.cgResidual;
  return result;
}

namespace {

// min, max and mean of per-vertex weights over the vertices marked `used`.
nlohmann::json weightSummary(const Eigen::VectorXd& weights, const std::vector<bool>& used) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo, sum = 0.0;
  int count = 0;
  for (int i = 0; i < weights.size(); ++i) {
    if (!used[static_cast<size_t>(i)]) continue;
    lo = std::min(lo, weights[i]);
    hi = std::max(hi, weights[i]);
    sum += weights[i];
    ++count;
  }
  return {{"min", count ? lo : 0.0}, {"max", count ? hi : 0.0}, {"mean", count ? sum / count : 0.0}};
}

}  // namespace

WeightsRun engineWeights(Document& doc, EditParams edit) {
  edit.deform = false;
  edit.reference = false;
  EditEngine& engine = doc.engine();
  engine.setEdit(doc.handles, std::move(edit));
  WeightsRun run{engine.updateOrThrow(), {}};
  doc.mesh.setVertexScalar(prop::weight, engine.weights());
  // The engine's own discretization: asking the document again would check its cache anew.
  run.summary = weightSummary(engine.weights(), engine.sharedDiscretization()->active());
  return run;
}

void registerWeightsFilters(Registry& registry) {
  registry.add(std::make_unique<DiffuseWeightsFilter>());
  registry.add(std::make_unique<RbfWeightsFilter>());
}

}  // namespace diffreg
