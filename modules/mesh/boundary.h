// The boundary surface of a tet mesh, as the PLY writer, the renderer and the browser editor
// need it.
#pragma once

#include <diffreg/mesh/mesh.h>

#include <Eigen/Core>

#include <array>
#include <vector>

namespace diffreg {

/// Boundary triangles of a tet mesh (the tet faces not shared with another tet), oriented
/// outwards, over the tet mesh's vertex ids, with the index of the tet each belongs to.
struct BoundaryFaces {
  std::vector<std::array<int, 3>> faces;
  std::vector<int> element;
};

/// The faces in the order of their sorted vertex ids. Tets are expected positively oriented.
/// \throw InvalidMesh for a vertex id outside the points (a reader's mesh has none).
BoundaryFaces tetBoundary(const TetMesh& tet);

/// The boundary as a triangle mesh of its own: only the vertices the faces use, kept in
/// increasing id order.
struct BoundarySurface {
  Eigen::MatrixXd points;      ///< one row per boundary vertex
  Eigen::MatrixXi faces;       ///< into `points`
  std::vector<int> vertexIds;  ///< tet mesh id of each boundary vertex
  std::vector<int> element;    ///< tet of each face
};
BoundarySurface boundarySurface(const TetMesh& tet);

}  // namespace diffreg
