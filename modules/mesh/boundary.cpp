#include <diffreg/mesh/boundary.h>

#include <algorithm>

namespace diffreg {

BoundaryFaces tetBoundary(const TetMesh& tet) {
  // Outward faces of a positively oriented tet (a, b, c, d), the one opposite vertex i first.
  static const int local[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  struct Face {
    std::array<int, 3> key;
    int tet, local;
  };
  std::vector<Face> faces;
  faces.reserve(tet.tets.size() * 4);
  for (int k = 0; k < static_cast<int>(tet.tets.size()); ++k) {
    for (int j = 0; j < 4; ++j) {
      std::array<int, 3> key{tet.tets[k][local[j][0]], tet.tets[k][local[j][1]],
                             tet.tets[k][local[j][2]]};
      std::sort(key.begin(), key.end());
      faces.push_back({key, k, j});
    }
  }
  std::sort(faces.begin(), faces.end(), [](const Face& a, const Face& b) { return a.key < b.key; });
  BoundaryFaces result;
  for (std::size_t i = 0; i < faces.size();) {
    std::size_t j = i + 1;
    while (j < faces.size() && faces[j].key == faces[i].key) ++j;
    if (j == i + 1) {
      const auto& t = tet.tets[faces[i].tet];
      const int* l = local[faces[i].local];
      result.faces.push_back({t[l[0]], t[l[1]], t[l[2]]});
      result.element.push_back(faces[i].tet);
    }
    i = j;
  }
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
