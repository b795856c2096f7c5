// Reading, validating and writing meshes. Every failure is an IoError or InvalidMesh whose
// message names the file and the element or line; writing never leaves a partial file.
#pragma once

#include <diffreg/mesh/mesh.h>

#include <string>
#include <vector>

namespace diffreg {

/// Reads OBJ, OFF, PLY (ASCII or binary), OM (through OpenMesh), Medit .mesh (Vertices +
/// Tetrahedra; other blocks ignored) or TetGen .node/.ele (either name given; the other is
/// found beside it) in double precision (mesh/parse.h), then validates it (see validateMesh).
/// Polygonal faces are ear-clipped in their plane, with a warning. Files are read through
/// readFileLimited (regular files of at most limits::meshBytes). A PLY whose header names
/// what its vertex or face properties hold (writeMesh) gives those properties back, as .om
/// gives its double properties: through polygons and split faces (buildMesh).
/// \throw IoError missing, unreadable, special or oversized file, unknown extension.
/// \throw InvalidMesh malformed content, counts the file cannot hold, values beyond double,
///        empty, out-of-range indices, bad polygons, degenerate elements, inverted tets, a
///        triangle shared by more than two tets or by two on the same side (a repeated tet)
///        (naming the file and the line or element).
Mesh readMesh(const std::string& path);

/// Checks a mesh read from `path` (used in messages). Unreferenced vertices are kept, with a
/// warning; they stay in place and are left out of every system.
void validateMesh(const Mesh& mesh, const std::string& path);

struct WriteOptions {
  /// PLY: vertex property written as double "quality" (and colours), if present.
  std::string vertexQuality = prop::weight;
  /// PLY: element property written as face double "quality", if present.
  std::string faceQuality = prop::distortion;
  /// PLY: vertex colours from viridis over the vertex quality (0..1 unless normalised).
  bool colors = true;
};

/// Writes OBJ/OFF/PLY/OM for triangle meshes, Medit .mesh for tet meshes (and PLY for a tet
/// mesh's boundary surface), coordinates and qualities as doubles (text: the shortest form
/// that reads back exactly). The file is written to a temporary name beside `path` and
/// renamed into place, so a failed write leaves any existing file untouched. A PLY names the
/// properties its qualities hold in header comments ("comment diffreg vertex quality
/// diffreg:weight") and writes every other named property as a PLY property of that name
/// ("comment diffreg face property diffreg:smoothness"; names that are not one word of
/// printable ASCII, or PLY's own such as "x", are left out with a warning), which readMesh
/// reads back as those properties; a tet mesh's boundary names its vertex values only (its
/// faces carry their tets' values).
/// \throw IoError unknown or unsupported extension for the mesh kind, write failure.
/// \throw InvalidMesh non-finite coordinates or written property values (nothing is written).
void writeMesh(const std::string& path, const Mesh& mesh, const WriteOptions& options = {});

/// The extensions writeMesh accepts for a mesh kind ("obj", "off", "ply", "om" or "mesh", "ply").
std::vector<std::string> writableExtensions(MeshKind kind);
/// \throw IoError when writeMesh cannot write a mesh of `kind` under the extension of `path`.
void checkWritable(const std::string& path, MeshKind kind);

/// Lower-case extension of `path` without the dot ("obj", "mesh", ...), "" when none.
std::string extensionOf(const std::string& path);

}  // namespace diffreg
