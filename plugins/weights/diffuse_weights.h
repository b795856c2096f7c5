// Filter diffuse_weights: shape-aware regularization weights by heat diffusion from the
// handles (paper §3.2-3.3), stored as the vertex property diffreg:weight.
#pragma once

#include <diffreg/engine/edit_engine.h>
#include <diffreg/pipeline/filter.h>
#include <diffreg/weights/diffusion.h>

namespace diffreg {

/// Parameters: t (float), t_unit (absolute|diagonal|mean_edge2), order
/// (first|second|implicit_euler), steps (int, implicit Euler). Needs handles; produces
/// prop::weight. Report data: t_absolute and the min, max and mean weight over referenced
/// vertices.
/// The diffusion parameters diffuse_weights's parameters say (t, t_unit, order, steps, solve).
DiffusionParams diffusionParamsOf(const ParamMap& params);

/// What engineWeights() did: the engine's report, and the min, max and mean of the weights
/// over the referenced vertices (the weight filters' report data).
struct WeightsRun {
  UpdateReport report;
  nlohmann::json summary;
};

/// The weights of `edit`'s scheme for the document's handles, computed by the document's edit
/// engine (weights only) and stored as diffreg:weight. \throw what the engine's update throws.
WeightsRun engineWeights(Document& doc, EditParams edit);

class DiffuseWeightsFilter : public Filter {
 public:
  std::string name() const override { return "diffuse_weights"; }
  std::string description() const override;
  std::vector<ParamSpec> params() const override;
  std::vector<std::string> produces(const ParamMap&) const override;
  bool needsHandles() const override { return true; }
  /// \throw InvalidMesh (degenerate element), InvalidParameter (handle ids out of range for
  ///        this mesh), SingularSystem (a solve failed).
  FilterResult apply(Document& doc, const ParamMap& params) const override;
};

}  // namespace diffreg
