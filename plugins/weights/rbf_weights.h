// Filter rbf_weights: the RBF baseline for regularization weights (paper §3.2.2, Fig. 10;
// docs/method.md, "The RBF baseline"), a Gaussian per handle summed over the handles, stored as
// diffreg:weight.
#pragma once

#include <diffreg/pipeline/filter.h>

namespace diffreg {

/// Parameters: distance (euclidean|geodesic), sigma (float), sigma_unit (diagonal|absolute),
/// clamp (bool). Needs handles; produces prop::weight. Computed on the rest shape the pipeline
/// loaded. Report data: sigma_absolute (the kernel width in length units), max_magnitude
/// (largest m_j) and the min, max and mean weight over referenced vertices.
class RbfWeightsFilter : public Filter {
 public:
  std::string name() const override { return "rbf_weights"; }
  std::string description() const override;
  std::vector<ParamSpec> params() const override;
  std::vector<std::string> produces(const ParamMap&) const override;
  bool needsHandles() const override { return true; }
  /// \throw InvalidParameter (handle ids out of range, r_j <= 0, m_j < 0), InvalidMesh
  ///        (degenerate element, geodesic distance only), SingularSystem (a geodesic solve
  ///        failed).
  FilterResult apply(Document& doc, const ParamMap& params) const override;
};

}  // namespace diffreg
