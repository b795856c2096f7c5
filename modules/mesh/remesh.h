// Mesh edits for the paper's robustness experiments: random edge flips (triangulation
// independence, paper Fig. 8) and uniform subdivision (resolution, paper Fig. 9). Both keep
// the ids of the existing vertices, so handles given by vertex id stay valid.
#pragma once

#include <diffreg/mesh/mesh.h>

#include <string>

namespace diffreg {

/// Flips round(fraction x interior edges) randomly chosen interior edges of a planar or
/// surface mesh, drawing the order from std::mt19937(seed) (same seed, same mesh, same
/// result on every platform). An edge is flipped only when OpenMesh's is_flip_ok allows it
/// and both new triangles are non-degenerate and keep the orientation: planar meshes, the
/// same sign of the signed area as the two old triangles (nothing folds); surfaces, the two
/// old normals within 30 degrees of each other and both new normals within 30 degrees of
/// their mean (the shape is unchanged up to that flatness). Edges that fail are skipped and the
/// next candidate is tried, so fewer flips happen when not enough edges qualify.
/// Vertex positions, ids and vertex properties are untouched; element scalar properties no
/// longer match the new triangles and are removed.
/// \return the number of edges flipped.
/// \throw InvalidParameter for a tet mesh or fraction outside [0, 1].
int flipEdges(Mesh& mesh, double fraction, unsigned seed);

/// Uniform 1-to-4 subdivision, `iterations` times, with OpenMesh's Loop subdivider:
/// "midpoint" splits every edge at its midpoint and keeps all old positions (OpenMesh's LoopT
/// without its smoothing step: the shape, a flat one included, is unchanged); "loop" is Loop
/// subdivision (old vertices move, the surface is smoothed; a planar mesh stays planar but
/// its boundary shrinks). Old vertices keep their ids 0..n-1, new ones are appended.
/// Vertex scalar properties are interpolated linearly: a new vertex gets the mean of the two
/// ends of the edge it split; old vertices keep their values. Element scalar properties are
/// removed (the faces are new).
/// \throw InvalidParameter for a tet mesh, iterations < 0 or an unknown scheme (listing the
///        valid ones).
void subdivide(Mesh& mesh, int iterations, const std::string& scheme);

}  // namespace diffreg
