#include "mesh/flip_edges.h"

#include <diffreg/core/error.h>
#include <diffreg/core/log.h>
#include <diffreg/mesh/remesh.h>
#include "plugins.h"

#include <climits>
#include <cmath>

namespace diffreg {

std::string FlipEdgesFilter::description() const {
  return "Flips a random fraction of the interior edges of a planar or surface mesh (seeded: "
         "the same seed gives the same mesh on every platform), for the triangulation-"
         "robustness test: weights and deformations should barely change. An edge is flipped "
         "only when both new triangles are well shaped and the mesh does not fold (planar: the "
         "orientation is kept; surfaces: only between faces within 30 degrees of each other, so "
         "the shape is kept); other edges are skipped, so fewer flips may happen than asked "
         "(the report says how many). The flips are decided on the rest shape; vertices, "
         "their ids, handles and vertex properties are kept; element properties are removed. "
         "Tet meshes are refused. Zhu, Li, Zhang, Song: Diffusion-based non-uniform "
         "regularization for variational shape deformation, Computer-Aided Design (2016), "
         "Fig. 8.";
}

std::vector<ParamSpec> FlipEdgesFilter::params() const {
  return {
      floatParam("fraction", "0.3", 0.0, 1.0, "Fraction of the interior edges to flip."),
      intParam("seed", "1", 0, INT_MAX, "Seed of the random choice of edges (std::mt19937)."),
  };
}

FilterResult FlipEdgesFilter::apply(Document& doc, const ParamMap& params) const {
  if (doc.mesh.isTet())
    throw InvalidParameter(
        "filter flip_edges: the mesh is a tet mesh; edge flips apply to planar and surface "
        "triangle meshes only");
  const double fraction = params.getFloat("fraction");
  int interior = 0;
  for (auto e : doc.mesh.tri().edges())
    if (!doc.mesh.tri().is_boundary(e)) ++interior;
  const int requested = static_cast<int>(std::lround(fraction * interior));

  // Flip on the rest shape (what every solver discretizes), then restore the current positions.
  const Eigen::MatrixXd current = doc.mesh.positions();
  doc.mesh.setPositions(doc.rest);
  const int flipped = flipEdges(doc.mesh, fraction, static_cast<unsigned>(params.getInt("seed")));
  doc.mesh.setPositions(current);
  if (flipped < requested)
    warn("flip_edges: " + std::to_string(flipped) + " of the " + std::to_string(requested) +
         " requested flips keep the triangles well shaped; the others were skipped");

  FilterResult result;
  result.data = {{"interior_edges", interior}, {"requested", requested}, {"flipped", flipped}};
  return result;
}

}  // namespace diffreg
