// Handle sets: which vertices are constrained, where they go, and each handle's range r and
// magnitude m for the diffused weights. Read from the JSON handle file (README: "Handle files").
#pragma once

#include "mesh/mesh.h"

#include <Eigen/Core>
#include <string>
#include <vector>

namespace diffreg {

struct Handle {
  std::string name;
  std::vector<int> vertices;  ///< mesh vertex ids (the file's numbering)
  Eigen::MatrixXd targets;    ///< |vertices| x 3 target positions (planar: z = rest z)
  double range = 1.0;         ///< r_j > 0
  double magnitude = 1.0;     ///< m_j >= 0
};

struct HandleSet {
  std::vector<Handle> handles;

  bool empty() const { return handles.empty(); }
  /// All constrained vertex ids, handle by handle.
  std::vector<int> allVertices() const;
  /// Per-vertex handle index, -1 for free vertices (size n).
  std::vector<int> handleOfVertex(int numVertices) const;
};

/// Parses a handle file against `mesh` (rest positions): resolves "vertices", "nearest" and
/// "within" selections and "translate", "rotate" and "targets" motions to absolute targets.
/// \throw IoError unreadable file. \throw InvalidParameter malformed JSON, unknown keys,
///        vertex ids out of range, empty handle, a vertex in two handles, range <= 0,
///        magnitude < 0 (each naming the file and the handle).
HandleSet readHandles(const std::string& path, const Mesh& mesh);

/// Same, from JSON text; `source` names it in messages.
HandleSet parseHandles(const std::string& jsonText, const Mesh& mesh, const std::string& source);

/// Writes the resolved handles as JSON ("vertices" + "targets") that readHandles accepts.
std::string handlesToJson(const HandleSet& handles);

}  // namespace diffreg
