// A triangle mesh's half-edge structure in one pass over its triangles, for the common case of an
// oriented 2-manifold (with or without boundary): the OpenMesh mesh that adding the triangles one
// by one with add_face would build, handle for handle, in a fraction of its time.
#pragma once

#include <diffreg/mesh/mesh.h>

#include <array>
#include <cstddef>
#include <memory>
#include <vector>

namespace diffreg {

/// The TriMesh of `points` and `triangles` (vertex indices, checked in range and distinct by the
/// caller) when the triangles form an oriented 2-manifold: no directed edge twice (so at most two
/// triangles on an edge, in opposite directions) and the triangles around every vertex one fan
/// (a closed disc or one open wedge). The result equals what TriMesh::add_vertex for every point
/// and add_face for every triangle in order build: the same edges in the same order and
/// direction, and the same next, previous, face and outgoing half-edge of every element (the test
/// compares them all). Returns null for anything else (the caller then adds the faces one by
/// one, and OpenMesh decides what to do with the non-manifold ones).
///
/// Why it can: for such a mesh the incremental construction leaves nothing to its history.
/// Edges appear in the order their first triangle names them, directed along it; a face keeps
/// the half-edge of its last corner; a boundary half-edge continues with the one boundary
/// half-edge leaving its end vertex; a boundary vertex keeps that outgoing boundary half-edge
/// and an interior one the half-edge leaving it in the last triangle that closed its fan.
std::unique_ptr<TriMesh> buildOrientedManifold(const std::vector<Eigen::Vector3d>& points,
                                               const std::vector<std::array<int, 3>>& triangles);

/// The TriMesh of `points` and `triangles` (vertex indices checked in range by the caller):
/// buildOrientedManifold's when it applies, else the triangles added one by one with add_face
/// (OpenMesh's complaints silenced). Null when add_face refuses a triangle (a repeated vertex, an
/// edge with a third triangle or in the same direction twice); `refused` is then its index, else
/// -1. For callers that report such a triangle rather than split it (the readers split them).
std::unique_ptr<TriMesh> buildTriangleMesh(const std::vector<Eigen::Vector3d>& points,
                                           const std::vector<std::array<int, 3>>& triangles,
                                           std::ptrdiff_t& refused);

}  // namespace diffreg
