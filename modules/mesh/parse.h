// Parsers of the mesh file formats, from the file's bytes: OBJ, OFF (ASCII and binary), PLY
// (ASCII and binary), Medit .mesh and TetGen .node/.ele. Coordinates are read in double
// precision; counts are checked against the bytes left before anything is allocated, and
// arrays grow only as elements are read. A leading UTF-8 byte order mark is skipped. Every
// error is an InvalidMesh "source:line: ..." (or "source: ..." for binary data, naming the
// element).
#pragma once

#include <diffreg/mesh/mesh.h>

#include <string>
#include <string_view>
#include <vector>

namespace diffreg {

/// Silences OpenMesh's own console output (omerr, omlog, omout) while alive: every problem
/// it would print is detected and reported by diffreg instead.
class OpenMeshQuiet {
 public:
  OpenMeshQuiet();
  ~OpenMeshQuiet();
  OpenMeshQuiet(const OpenMeshQuiet&) = delete;
  OpenMeshQuiet& operator=(const OpenMeshQuiet&) = delete;

 private:
  bool was_[3] = {true, true, true};
};

/// A face as written in the file: 0-based vertex ids and its line (0 when unknown).
struct RawFace {
  int line = 0;
  std::vector<long long> ids;
};

/// A polygon mesh as read: points and faces, before any check of the faces.
struct RawMesh {
  std::vector<Eigen::Vector3d> points;
  std::vector<RawFace> faces;
  int base = 0;  ///< the file's first vertex and face number in messages (OBJ: 1)
  /// Named values the file carries, one per vertex (face) of the file: a PLY written by
  /// diffreg (its header names what the properties hold), an .om file's double properties.
  struct Values {
    std::string name;  ///< the mesh property they are ("diffreg:weight")
    std::vector<double> values;
  };
  std::vector<Values> vertexValues, faceValues;
};

/// The most named properties of vertices, and of faces, a file gives a mesh (PLY namings, .om
/// double properties); the others are left out with a warning. Each becomes a property of the
/// mesh, whose look-ups by name are linear.
inline constexpr int kMaxNamedProperties = 256;

/// Whether a PLY property of that name means something else to PLY readers (coordinates,
/// normals, colours, texture coordinates, indices, MeshLab's quality, radius and flags), so
/// that diffreg neither writes a named property under it nor reads one from it.
bool plyReservedName(bool vertex, const std::string& name);

/// OBJ's v and f lines. The other OBJ statements (vt, vn, g, usemtl, free-form geometry, ...)
/// are read past; lines that start with no OBJ statement are ignored with a warning that
/// counts them and names the first.
RawMesh parseObj(std::string_view text, const std::string& source);
namespace detail {
/// parseObj's general reading, line by line through a list of tokens. parseObj reads most
/// files in one pass and falls back to this for the first line that pass cannot take (every
/// error, for its message, and every line with no OBJ statement, for the warning); tests
/// compare the two.
RawMesh parseObjByTokens(std::string_view text, const std::string& source);
}  // namespace detail
RawMesh parseOff(std::string_view text, const std::string& source);
/// PLY (ASCII or binary). A vertex or face property is kept (RawMesh::Values) only where the
/// header names the mesh property it holds, as diffreg's writer does: "comment diffreg vertex
/// quality NAME" for the quality, "comment diffreg vertex property NAME" for the property
/// called NAME (faces alike).
RawMesh parsePly(std::string_view text, const std::string& source);
TetMesh parseMedit(std::string_view text, const std::string& source);
TetMesh parseTetgen(std::string_view node, const std::string& nodeSource, std::string_view ele,
                    const std::string& eleSource);

/// The triangle mesh of `raw`: faces checked (at least 3 distinct vertices in range), polygons
/// triangulated in their plane (non-planar or self-intersecting ones refused), faces that would
/// make the mesh non-manifold split off with their own vertex copies (after the file's; more
/// than 1000 of them and more than 10% of the faces is an error). Warns about polygons and
/// split faces. Triangles that make an oriented manifold (most files) are built in one pass
/// (halfedges.h), to the same mesh.
/// \throw InvalidMesh naming `source`, the line and the face.
std::unique_ptr<TriMesh> buildTriMesh(const RawMesh& raw, const std::string& source);

/// Where the vertices and faces of a mesh built by buildTriMesh come from in the file.
struct BuildOrigin {
  /// The file's vertex each appended copy repeats: vertex `numFileVertices + i` of the mesh is
  /// a copy of `copied[i]` (faces split off as non-manifold).
  std::vector<int> copied;
  /// The file's face of each face of the mesh; empty when they are the file's, one to one
  /// (no polygon was triangulated).
  std::vector<int> faceOf;
};
/// buildTriMesh, also telling where each vertex and face of the mesh comes from.
std::unique_ptr<TriMesh> buildTriMesh(const RawMesh& raw, const std::string& source,
                                      BuildOrigin& origin);

/// The mesh of `raw` (buildTriMesh) with the file's named values (RawMesh::Values) as its
/// vertex and element scalars: a vertex copy takes the value of the vertex it copies, each
/// triangle of a polygon the polygon's. The values are released from `raw` as they are taken.
Mesh buildMesh(RawMesh raw, const std::string& source);

}  // namespace diffreg
