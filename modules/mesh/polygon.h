// Triangulation of the polygonal faces of OBJ, OFF and PLY files.
#pragma once

#include <Eigen/Core>

#include <array>
#include <string>
#include <vector>

namespace diffreg {

/// Corners a polygonal face may have (ear clipping is quadratic in them).
inline constexpr size_t kMaxPolygonCorners = 256;

/// The sum of the squared corner counts of a file's polygonal faces (the work of checking and
/// clipping them): about 4,000 faces of 256 corners, 2 to 3 seconds here; 16 million quads.
inline constexpr unsigned long long kMaxPolygonWork = 1ULL << 28;

/// Triangulates the polygon `ids` (indices into `points`) by ear clipping in its plane (the
/// Newell plane), keeping its orientation: every triangle lies inside the polygon and none
/// overlaps another. `where` ("file:line: face N") starts the messages.
/// \throw InvalidMesh when the polygon has more than kMaxPolygonCorners corners, no area, is
///        not planar (a corner farther than 5% of its diameter from its plane) or intersects
///        itself (two edges cross or touch, or two corners coincide).
std::vector<std::array<long long, 3>> triangulatePolygon(const std::vector<Eigen::Vector3d>& points,
                                                         const std::vector<long long>& ids,
                                                         const std::string& where);

}  // namespace diffreg
