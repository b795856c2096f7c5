// Filter flip_edges: random, seeded edge flips of a planar or surface mesh, for the paper's
// triangulation-robustness experiment (Fig. 8).
#pragma once

#include <diffreg/pipeline/filter.h>

namespace diffreg {

/// Parameters: fraction (of the interior edges, [0, 1]), seed. Flips edges of the rest shape
/// (mesh/remesh.h flipEdges: no fold, no degenerate triangle, the surface kept); vertices, their
/// ids, the rest positions, the current positions, the handles and the vertex properties stay;
/// element properties (distortion, smoothness) are removed, since their elements are gone.
/// Report data: interior_edges, requested, flipped.
class FlipEdgesFilter : public Filter {
 public:
  std::string name() const override { return "flip_edges"; }
  std::string description() const override;
  std::vector<ParamSpec> params() const override;
  /// \throw InvalidParameter for a tet mesh.
  bool dropsElementProperties() const override { return true; }
  FilterResult apply(Document& doc, const ParamMap& params) const override;
};

}  // namespace diffreg
