#include <diffreg/mesh/boundary.h>

#include <diffreg/core/error.h>
#include <diffreg/mesh/tet_facets.h>

#include <algorithm>
#include <string>

namespace diffreg {

BoundaryFaces tetBoundary(const TetMesh& tet) {
  const int tets = static_cast<int>(tet.tets.size());
  const int vertices = static_cast<int>(tet.points.size());
  for (int k = 0; k < tets; ++k)
    for (int v : tet.tets[static_cast<size_t>(k)])
      if (v < 0 || v >= vertices)
        throw InvalidMesh("tet boundary: tet " + std::to_string(k) + " has vertex id " +
                          std::to_string(v) + " outside [0, " + std::to_string(vertices) + ")");
  BoundaryFaces result;
  forEachFacet(
      sortedTetFacets(tets, vertices,
                      [&tet](int k, int j) { return tet.tets[static_cast<size_t>(k)][j]; }),
      [&](const std::array<int, 3>&, const TetFacet* first, int count) {
        if (count != 1) return;  // a facet of one tet only
        const auto& t = tet.tets[static_cast<size_t>(first->tet)];
        const int* l = kOutwardFacet[first->opposite];
        result.faces.push_back({t[l[0]], t[l[1]], t[l[2]]});
        result.element.push_back(first->tet);
      });
  return result;
}

BoundarySurface boundarySurface(const TetMesh& tet) {
  BoundaryFaces boundary = tetBoundary(tet);
  BoundarySurface s;
  std::vector<int> map(tet.points.size(), -1);
  for (const auto& f : boundary.faces)
    for (int v : f) map[v] = 0;
  for (size_t v = 0; v < map.size(); ++v) {
    if (map[v] == 0) {
      map[v] = static_cast<int>(s.vertexIds.size());
      s.vertexIds.push_back(static_cast<int>(v));
    }
  }
  s.points.resize(static_cast<Eigen::Index>(s.vertexIds.size()), 3);
  for (size_t i = 0; i < s.vertexIds.size(); ++i)
    s.points.row(static_cast<Eigen::Index>(i)) = tet.points[s.vertexIds[i]].transpose();
  s.faces.resize(static_cast<Eigen::Index>(boundary.faces.size()), 3);
  for (size_t k = 0; k < boundary.faces.size(); ++k)
    for (int j = 0; j < 3; ++j)
      s.faces(static_cast<Eigen::Index>(k), j) = map[boundary.faces[k][j]];
  s.element = std::move(boundary.element);
  return s;
}

}  // namespace diffreg
