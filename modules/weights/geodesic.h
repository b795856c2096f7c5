// Geodesic distances by the heat method (Crane, Weischedel and Wardetzky, "Geodesics in heat",
// ACM TOG 2013), used by the RBF baseline (docs/method.md, "The RBF baseline").
//
// Triangle meshes (planar and surface) use CGAL's implementation
// (CGAL::Heat_method_3::Surface_mesh_geodesic_distances_3, Direct mode) on the OpenMesh
// TriMesh through CGAL's graph traits, with a double-precision point map. Direct rather than
// Intrinsic_Delaunay: CGAL's intrinsic Delaunay variant copies the mesh into a second OpenMesh
// mesh through CGAL's OpenMesh point map, which stores coordinates as float; Direct reads every
// coordinate through our double map. The price is the usual one of the direct heat method:
// accuracy degrades on triangulations with many obtuse angles (negative cotangent weights).
//
// Tet meshes: CGAL's heat method exists for triangle surface meshes only, so diffreg runs the
// same three steps on its own Discretization (docs/method.md, "Discretization"):
//   1. (M + h K) u = delta_sources, h = (mean edge length)^2, M lumped, K the cotangent matrix;
//   2. X_e = -grad u_e / |grad u_e| per tet (X_e = 0 where the gradient vanishes);
//   3. K phi = b with b_i = sum_e a_e g_i . X_e (g_i the gradient of hat function i in e),
//      one vertex per connected component held at 0, then phi shifted so that its minimum
//      over the component's sources is 0 and negative values (numerical) clamped to 0.
// Both systems are factored once per mesh and reused for every source set.
//
// Every connected component is solved on its own; vertices of a component without a source
// and unreferenced vertices get +infinity.
#pragma once

#include <diffreg/mesh/mesh.h>

#include <Eigen/Core>
#include <memory>
#include <vector>

namespace diffreg {

/// Heat-method distances on one mesh, with the per-mesh work (factorizations) done once and
/// reused for every source set. Holds its own copy of what it needs; `mesh` may go away.
class GeodesicDistance {
 public:
  /// \pre mesh has no degenerate element.
  /// \throw InvalidMesh for a degenerate triangle or tet (naming it) or an empty mesh.
  explicit GeodesicDistance(const Mesh& mesh);
  ~GeodesicDistance();
  GeodesicDistance(GeodesicDistance&&) noexcept;
  GeodesicDistance& operator=(GeodesicDistance&&) noexcept;

  /// Distance from every vertex to the nearest of `sources` (vertex ids), size n, >= 0,
  /// 0 at the sources, +infinity where no source is reachable.
  /// \throw InvalidParameter for no source or a source id out of range.
  /// \throw SingularSystem if a solve fails.
  Eigen::VectorXd distances(const std::vector<int>& sources);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// One-shot: geodesic distances from `sources` (see GeodesicDistance::distances).
Eigen::VectorXd geodesicDistances(const Mesh& mesh, const std::vector<int>& sources);

}  // namespace diffreg
