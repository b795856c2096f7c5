// Reading, validating and writing meshes. Every failure is an IoError or InvalidMesh whose
// message names the file and the element or line; writing never leaves a partial file.
#pragma once

#include "mesh/mesh.h"

#include <string>
#include <vector>

namespace diffreg {

/// Reads OBJ, OFF, PLY, OM (through OpenMesh), Medit .mesh (Vertices + Tetrahedra; other
/// blocks ignored) or TetGen .node/.ele (either name given; the other is found beside it),
/// then validates it (see validateMesh). Polygonal faces are triangulated with a warning.
/// \throw IoError missing or unreadable file, unknown extension.
/// \throw InvalidMesh empty, non-finite coordinates, out-of-range indices, degenerate elements,
///        inverted tets (naming the element index and the file).
Mesh readMesh(const std::string& path);

/// Checks a mesh read from `path` (used in messages). Unreferenced vertices are kept, with a
/// warning; they stay in place and are left out of every system.
void validateMesh(const Mesh& mesh, const std::string& path);

struct WriteOptions {
  /// PLY: vertex property written as float "quality" (and colours), if present.
  std::string vertexQuality = prop::weight;
  /// PLY: element property written as face float "quality", if present.
  std::string faceQuality = prop::distortion;
  /// PLY: vertex colours from viridis over the vertex quality (0..1 unless normalised).
  bool colors = true;
};

/// Writes OBJ/OFF/PLY/OM for triangle meshes, Medit .mesh for tet meshes (and PLY for a tet
/// mesh's boundary surface). The file is written to a temporary name beside `path` and
/// renamed into place, so a failed write leaves any existing file untouched.
/// \throw IoError unknown or unsupported extension for the mesh kind, write failure.
void writeMesh(const std::string& path, const Mesh& mesh, const WriteOptions& options = {});

/// The extensions writeMesh accepts for a mesh kind ("obj", "off", "ply", "om" or "mesh", "ply").
std::vector<std::string> writableExtensions(MeshKind kind);
/// \throw IoError when writeMesh cannot write a mesh of `kind` under the extension of `path`.
void checkWritable(const std::string& path, MeshKind kind);

/// Lower-case extension of `path` without the dot ("obj", "mesh", ...), "" when none.
std::string extensionOf(const std::string& path);

}  // namespace diffreg
