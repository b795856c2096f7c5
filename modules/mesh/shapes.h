// Small meshes the project makes itself: for tests, the shipped scenarios and benchmarks.
// Planar shapes are unions of square cells, each cut into 4 right triangles around its centre,
// so every angle is at most 90 degrees and the cotangent weights are non-negative (Delaunay).
#pragma once

#include <diffreg/mesh/mesh.h>

#include <vector>

namespace diffreg {

/// Planar rectangle [0, width] x [0, height] with nx x ny cells.
Mesh makeRectangle(double width, double height, int nx, int ny);
/// Planar union of the cells (i, j) with mask[j][i] true, cell size `cell`, origin at (0, 0).
Mesh makeCellShape(const std::vector<std::vector<bool>>& mask, double cell);
/// Planar L: a `size` x `size` square minus its upper-right (size - arm) x (size - arm) square.
Mesh makeLShape(double size, double arm, int cellsPerUnit);
/// Planar U: two vertical arms of width `arm` and height `height` joined by a bottom bar of
/// height `arm`; the gap between the arms has width `gap`.
Mesh makeUShape(double arm, double gap, double height, int cellsPerUnit);
/// Planar disc of `radius` from `rings` concentric rings (6 k vertices on ring k).
Mesh makeDisc(double radius, int rings);
/// Open cylinder surface (axis z) with `around` x `along` quads, each cut into 2 triangles.
Mesh makeCylinder(double radius, double height, int around, int along);
/// Closed UV sphere surface.
Mesh makeSphere(double radius, int slices, int stacks);
/// Tet box [0,lx]x[0,ly]x[0,lz], nx x ny x nz cubes of 6 positively oriented tets each.
Mesh makeTetBox(double lx, double ly, double lz, int nx, int ny, int nz);

}  // namespace diffreg
