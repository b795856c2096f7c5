#include "mesh/subdivide.h"

#include <diffreg/core/error.h>
#include <diffreg/mesh/remesh.h>
#include "mesh/flip_edges.h"
#include "plugins.h"

#include <vector>

namespace diffreg {
namespace {

/// After one subdivision step of doc.mesh (old vertices 0..oldCount-1, rest positions oldRest ->
/// newRest): moves each handle's targets with its vertices (same displacement) and, with
/// `grow`, adds every new vertex that splits an edge inside one handle to that handle.
/// \return the number of vertices added to handles.
int updateHandles(Document& doc, int oldCount, const Eigen::MatrixXd& oldRest,
                  const Eigen::MatrixXd& newRest, bool grow) {
  const std::vector<int> owner = doc.handles.handleOfVertex(oldCount);
  // Displacement of every old handle vertex.
  Eigen::MatrixXd displacement = Eigen::MatrixXd::Zero(oldCount, 3);
  for (const Handle& h : doc.handles.handles)
    for (std::size_t i = 0; i < h.vertices.size(); ++i)
      displacement.row(h.vertices[i]) = h.targets.row(i) - oldRest.row(h.vertices[i]);

  std::vector<std::vector<int>> added(doc.handles.handles.size());
  if (grow) {
    const TriMesh& tri = doc.mesh.tri();
    for (int v = oldCount; v < static_cast<int>(tri.n_vertices()); ++v) {
      // A new vertex is adjacent to exactly the two old vertices of the edge it split.
      int ends[2], count = 0;
      for (auto w : tri.vv_range(tri.vertex_handle(v)))
        if (w.idx() < oldCount && count < 2) ends[count++] = w.idx();
      if (count == 2 && owner[ends[0]] >= 0 && owner[ends[0]] == owner[ends[1]])
        added[owner[ends[0]]].push_back(v);
    }
  }

  int total = 0;
  for (std::size_t j = 0; j < doc.handles.handles.size(); ++j) {
    Handle& h = doc.handles.handles[j];
    const int oldSize = static_cast<int>(h.vertices.size());
    Eigen::MatrixXd targets(oldSize + static_cast<int>(added[j].size()), 3);
    for (int i = 0; i < oldSize; ++i) {
      const int v = h.vertices[i];
      targets.row(i) = newRest.row(v) == oldRest.row(v) ? Eigen::RowVector3d(h.targets.row(i))
                                                        : newRest.row(v) + displacement.row(v);
    }
    const TriMesh& tri = doc.mesh.tri();
    for (std::size_t k = 0; k < added[j].size(); ++k) {
      const int v = added[j][k];
      Eigen::RowVector3d d = Eigen::RowVector3d::Zero();
      for (auto w : tri.vv_range(tri.vertex_handle(v)))
        if (w.idx() < oldCount) d += 0.5 * displacement.row(w.idx());
      targets.row(oldSize + static_cast<int>(k)) = newRest.row(v) + d;
      h.vertices.push_back(v);
    }
    h.targets = targets;
    total += static_cast<int>(added[j].size());
  }
  return total;
}

}  // namespace

std::string SubdivideFilter::description() const {
  return "Uniform 1-to-4 subdivision of a planar or surface mesh with OpenMesh's Loop "
         "subdivider, for the resolution study: midpoint splits every edge at its midpoint and "
         "keeps the shape; loop is Loop subdivision (the surface is smoothed, old vertices "
         "move). The old vertices keep their ids, so handles stay valid; rest and current "
         "positions are subdivided alike; each handle vertex keeps its displacement, and with "
         "handles=grow a new vertex on an edge between two vertices of one handle joins it "
         "(a handle region keeps its extent, a one-vertex handle stays one vertex). Vertex "
         "properties are interpolated, element properties removed. Tet meshes are refused. "
         "Zhu, Li, Zhang, Song: Diffusion-based non-uniform regularization for variational "
         "shape deformation, Computer-Aided Design (2016), Fig. 9.";
}

std::vector<ParamSpec> SubdivideFilter::params() const {
  return {
      intParam("iterations", "1", 0, 8,
               "Number of 1-to-4 steps (each multiplies the triangle count by 4; the result "
               "may have at most 16,777,216 triangles)."),
      enumParam("scheme", "midpoint", {"midpoint", "loop"},
                "midpoint (new vertices at edge midpoints, the shape unchanged) or loop (Loop "
                "subdivision, smoothing; a planar boundary shrinks)."),
      enumParam("handles", "grow", {"grow", "keep"},
                "grow: a new vertex splitting an edge between two vertices of one handle joins "
                "that handle (its region keeps its extent); keep: handles keep exactly their "
                "vertices."),
  };
}

FilterResult SubdivideFilter::apply(Document& doc, const ParamMap& params) const {
  if (doc.mesh.isTet())
    throw InvalidParameter(
        "filter subdivide: the mesh is a tet mesh; subdivision applies to planar and surface "
        "triangle meshes only");
  const int iterations = params.getInt("iterations");
  // Refused before any work: 8 steps make a 512-triangle mesh 33.5M triangles (several GB).
  const std::int64_t triangles = std::int64_t(doc.mesh.numElements()) << (2 * iterations);
  if (iterations > 0 && triangles > kMaxSubdividedTriangles)
    throw InvalidParameter(
        "filter subdivide: parameter 'iterations' = " + std::to_string(iterations) +
        " would make " + std::to_string(triangles) + " triangles of the mesh's " +
        std::to_string(doc.mesh.numElements()) + ", more than the " +
        std::to_string(kMaxSubdividedTriangles) + " allowed");
  const std::string scheme = params.getString("scheme");
  const bool grow = params.getString("handles") == "grow";

  // The mesh is subdivided at its rest positions (so its kind and the new rest positions come
  // from the rest shape); when an earlier step moved it, a copy at the current positions is
  // subdivided alike (the same connectivity) for the new current positions.
  Eigen::MatrixXd current = doc.mesh.positions();
  const bool moved = current != doc.rest;
  int added = 0;
  for (int it = 0; it < iterations; ++it) {
    const int oldCount = doc.mesh.numVertices();
    Mesh shadow;
    if (moved) {
      shadow = Mesh(TriMesh(doc.mesh.tri()));
      shadow.setPositions(current);
    }
    doc.mesh.setPositions(doc.rest);
    subdivide(doc.mesh, 1, scheme);
    const Eigen::MatrixXd newRest = doc.mesh.positions();
    if (moved) {
      subdivide(shadow, 1, scheme);
      if (shadow.elements() != doc.mesh.elements())
        throw std::logic_error("subdivide: rest and current meshes diverged");
      current = shadow.positions();
    }
    added += updateHandles(doc, oldCount, doc.rest, newRest, grow);
    doc.rest = newRest;
  }
  doc.mesh.setPositions(moved ? current : doc.rest);

  int handleVertices = 0;
  for (const Handle& h : doc.handles.handles) handleVertices += static_cast<int>(h.vertices.size());
  FilterResult result;
  result.data = {{"vertices", doc.mesh.numVertices()},
                 {"elements", doc.mesh.numElements()},
                 {"handle_vertices", handleVertices},
                 {"added_handle_vertices", added}};
  return result;
}

void registerMeshFilters(Registry& registry) {
  registry.add(std::make_unique<FlipEdgesFilter>());
  registry.add(std::make_unique<SubdivideFilter>());
}

}  // namespace diffreg
