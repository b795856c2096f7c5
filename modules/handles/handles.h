// Handle sets: which vertices are constrained, where they go, and each handle's range r and
// magnitude m for the diffused weights. Read from the JSON handle file (README: "Handle files").
#pragma once

#include <diffreg/mesh/mesh.h>

#include <Eigen/Core>
#include <string>
#include <vector>

namespace diffreg {

/// The range r_j every front end accepts: past these the diffusion times r_j^2 t leave the
/// numbers a factorization can take (a range of 1e-310 made the weights' system singular).
constexpr double kMinHandleRange = 1e-6, kMaxHandleRange = 1e6;

struct Handle {
  std::string name;
  std::vector<int> vertices;  ///< mesh vertex ids (the file's numbering)
  Eigen::MatrixXd targets;    ///< |vertices| x 3 target positions (planar: z = rest z)
  double range = 1.0;         ///< r_j in [kMinHandleRange, kMaxHandleRange]
  double magnitude = 1.0;     ///< m_j in [0, 1]
};

struct HandleSet {
  std::vector<Handle> handles;

  bool empty() const { return handles.empty(); }
  /// All constrained vertex ids, handle by handle.
  std::vector<int> allVertices() const;
  /// Their targets in the same order, one row of 3 coordinates per vertex.
  /// \throw InvalidParameter naming a handle whose targets are not |vertices| x 3.
  Eigen::MatrixXd allTargets() const;
  /// Per-vertex handle index, -1 for free vertices (size n).
  std::vector<int> handleOfVertex(int numVertices) const;
};

/// One point of a MeshLab PickedPoints (.pp) file.
struct PickedPoint {
  std::string name;          ///< the point's name ("" when the file gives none)
  Eigen::Vector3d position;  ///< x, y, z
  bool active = true;        ///< MeshLab's check box: only active points select vertices
  int line = 0;              ///< line of the <point> element in the file
};

/// Parses a MeshLab PickedPoints file: <PickedPoints> with <point x= y= z= active= name=/>
/// elements (active "1"/"0" or "true"/"false", default active; <DocumentData> and other
/// elements are ignored). `source` names the text in messages.
/// \throw InvalidParameter "source:line: ..." for malformed XML, another root element, or a
///        point whose x, y or z is missing or not a finite number, or whose active flag is not
///        one of 1, 0, true, false.
std::vector<PickedPoint> parsePickedPoints(const std::string& xmlText, const std::string& source);

/// Reads a PickedPoints file (see parsePickedPoints).
/// \throw IoError missing or unreadable file; InvalidParameter as parsePickedPoints.
std::vector<PickedPoint> readPickedPoints(const std::string& path);

/// Parses a handle file against `mesh` (rest positions): resolves "vertices", "nearest",
/// "within" and "picked" (MeshLab .pp) selections, top-level "handles_from_picked" entries
/// (one handle per picked point) and "translate", "rotate" and "targets" motions to absolute
/// targets. Relative .pp paths are resolved against the handle file's directory.
/// \throw IoError unreadable handle or .pp file. \throw InvalidParameter malformed JSON or
///        .pp, unknown keys, vertex ids out of range, empty handle, a vertex in two handles,
///        range outside [1e-6, 1e6], magnitude outside [0, 1], a target that is not finite or
///        more than 1000 mesh diagonals away, a .pp without active points, a picked name not
///        found (each naming the file, the handle and the field). Files are read through
///        readFileLimited (16 MiB, regular files only).
HandleSet readHandles(const std::string& path, const Mesh& mesh);

/// Same, from JSON text; `source` names it in messages and relative .pp paths are resolved
/// against `baseDir` ("" = the working directory). With `revealFiles` false (text from a
/// network client), any problem with a .pp file it names is one IoError that says neither
/// whether the file exists nor what it holds.
HandleSet parseHandles(const std::string& jsonText, const Mesh& mesh, const std::string& source,
                       const std::string& baseDir = "", bool revealFiles = true);

/// Writes the resolved handles as JSON ("vertices" + "targets") that readHandles accepts.
std::string handlesToJson(const HandleSet& handles);

}  // namespace diffreg
