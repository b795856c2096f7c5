// Filter subdivide: uniform 1-to-4 subdivision (midpoint or Loop) of a planar or surface
// mesh, for the paper's resolution experiment (Fig. 9).
#pragma once

#include <diffreg/pipeline/filter.h>

#include <cstdint>

namespace diffreg {

/// The most triangles subdivide makes (2^24, about 1.5 GB of mesh): more is refused before work.
inline constexpr std::int64_t kMaxSubdividedTriangles = std::int64_t(1) << 24;

/// Parameters: iterations, scheme (midpoint|loop), handles (grow|keep). The old vertices keep
/// their ids 0..n-1 (mesh/remesh.h subdivide), so handles stay valid; the rest positions are
/// subdivided alike (and the current positions, when an earlier step moved the mesh). Each
/// handle vertex keeps its displacement (target - rest); with handles=grow a new vertex that
/// splits an edge between two vertices of one handle joins that handle, its displacement the
/// mean of theirs (for midpoint subdivision: the target is the midpoint of the two targets,
/// exact for translations and rotations). Vertex properties are interpolated, element
/// properties removed. Report data: vertices, elements, handle_vertices, added_handle_vertices.
class SubdivideFilter : public Filter {
 public:
  std::string name() const override { return "subdivide"; }
  std::string description() const override;
  std::vector<ParamSpec> params() const override;
  /// \throw InvalidParameter for a tet mesh.
  bool dropsElementProperties() const override { return true; }
  FilterResult apply(Document& doc, const ParamMap& params) const override;
};

}  // namespace diffreg
