#include <diffreg/mesh/shapes.h>

#include <diffreg/core/error.h>
#include <diffreg/mesh/halfedges.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <utility>

namespace diffreg {
namespace {

constexpr double kPi = 3.14159265358979323846;
/// Upper bound on the elements of a generated mesh, so absurd counts fail cleanly.
constexpr std::int64_t kMaxElements = std::int64_t(1) << 26;

using Triangle = std::array<int, 3>;

[[noreturn]] void fail(const char* function, const std::string& what) {
  throw InvalidParameter(std::string(function) + ": " + what);
}

void requireLength(const char* function, const char* name, double value) {
  if (!std::isfinite(value) || !(value > 0.0))
    fail(function,
         std::string(name) + " must be a positive finite number, got " + std::to_string(value));
}

void requireCount(const char* function, const char* name, int value, int minimum) {
  if (value < minimum)
    fail(function, std::string(name) + " must be at least " + std::to_string(minimum) + ", got " +
                       std::to_string(value));
}

void requireElements(const char* function, std::int64_t elements) {
  if (elements > kMaxElements)
    fail(function, "too many elements (" + std::to_string(elements) + ", at most " +
                       std::to_string(kMaxElements) + ")");
}

/// Number of cells of size 1/cellsPerUnit that make up `length`; it must be a whole number.
int cellsAlong(const char* function, const char* name, double length, int cellsPerUnit) {
  const double cells = length * cellsPerUnit;
  const double rounded = std::round(cells);
  if (!(cells < double(kMaxElements)) || std::abs(cells - rounded) > 1e-9 * std::max(1.0, cells) ||
      rounded < 1.0)
    fail(function, std::string(name) + " * cellsPerUnit must be a positive whole number, got " +
                       std::to_string(cells));
  return int(rounded);
}

/// Builds the TriMesh from points and triangles (indices into points).
Mesh buildTriMesh(const char* function, const std::vector<Eigen::Vector3d>& points,
                  const std::vector<Triangle>& triangles) {
  std::ptrdiff_t refused = -1;
  auto tri = buildTriangleMesh(points, triangles, refused);
  if (!tri) fail(function, "face " + std::to_string(refused) + " makes the mesh non-manifold");
  return Mesh(std::move(tri));
}

/// Coordinate value * t / divisions along one axis; exact at t = 0 and t = divisions.
struct Axis {
  double length;
  double divisions;
  double at(double t) const { return length * t / divisions; }
};

/// Union of the cells mask[j][i] over a grid whose lattice point (i, j) sits at
/// (x.at(i), y.at(j)). Corner vertices come first, row by row (j, then i), then one centre
/// vertex per cell in the same order; each cell is cut into 4 triangles around its centre.
Mesh gridShape(const char* function, const std::vector<std::vector<bool>>& mask, Axis x, Axis y) {
  const int rows = int(mask.size());
  if (rows == 0 || mask[0].empty()) fail(function, "the cell mask is empty");
  const int cols = int(mask[0].size());
  for (int j = 0; j < rows; ++j)
    if (int(mask[j].size()) != cols)
      fail(function, "mask row " + std::to_string(j) + " has " + std::to_string(mask[j].size()) +
                         " cells, row 0 has " + std::to_string(cols));
  requireElements(function, std::int64_t(rows) * cols * 4);
  if (!std::isfinite(x.at(cols)) || !std::isfinite(y.at(rows)) || !(x.at(0.5) * y.at(0.5) > 0.0))
    fail(function, "the cell size gives non-finite coordinates or zero-area triangles");
  auto in = [&](int i, int j) { return i >= 0 && j >= 0 && i < cols && j < rows && mask[j][i]; };

  std::vector<Eigen::Vector3d> points;
  std::vector<int> cornerId(std::size_t(rows + 1) * (cols + 1), -1);
  auto corner = [&](int i, int j) -> int& { return cornerId[std::size_t(j) * (cols + 1) + i]; };
  for (int j = 0; j <= rows; ++j) {
    for (int i = 0; i <= cols; ++i) {
      const bool a = in(i - 1, j - 1), b = in(i, j - 1), c = in(i - 1, j), d = in(i, j);
      if ((a && d && !b && !c) || (b && c && !a && !d))
        fail(function, "cells meet only at the corner (" + std::to_string(i) + ", " +
                           std::to_string(j) + "), which would make the mesh non-manifold");
      if (a || b || c || d) {
        corner(i, j) = int(points.size());
        points.emplace_back(x.at(i), y.at(j), 0.0);
      }
    }
  }
  std::vector<Triangle> triangles;
  for (int j = 0; j < rows; ++j) {
    for (int i = 0; i < cols; ++i) {
      if (!in(i, j)) continue;
      const int centre = int(points.size());
      points.emplace_back(x.at(i + 0.5), y.at(j + 0.5), 0.0);
      const int c00 = corner(i, j), c10 = corner(i + 1, j);
      const int c11 = corner(i + 1, j + 1), c01 = corner(i, j + 1);
      triangles.push_back({c00, c10, centre});
      triangles.push_back({c10, c11, centre});
      triangles.push_back({c11, c01, centre});
      triangles.push_back({c01, c00, centre});
    }
  }
  if (triangles.empty()) fail(function, "the cell mask selects no cell");
  return buildTriMesh(function, points, triangles);
}

}  // namespace

Mesh makeRectangle(double width, double height, int nx, int ny) {
  const char* fn = "makeRectangle";
  requireLength(fn, "width", width);
  requireLength(fn, "height", height);
  requireCount(fn, "nx", nx, 1);
  requireCount(fn, "ny", ny, 1);
  requireElements(fn, std::int64_t(nx) * ny * 4);
  const std::vector<std::vector<bool>> mask(ny, std::vector<bool>(nx, true));
  return gridShape(fn, mask, {width, double(nx)}, {height, double(ny)});
}

Mesh makeCellShape(const std::vector<std::vector<bool>>& mask, double cell) {
  const char* fn = "makeCellShape";
  requireLength(fn, "cell", cell);
  return gridShape(fn, mask, {cell, 1.0}, {cell, 1.0});
}

Mesh makeLShape(double size, double arm, int cellsPerUnit) {
  const char* fn = "makeLShape";
  requireLength(fn, "size", size);
  requireLength(fn, "arm", arm);
  requireCount(fn, "cellsPerUnit", cellsPerUnit, 1);
  if (!(arm < size))
    fail(fn, "arm (" + std::to_string(arm) + ") must be smaller than size (" +
                 std::to_string(size) + ")");
  const int n = cellsAlong(fn, "size", size, cellsPerUnit);
  const int a = cellsAlong(fn, "arm", arm, cellsPerUnit);
  requireElements(fn, std::int64_t(n) * n * 4);
  std::vector<std::vector<bool>> mask(n, std::vector<bool>(n, false));
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) mask[j][i] = i < a || j < a;
  const Axis axis{1.0, double(cellsPerUnit)};
  return gridShape(fn, mask, axis, axis);
}

Mesh makeUShape(double arm, double gap, double height, int cellsPerUnit) {
  const char* fn = "makeUShape";
  requireLength(fn, "arm", arm);
  requireLength(fn, "gap", gap);
  requireLength(fn, "height", height);
  requireCount(fn, "cellsPerUnit", cellsPerUnit, 1);
  if (!(arm < height))
    fail(fn, "arm (" + std::to_string(arm) + ") must be smaller than height (" +
                 std::to_string(height) + ")");
  const int a = cellsAlong(fn, "arm", arm, cellsPerUnit);
  const int g = cellsAlong(fn, "gap", gap, cellsPerUnit);
  const int h = cellsAlong(fn, "height", height, cellsPerUnit);
  const int w = 2 * a + g;
  requireElements(fn, std::int64_t(w) * h * 4);
  std::vector<std::vector<bool>> mask(h, std::vector<bool>(w, false));
  for (int j = 0; j < h; ++j)
    for (int i = 0; i < w; ++i) mask[j][i] = j < a || i < a || i >= a + g;
  const Axis axis{1.0, double(cellsPerUnit)};
  return gridShape(fn, mask, axis, axis);
}

Mesh makeDisc(double radius, int rings) {
  const char* fn = "makeDisc";
  requireLength(fn, "radius", radius);
  requireCount(fn, "rings", rings, 1);
  requireElements(fn, std::int64_t(6) * rings * rings);
  // Vertex 0 is the centre; ring k (1..rings) starts at 1 + 3 k (k - 1) with 6 k vertices at
  // angles 2 pi j / (6 k).
  std::vector<Eigen::Vector3d> points{Eigen::Vector3d::Zero()};
  for (int k = 1; k <= rings; ++k) {
    const double r = radius * k / rings;
    for (int j = 0; j < 6 * k; ++j) {
      const double angle = 2.0 * kPi * j / (6 * k);
      points.emplace_back(r * std::cos(angle), r * std::sin(angle), 0.0);
    }
  }
  auto ringStart = [](int k) { return k == 0 ? 0 : 1 + 3 * k * (k - 1); };
  std::vector<Triangle> triangles;
  for (int k = 1; k <= rings; ++k) {
    // Zip ring k-1 (m vertices; the centre when k = 1) to ring k, advancing along whichever
    // ring has the next vertex at the smaller angle (the inner ring first on a tie, which
    // keeps each 60-degree sector mirror-symmetric).
    const int m = 6 * (k - 1), n = 6 * k;
    const int in0 = ringStart(k - 1), out0 = ringStart(k);
    auto inner = [&](int i) { return m == 0 ? in0 : in0 + i % m; };
    auto outer = [&](int j) { return out0 + j % n; };
    int i = 0, j = 0;
    while (i < m || j < n) {
      const bool advanceInner =
          j == n || (i < m && std::int64_t(i + 1) * n <= std::int64_t(j + 1) * m);
      if (advanceInner) {
        triangles.push_back({inner(i), outer(j), inner(i + 1)});
        ++i;
      } else {
        triangles.push_back({inner(i), outer(j), outer(j + 1)});
        ++j;
      }
    }
  }
  return buildTriMesh(fn, points, triangles);
}

Mesh makeCylinder(double radius, double height, int around, int along) {
  const char* fn = "makeCylinder";
  requireLength(fn, "radius", radius);
  requireLength(fn, "height", height);
  requireCount(fn, "around", around, 3);
  requireCount(fn, "along", along, 1);
  requireElements(fn, std::int64_t(around) * along * 2);
  // Vertex (l, a) = l * around + a at height height * l / along and angle 2 pi a / around.
  std::vector<Eigen::Vector3d> points;
  for (int l = 0; l <= along; ++l) {
    for (int a = 0; a < around; ++a) {
      const double angle = 2.0 * kPi * a / around;
      points.emplace_back(radius * std::cos(angle), radius * std::sin(angle), height * l / along);
    }
  }
  auto id = [&](int l, int a) { return l * around + a % around; };
  std::vector<Triangle> triangles;
  for (int l = 0; l < along; ++l) {
    for (int a = 0; a < around; ++a) {
      // Quad (l, a) -> (l, a+1) -> (l+1, a+1) -> (l+1, a) is counter-clockwise seen from
      // outside; the diagonal alternates in a checkerboard so the mesh has no twist bias.
      const int p00 = id(l, a), p10 = id(l, a + 1), p11 = id(l + 1, a + 1), p01 = id(l + 1, a);
      if ((l + a) % 2 == 0) {
        triangles.push_back({p00, p10, p11});
        triangles.push_back({p00, p11, p01});
      } else {
        triangles.push_back({p00, p10, p01});
        triangles.push_back({p10, p11, p01});
      }
    }
  }
  return buildTriMesh(fn, points, triangles);
}

Mesh makeSphere(double radius, int slices, int stacks) {
  const char* fn = "makeSphere";
  requireLength(fn, "radius", radius);
  requireCount(fn, "slices", slices, 3);
  requireCount(fn, "stacks", stacks, 2);
  requireElements(fn, std::int64_t(slices) * stacks * 2);
  // Vertex 0 is the north pole, then rings s = 1..stacks-1 of `slices` vertices from north to
  // south, then the south pole.
  std::vector<Eigen::Vector3d> points{Eigen::Vector3d(0.0, 0.0, radius)};
  for (int s = 1; s < stacks; ++s) {
    const double polar = kPi * s / stacks;
    for (int a = 0; a < slices; ++a) {
      const double azimuth = 2.0 * kPi * a / slices;
      points.emplace_back(radius * std::sin(polar) * std::cos(azimuth),
                          radius * std::sin(polar) * std::sin(azimuth), radius * std::cos(polar));
    }
  }
  const int south = int(points.size());
  points.emplace_back(0.0, 0.0, -radius);
  auto id = [&](int s, int a) { return 1 + (s - 1) * slices + a % slices; };
  std::vector<Triangle> triangles;
  for (int a = 0; a < slices; ++a) triangles.push_back({0, id(1, a), id(1, a + 1)});
  for (int s = 1; s + 1 < stacks; ++s) {
    for (int a = 0; a < slices; ++a) {
      triangles.push_back({id(s, a), id(s + 1, a), id(s + 1, a + 1)});
      triangles.push_back({id(s, a), id(s + 1, a + 1), id(s, a + 1)});
    }
  }
  for (int a = 0; a < slices; ++a)
    triangles.push_back({id(stacks - 1, a), south, id(stacks - 1, a + 1)});
  return buildTriMesh(fn, points, triangles);
}

Mesh makeTetBox(double lx, double ly, double lz, int nx, int ny, int nz) {
  const char* fn = "makeTetBox";
  requireLength(fn, "lx", lx);
  requireLength(fn, "ly", ly);
  requireLength(fn, "lz", lz);
  requireCount(fn, "nx", nx, 1);
  requireCount(fn, "ny", ny, 1);
  requireCount(fn, "nz", nz, 1);
  requireElements(fn, std::int64_t(nx) * ny * nz * 6);
  // Vertex (i, j, k) = (k (ny + 1) + j) (nx + 1) + i.
  TetMesh tet;
  auto id = [&](int i, int j, int k) { return (k * (ny + 1) + j) * (nx + 1) + i; };
  for (int k = 0; k <= nz; ++k)
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i) tet.points.emplace_back(lx * i / nx, ly * j / ny, lz * k / nz);
  // Kuhn (Freudenthal) subdivision: one tet per axis order, each a monotone path from the
  // cube's minimum corner to its maximum corner. Every cube face is then cut along the
  // diagonal through its minimum corner, so neighbouring cubes conform.
  static const int kOrders[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1},   // even permutations
                                    {0, 2, 1}, {2, 1, 0}, {1, 0, 2}};  // odd permutations
  for (int k = 0; k < nz; ++k) {
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        for (int p = 0; p < 6; ++p) {
          std::array<int, 3> c{i, j, k};
          std::array<int, 4> t;
          t[0] = id(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            ++c[kOrders[p][s]];
            t[s + 1] = id(c[0], c[1], c[2]);
          }
          // det[b-a, c-a, d-a] is the permutation's sign; swap two vertices of odd ones.
          if (p >= 3) std::swap(t[2], t[3]);
          tet.tets.push_back(t);
        }
      }
    }
  }
  return Mesh(std::move(tet));
}

}  // namespace diffreg
