#include "weights/rbf_weights.h"

#include <diffreg/engine/edit_engine.h>
#include <diffreg/weights/rbf.h>

#include "weights/diffuse_weights.h"

#include <algorithm>
#include <limits>

namespace diffreg {

std::string RbfWeightsFilter::description() const {
  return "The RBF baseline for regularization weights: x(v) = sum_j m_j exp(-(d(v, j) / (r_j "
         "sigma))^2), a Gaussian per handle with its range r_j and magnitude m_j, summed over "
         "the handles, on the rest shape, stored as the vertex property "
         "diffreg:weight. d is the Euclidean distance or the geodesic distance to the handle's "
         "nearest vertex by the heat method (Crane et al. 2013): CGAL's Heat_method_3 on planar "
         "and surface meshes; on tet meshes, where CGAL's heat method does not apply (it works "
         "on triangle surfaces only), the same three heat-method steps on the tetrahedral "
         "discretization, i.e. the distance through the solid, the same domain diffuse_weights "
         "diffuses through (the distance over the boundary surface would overestimate it "
         "across the solid). Unlike diffused weights, the sum can exceed max m_j between "
         "nearby handles (no maximum principle), which is the paper's argument against it; "
         "deform's non-uniform regularization needs weights in [0, 1], so set clamp=true "
         "when the sum exceeds 1. Zhu, Li, Zhang, Song: Diffusion-based non-uniform "
         "regularization for variational shape deformation, Computer-Aided Design (2016), "
         "Sec. 3.2.2 and Fig. 10.";
}

std::vector<ParamSpec> RbfWeightsFilter::params() const {
  return {
      enumParam("distance", RbfDistance::Geodesic,
                "Distance to a handle: euclidean (straight line, jumps across gaps) or geodesic "
                "(heat method: CGAL on triangle meshes, through the volume on tet meshes)."),
      floatParam("sigma", "0.1", kMinRbfSigma, kMaxRbfSigma,
                 "Gaussian width, in the unit sigma_unit; a handle's range r_j multiplies it. A "
                 "weight falls to 1/e of m_j at distance r_j sigma."),
      enumParam("sigma_unit", "diagonal", {"diagonal", "absolute"},
                "Unit of sigma: diagonal (the rest shape's bounding-box diagonal; independent of "
                "scale and resolution) or absolute (length)."),
      boolParam("clamp", false,
                "Clamp the summed weights to [0, 1] (off: the plain sum, which may exceed 1)."),
  };
}

std::vector<std::string> RbfWeightsFilter::produces(const ParamMap&) const {
  return {prop::weight};
}

FilterResult RbfWeightsFilter::apply(Document& doc, const ParamMap& params) const {
  EditParams edit;
  edit.scheme = WeightScheme::Rbf;
  edit.rbf.distance = parseEnum<RbfDistance>(params.getString("distance"));
  edit.rbf.sigma = params.getFloat("sigma");
  edit.rbf.sigmaAbsolute = params.getString("sigma_unit") == "absolute";
  edit.rbf.clamp = params.getBool("clamp");
  WeightsRun run = engineWeights(doc, std::move(edit));
  const UpdateReport& report = run.report;

  double magnitude = 0.0;
  for (const Handle& h : doc.handles.handles) magnitude = std::max(magnitude, h.magnitude);
  FilterResult result;
  result.data = std::move(run.summary);
  result.data["sigma_absolute"] = report.absoluteSigma;
  result.data["max_magnitude"] = magnitude;
  return result;
}

}  // namespace diffreg
