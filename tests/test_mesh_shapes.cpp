// Generated shapes: counts, exact measures, orientation, manifoldness, Euler characteristic,
// angle bounds and argument checking.
#include <diffreg/core/error.h>
#include <diffreg/mesh/shapes.h>

#include <catch2/catch.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <vector>

using namespace diffreg;

namespace {

constexpr double kPi = 3.14159265358979323846;

std::vector<Eigen::Vector3d> points(const Mesh& mesh) {
  std::vector<Eigen::Vector3d> result;
  if (mesh.isTet()) return mesh.tet().points;
  for (auto v : mesh.tri().vertices()) {
    const auto& p = mesh.tri().point(v);
    result.emplace_back(p[0], p[1], p[2]);
  }
  return result;
}

std::vector<std::array<int, 3>> triangles(const Mesh& mesh) {
  std::vector<std::array<int, 3>> result;
  for (auto f : mesh.tri().faces()) {
    std::array<int, 3> t{};
    int k = 0;
    for (auto v : mesh.tri().fv_range(f)) t[k++] = v.idx();
    REQUIRE(k == 3);
    result.push_back(t);
  }
  return result;
}

double signedArea2d(const std::vector<Eigen::Vector3d>& p, const std::array<int, 3>& t) {
  const Eigen::Vector3d a = p[t[1]] - p[t[0]], b = p[t[2]] - p[t[0]];
  return 0.5 * (a.x() * b.y() - a.y() * b.x());
}

Eigen::Vector3d areaVector(const std::vector<Eigen::Vector3d>& p, const std::array<int, 3>& t) {
  return 0.5 * (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]);
}

/// No two vertices share a position.
void checkNoDuplicates(const std::vector<Eigen::Vector3d>& p) {
  std::set<std::array<double, 3>> unique;
  for (const auto& q : p) unique.insert({q.x(), q.y(), q.z()});
  CHECK(unique.size() == p.size());
}

struct Topology {
  int edges = 0;
  int boundaryEdges = 0;
  bool manifold = true;  ///< each edge in 1 or 2 faces, each directed edge in at most 1
  int euler = 0;
};

Topology topology(int numVertices, const std::vector<std::array<int, 3>>& tris) {
  std::map<std::pair<int, int>, int> undirected, directed;
  for (const auto& t : tris) {
    for (int k = 0; k < 3; ++k) {
      const int a = t[k], b = t[(k + 1) % 3];
      ++directed[{a, b}];
      ++undirected[{std::min(a, b), std::max(a, b)}];
    }
  }
  Topology topo;
  topo.edges = int(undirected.size());
  for (const auto& [edge, count] : undirected) {
    if (count == 1) ++topo.boundaryEdges;
    if (count < 1 || count > 2) topo.manifold = false;
  }
  for (const auto& [edge, count] : directed)
    if (count != 1) topo.manifold = false;
  topo.euler = numVertices - topo.edges + int(tris.size());
  return topo;
}

double maxAngleDegrees(const std::vector<Eigen::Vector3d>& p,
                       const std::vector<std::array<int, 3>>& tris) {
  double largest = 0.0;
  for (const auto& t : tris) {
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d u = p[t[(k + 1) % 3]] - p[t[k]], v = p[t[(k + 2) % 3]] - p[t[k]];
      const double c = std::clamp(u.dot(v) / (u.norm() * v.norm()), -1.0, 1.0);
      largest = std::max(largest, std::acos(c) * 180.0 / kPi);
    }
  }
  return largest;
}

/// Checks shared by every planar shape; returns the total area.
double checkPlanar(const Mesh& mesh, int expectedEuler, bool rightTriangles) {
  CHECK(mesh.kind() == MeshKind::Planar);
  const auto p = points(mesh);
  const auto tris = triangles(mesh);
  for (const auto& q : p) CHECK(q.z() == 0.0);
  double area = 0.0;
  int clockwise = 0;
  for (const auto& t : tris) {
    const double a = signedArea2d(p, t);
    if (!(a > 0.0)) ++clockwise;
    area += a;
  }
  CHECK(clockwise == 0);
  checkNoDuplicates(p);
  const Topology topo = topology(int(p.size()), tris);
  CHECK(topo.manifold);
  CHECK(topo.euler == expectedEuler);
  if (rightTriangles) CHECK(maxAngleDegrees(p, tris) <= 90.0 + 1e-9);
  return area;
}

}  // namespace

TEST_CASE("rectangle: counts, exact area, CCW, Delaunay, Euler 1", "[shapes]") {
  const int nx = 32, ny = 4;
  const Mesh mesh = makeRectangle(8.0, 1.0, nx, ny);
  CHECK(mesh.numVertices() == (nx + 1) * (ny + 1) + nx * ny);
  CHECK(mesh.numElements() == 4 * nx * ny);
  CHECK(checkPlanar(mesh, 1, true) == Approx(8.0).epsilon(1e-14));
  const Topology topo = topology(mesh.numVertices(), triangles(mesh));
  CHECK(topo.boundaryEdges == 2 * (nx + ny));
  // Corner (i, j) is vertex j (nx + 1) + i: the numbering the shipped scenarios rely on.
  const auto p = points(mesh);
  CHECK(p[2 * (nx + 1) + 30] == Eigen::Vector3d(7.5, 0.5, 0.0));
  CHECK(p[(ny + 1) * (nx + 1) - 1] == Eigen::Vector3d(8.0, 1.0, 0.0));
}

TEST_CASE("rectangle with non-square cells keeps exact extents", "[shapes]") {
  const Mesh mesh = makeRectangle(1.0, 3.0, 3, 7);
  CHECK(checkPlanar(mesh, 1, false) == Approx(3.0).epsilon(1e-14));
  double xmax = 0.0, ymax = 0.0;
  for (const auto& q : points(mesh)) {
    xmax = std::max(xmax, q.x());
    ymax = std::max(ymax, q.y());
  }
  CHECK(xmax == 1.0);
  CHECK(ymax == 3.0);
}

TEST_CASE("cell shapes: plus sign, ring with a hole, invalid masks", "[shapes]") {
  SECTION("plus sign") {
    const std::vector<std::vector<bool>> plus{
        {false, true, false}, {true, true, true}, {false, true, false}};
    const Mesh mesh = makeCellShape(plus, 0.5);
    CHECK(mesh.numVertices() == 12 + 5);  // 12 lattice corners used, 5 centres
    CHECK(mesh.numElements() == 20);
    CHECK(checkPlanar(mesh, 1, true) == Approx(5 * 0.25).epsilon(1e-14));
    CHECK(topology(mesh.numVertices(), triangles(mesh)).boundaryEdges == 12);
  }
  SECTION("ring around a hole has Euler characteristic 0") {
    const std::vector<std::vector<bool>> ring{
        {true, true, true}, {true, false, true}, {true, true, true}};
    const Mesh mesh = makeCellShape(ring, 1.0);
    CHECK(checkPlanar(mesh, 0, true) == Approx(8.0).epsilon(1e-14));
    CHECK(topology(mesh.numVertices(), triangles(mesh)).boundaryEdges == 16);
  }
  SECTION("invalid masks") {
    CHECK_THROWS_AS(makeCellShape({}, 1.0), InvalidParameter);
    CHECK_THROWS_AS(makeCellShape({{false, false}}, 1.0), InvalidParameter);
    CHECK_THROWS_AS(makeCellShape({{true, true}, {true}}, 1.0), InvalidParameter);
    // Cells touching only at a corner would make a non-manifold vertex.
    CHECK_THROWS_AS(makeCellShape({{true, false}, {false, true}}, 1.0), InvalidParameter);
    CHECK_THROWS_AS(makeCellShape({{false, true}, {true, false}}, 1.0), InvalidParameter);
    CHECK_THROWS_AS(makeCellShape({{true}}, 0.0), InvalidParameter);
    CHECK_THROWS_AS(makeCellShape({{true}}, -1.0), InvalidParameter);
    CHECK_THROWS_AS(makeCellShape({{true, true, true}}, 1e308), InvalidParameter);
  }
}

TEST_CASE("L shape: counts, exact area, Euler 1", "[shapes]") {
  const Mesh mesh = makeLShape(2.0, 1.0, 8);
  const int cells = 16 * 16 - 8 * 8;
  CHECK(mesh.numElements() == 4 * cells);
  CHECK(mesh.numVertices() == (17 * 17 - 8 * 8) + cells);
  CHECK(checkPlanar(mesh, 1, true) == Approx(4.0 - 1.0).epsilon(1e-14));
  // Non-unit arm and size.
  CHECK(checkPlanar(makeLShape(3.0, 0.5, 2), 1, true) == Approx(9.0 - 6.25).epsilon(1e-14));
}

TEST_CASE("U shape: counts, exact area, Euler 1", "[shapes]") {
  const Mesh mesh = makeUShape(1.0, 1.0, 4.0, 4);
  const int cells = 2 * (4 * 16) + 4 * 4;
  CHECK(mesh.numElements() == 4 * cells);
  CHECK(mesh.numVertices() == (13 * 17 - 3 * 12) + cells);
  CHECK(checkPlanar(mesh, 1, true) == Approx(2 * 4.0 + 1.0).epsilon(1e-14));
  CHECK(checkPlanar(makeUShape(0.5, 2.0, 1.5, 2), 1, true) ==
        Approx(2 * 0.5 * 1.5 + 2.0 * 0.5).epsilon(1e-14));
}

TEST_CASE("disc: rings of 6k vertices, exact polygon area, Euler 1", "[shapes]") {
  for (int rings : {1, 2, 8}) {
    const double radius = 1.5;
    const Mesh mesh = makeDisc(radius, rings);
    CHECK(mesh.numVertices() == 1 + 3 * rings * (rings + 1));
    CHECK(mesh.numElements() == 6 * rings * rings);
    // The union of the triangles is the regular 6n-gon inscribed in the circle.
    const int n = 6 * rings;
    const double polygon = 0.5 * n * radius * radius * std::sin(2.0 * kPi / n);
    CHECK(checkPlanar(mesh, 1, false) == Approx(polygon).epsilon(1e-13));
    const Topology topo = topology(mesh.numVertices(), triangles(mesh));
    CHECK(topo.boundaryEdges == n);
    const auto p = points(mesh);
    for (int j = 0; j < n; ++j)
      CHECK(p[1 + 3 * rings * (rings - 1) + j].norm() == Approx(radius).epsilon(1e-14));
  }
}

TEST_CASE("cylinder: outward orientation, exact area, Euler 0", "[shapes]") {
  const int around = 24, along = 16;
  const double radius = 1.0, height = 4.0;
  const Mesh mesh = makeCylinder(radius, height, around, along);
  CHECK(mesh.kind() == MeshKind::Surface);
  CHECK(mesh.numVertices() == around * (along + 1));
  CHECK(mesh.numElements() == 2 * around * along);
  const auto p = points(mesh);
  const auto tris = triangles(mesh);
  double area = 0.0;
  int inward = 0;
  for (const auto& t : tris) {
    const Eigen::Vector3d n = areaVector(p, t);
    Eigen::Vector3d radial = (p[t[0]] + p[t[1]] + p[t[2]]) / 3.0;
    radial.z() = 0.0;
    if (!(n.dot(radial) > 0.0)) ++inward;
    area += n.norm();
  }
  CHECK(inward == 0);
  const double chord = 2.0 * radius * std::sin(kPi / around);
  CHECK(area == Approx(around * chord * height).epsilon(1e-13));
  checkNoDuplicates(p);
  const Topology topo = topology(int(p.size()), tris);
  CHECK(topo.manifold);
  CHECK(topo.euler == 0);
  CHECK(topo.boundaryEdges == 2 * around);
}

TEST_CASE("sphere: closed, outward, single poles, exact area, Euler 2", "[shapes]") {
  const int slices = 12, stacks = 7;
  const double radius = 2.0;
  const Mesh mesh = makeSphere(radius, slices, stacks);
  CHECK(mesh.kind() == MeshKind::Surface);
  CHECK(mesh.numVertices() == 2 + slices * (stacks - 1));
  CHECK(mesh.numElements() == 2 * slices * (stacks - 1));
  const auto p = points(mesh);
  const auto tris = triangles(mesh);
  double area = 0.0, volume = 0.0;
  int inward = 0;
  for (const auto& t : tris) {
    const Eigen::Vector3d n = areaVector(p, t);
    if (!(n.dot(p[t[0]] + p[t[1]] + p[t[2]]) > 0.0)) ++inward;
    area += n.norm();
    volume += p[t[0]].dot(p[t[1]].cross(p[t[2]])) / 6.0;
  }
  CHECK(inward == 0);
  // Rings s = 0..stacks (poles included) at distance rho_s from the axis and height z_s; the
  // band between two rings is `slices` isosceles trapezoids (triangles at the poles) whose
  // parallel sides are chords 2 rho sin(pi / slices) and whose height joins the chord midpoints.
  double expected = 0.0;
  for (int s = 0; s < stacks; ++s) {
    const double r0 = radius * std::sin(kPi * s / stacks),
                 r1 = radius * std::sin(kPi * (s + 1) / stacks);
    const double z0 = radius * std::cos(kPi * s / stacks),
                 z1 = radius * std::cos(kPi * (s + 1) / stacks);
    const double c = std::cos(kPi / slices), half = std::sin(kPi / slices);
    const double h = std::hypot((r1 - r0) * c, z1 - z0);
    expected += slices * (r0 + r1) * half * h;
  }
  CHECK(area == Approx(expected).epsilon(1e-13));
  CHECK(volume > 0.0);
  CHECK(volume < 4.0 / 3.0 * kPi * radius * radius * radius);
  int poles = 0;
  for (const auto& q : p)
    if (std::abs(std::abs(q.z()) - radius) < 1e-12) ++poles;
  CHECK(poles == 2);
  checkNoDuplicates(p);
  const Topology topo = topology(int(p.size()), tris);
  CHECK(topo.manifold);
  CHECK(topo.boundaryEdges == 0);
  CHECK(topo.euler == 2);
}

TEST_CASE("tet box: positive tets, exact volume, conforming, Euler 1", "[shapes]") {
  const int nx = 5, ny = 3, nz = 2;
  const double lx = 2.5, ly = 1.0, lz = 0.75;
  const Mesh mesh = makeTetBox(lx, ly, lz, nx, ny, nz);
  CHECK(mesh.kind() == MeshKind::Tet);
  CHECK(mesh.numVertices() == (nx + 1) * (ny + 1) * (nz + 1));
  CHECK(mesh.numElements() == 6 * nx * ny * nz);
  const auto& p = mesh.tet().points;
  double volume = 0.0;
  int nonPositive = 0;
  std::map<std::array<int, 3>, int> faces;
  std::set<std::pair<int, int>> edges;
  for (const auto& t : mesh.tet().tets) {
    Eigen::Matrix3d d;
    d << p[t[1]] - p[t[0]], p[t[2]] - p[t[0]], p[t[3]] - p[t[0]];
    const double det = d.determinant();
    if (!(det > 0.0)) ++nonPositive;
    volume += det / 6.0;
    for (int k = 0; k < 4; ++k) {
      std::array<int, 3> f{t[(k + 1) % 4], t[(k + 2) % 4], t[(k + 3) % 4]};
      std::sort(f.begin(), f.end());
      ++faces[f];
      for (int l = k + 1; l < 4; ++l) edges.insert({std::min(t[k], t[l]), std::max(t[k], t[l])});
    }
  }
  CHECK(nonPositive == 0);
  CHECK(volume == Approx(lx * ly * lz).epsilon(1e-14));
  // Conforming: every face is shared by two tets or lies on the box boundary.
  int boundary = 0, offBoundary = 0, overShared = 0;
  auto onBoxFace = [&](const std::array<int, 3>& f) {
    for (int axis = 0; axis < 3; ++axis) {
      const double extent = axis == 0 ? lx : axis == 1 ? ly : lz;
      for (double side : {0.0, extent})
        if (p[f[0]][axis] == side && p[f[1]][axis] == side && p[f[2]][axis] == side) return true;
    }
    return false;
  };
  for (const auto& [f, count] : faces) {
    if (count > 2) ++overShared;
    if (count == 1) {
      ++boundary;
      if (!onBoxFace(f)) ++offBoundary;
    }
  }
  CHECK(overShared == 0);
  CHECK(offBoundary == 0);
  CHECK(boundary == 4 * (nx * ny + ny * nz + nz * nx));
  CHECK(mesh.numVertices() - int(edges.size()) + int(faces.size()) - mesh.numElements() == 1);
  checkNoDuplicates(p);
}

TEST_CASE("invalid shape arguments are InvalidParameter", "[shapes]") {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  CHECK_THROWS_AS(makeRectangle(0.0, 1.0, 2, 2), InvalidParameter);
  CHECK_THROWS_AS(makeRectangle(1.0, -1.0, 2, 2), InvalidParameter);
  CHECK_THROWS_AS(makeRectangle(nan, 1.0, 2, 2), InvalidParameter);
  CHECK_THROWS_AS(makeRectangle(inf, 1.0, 2, 2), InvalidParameter);
  CHECK_THROWS_AS(makeRectangle(1.0, 1.0, 0, 2), InvalidParameter);
  CHECK_THROWS_AS(makeRectangle(1.0, 1.0, 2, -3), InvalidParameter);
  CHECK_THROWS_AS(makeRectangle(1.0, 1.0, 1 << 20, 1 << 20), InvalidParameter);
  CHECK_THROWS_AS(makeLShape(1.0, 1.0, 4), InvalidParameter);  // arm == size
  CHECK_THROWS_AS(makeLShape(1.0, 2.0, 4), InvalidParameter);  // arm > size
  CHECK_THROWS_AS(makeLShape(2.0, 0.3, 4), InvalidParameter);  // arm not a whole number of cells
  CHECK_THROWS_AS(makeLShape(2.0, 1.0, 0), InvalidParameter);
  CHECK_THROWS_AS(makeLShape(2.0, 0.0, 4), InvalidParameter);
  CHECK_THROWS_AS(makeUShape(1.0, 1.0, 1.0, 4), InvalidParameter);  // arm == height
  CHECK_THROWS_AS(makeUShape(1.0, 0.0, 4.0, 4), InvalidParameter);
  CHECK_THROWS_AS(makeUShape(1.0, 1.1, 4.0, 4), InvalidParameter);
  CHECK_THROWS_AS(makeUShape(1.0, 1.0, 4.0, -1), InvalidParameter);
  CHECK_THROWS_AS(makeDisc(0.0, 3), InvalidParameter);
  CHECK_THROWS_AS(makeDisc(1.0, 0), InvalidParameter);
  CHECK_THROWS_AS(makeCylinder(1.0, 1.0, 2, 3), InvalidParameter);
  CHECK_THROWS_AS(makeCylinder(1.0, 1.0, 8, 0), InvalidParameter);
  CHECK_THROWS_AS(makeCylinder(-1.0, 1.0, 8, 2), InvalidParameter);
  CHECK_THROWS_AS(makeCylinder(1.0, nan, 8, 2), InvalidParameter);
  CHECK_THROWS_AS(makeSphere(1.0, 2, 4), InvalidParameter);
  CHECK_THROWS_AS(makeSphere(1.0, 8, 1), InvalidParameter);
  CHECK_THROWS_AS(makeSphere(0.0, 8, 4), InvalidParameter);
  CHECK_THROWS_AS(makeTetBox(1.0, 1.0, 0.0, 1, 1, 1), InvalidParameter);
  CHECK_THROWS_AS(makeTetBox(1.0, 1.0, 1.0, 1, 0, 1), InvalidParameter);
  CHECK_THROWS_AS(makeTetBox(1.0, 1.0, 1.0, 1000, 1000, 1000), InvalidParameter);
}
