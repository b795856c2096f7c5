// The one-pass half-edge construction (modules/mesh/halfedges.h) against OpenMesh's own
// add_face, element for element.

#include <diffreg/core/file.h>
#include <diffreg/mesh/halfedges.h>
#include <diffreg/mesh/parse.h>
#include <diffreg/mesh/shapes.h>

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>
#include <string>

using namespace diffreg;
namespace fs = std::filesystem;

namespace {

struct Soup {
  std::vector<Eigen::Vector3d> points;
  std::vector<std::array<int, 3>> triangles;
};

Soup soupOf(const Mesh& mesh) {
  Soup s;
  const Eigen::MatrixXd p = mesh.positions();
  const Eigen::MatrixXi e = mesh.elements();
  for (Eigen::Index i = 0; i < p.rows(); ++i) s.points.emplace_back(p(i, 0), p(i, 1), p(i, 2));
  for (Eigen::Index k = 0; k < e.rows(); ++k) s.triangles.push_back({e(k, 0), e(k, 1), e(k, 2)});
  return s;
}

/// What OpenMesh builds adding the triangles one by one; false when it refuses one.
bool incremental(const Soup& s, TriMesh& tri) {
  OpenMeshQuiet quiet;
  for (const auto& p : s.points) tri.add_vertex(TriMesh::Point(p[0], p[1], p[2]));
  for (const auto& t : s.triangles)
    if (!tri.add_face(OpenMesh::VertexHandle(t[0]), OpenMesh::VertexHandle(t[1]),
                      OpenMesh::VertexHandle(t[2]))
             .is_valid())
      return false;
  return true;
}

/// Every handle of the two meshes' connectivity, and the points, the same; names the first
/// difference.
std::string difference(const TriMesh& a, const TriMesh& b) {
  if (a.n_vertices() != b.n_vertices() || a.n_edges() != b.n_edges() || a.n_faces() != b.n_faces())
    return "counts";
  for (auto v : a.vertices()) {
    const auto w = b.vertex_handle(unsigned(v.idx()));
    if (a.point(v) != b.point(w)) return "point of vertex " + std::to_string(v.idx());
    if (a.halfedge_handle(v) != b.halfedge_handle(w))
      return "outgoing half-edge of vertex " + std::to_string(v.idx());
  }
  for (auto h : a.halfedges()) {
    const auto g = b.halfedge_handle(unsigned(h.idx()));
    const std::string at = " of half-edge " + std::to_string(h.idx());
    if (a.to_vertex_handle(h) != b.to_vertex_handle(g)) return "vertex" + at;
    if (a.face_handle(h) != b.face_handle(g)) return "face" + at;
    if (a.next_halfedge_handle(h) != b.next_halfedge_handle(g)) return "next" + at;
    if (a.prev_halfedge_handle(h) != b.prev_halfedge_handle(g)) return "previous" + at;
  }
  for (auto f : a.faces())
    if (a.halfedge_handle(f) != b.halfedge_handle(b.face_handle(unsigned(f.idx()))))
      return "half-edge of face " + std::to_string(f.idx());
  return "";
}

void checkSame(const Soup& s) {
  TriMesh expected;
  REQUIRE(incremental(s, expected));
  const auto built = buildOrientedManifold(s.points, s.triangles);
  REQUIRE(built);
  CHECK(difference(expected, *built) == "");
}

}  // namespace

TEST_CASE("one-pass half-edges equal OpenMesh's add_face on manifold meshes", "[mesh][halfedges]") {
  SECTION("closed, with boundary, planar, several boundary loops") {
    for (const Mesh& mesh :
         {makeSphere(1.0, 24, 12), makeRectangle(2.0, 1.0, 9, 5), makeDisc(1.0, 6),
          makeCylinder(0.5, 2.0, 16, 7), makeUShape(1.0, 0.5, 2.0, 4)}) {
      INFO(mesh.numVertices() << " vertices");
      checkSame(soupOf(mesh));
    }
  }
  SECTION("triangles in any order: vertices with several gaps while they fill") {
    std::mt19937 rng(7);
    for (const Mesh& mesh :
         {makeSphere(1.0, 16, 9), makeRectangle(1.0, 1.0, 6, 6), makeCylinder(0.5, 2.0, 10, 5)}) {
      Soup s = soupOf(mesh);
      for (int round = 0; round < 20; ++round) {
        std::shuffle(s.triangles.begin(), s.triangles.end(), rng);
        for (auto& t : s.triangles)  // each triangle from another corner
          std::rotate(t.begin(), t.begin() + std::uniform_int_distribution<int>(0, 2)(rng),
                      t.end());
        INFO("round " << round);
        checkSame(s);
      }
    }
  }
  SECTION("a vertex of high valence: a closed and an open fan") {
    for (const bool closed : {true, false}) {
      const int k = 500;
      Soup s;
      s.points.emplace_back(0, 0, 0);
      for (int i = 0; i < k; ++i)
        s.points.emplace_back(std::cos(6.283185307179586 * i / k),
                              std::sin(6.283185307179586 * i / k), 0.0);
      for (int i = 0; i < (closed ? k : k - 1); ++i)
        s.triangles.push_back({0, 1 + i, 1 + (i + 1) % k});
      INFO((closed ? "closed" : "open"));
      checkSame(s);
    }
  }
  SECTION("an unreferenced vertex keeps no half-edge") {
    Soup s = soupOf(makeRectangle(1.0, 1.0, 2, 2));
    s.points.insert(s.points.begin() + 3, Eigen::Vector3d(5, 5, 0));
    for (auto& t : s.triangles)
      for (int& v : t) v += v >= 3 ? 1 : 0;
    checkSame(s);
  }
}

TEST_CASE("one-pass half-edges decline what is not an oriented manifold", "[mesh][halfedges]") {
  const std::vector<Eigen::Vector3d> points = {{0, 0, 0},  {1, 0, 0}, {0, 1, 0}, {-1, 0, 0},
                                               {0, -1, 0}, {1, 1, 1}, {0, 0, 1}};
  using T = std::vector<std::array<int, 3>>;
  // Two triangles meeting at a vertex only (a vertex with two gaps).
  CHECK_FALSE(buildOrientedManifold(points, T{{0, 1, 2}, {0, 3, 4}}));
  // A flipped neighbour: the shared edge twice in one direction.
  CHECK_FALSE(buildOrientedManifold(points, T{{0, 1, 2}, {0, 1, 4}}));
  // Three triangles on one edge.
  CHECK_FALSE(buildOrientedManifold(points, T{{0, 1, 2}, {1, 0, 4}, {1, 0, 6}}));
  // The same triangle twice.
  CHECK_FALSE(buildOrientedManifold(points, T{{0, 1, 2}, {0, 1, 2}}));
  // Two closed fans (tetrahedra) sharing a vertex.
  const std::vector<Eigen::Vector3d> cones = {{0, 0, 0},  {1, 0, 0},  {0, 1, 0}, {0, 0, 1},
                                              {-1, 0, 0}, {0, -1, 0}, {0, 0, -1}};
  T twoCones = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3},
                {0, 4, 5}, {0, 6, 4}, {0, 5, 6}, {4, 6, 5}};
  CHECK(buildOrientedManifold(cones, T(twoCones.begin(), twoCones.begin() + 4)));
  CHECK_FALSE(buildOrientedManifold(cones, twoCones));
  CHECK_FALSE(buildOrientedManifold(points, T{}));
}

TEST_CASE("a triangle mesh in one pass or face by face, naming the face add_face refuses",
          "[mesh][halfedges]") {
  const std::vector<Eigen::Vector3d> points = {{0, 0, 0},  {1, 0, 0}, {0, 1, 0}, {-1, 0, 0},
                                               {0, -1, 0}, {1, 1, 1}, {0, 0, 1}};
  using T = std::vector<std::array<int, 3>>;
  // A manifold, and two triangles meeting at a vertex only (no one-pass structure, but
  // add_face takes them): both what add_face builds.
  for (const T& triangles : {T{{0, 1, 2}, {0, 2, 3}, {0, 3, 4}}, T{{0, 1, 2}, {0, 3, 4}}}) {
    std::ptrdiff_t refused = 7;
    const auto built = buildTriangleMesh(points, triangles, refused);
    REQUIRE(built);
    CHECK(refused == -1);
    TriMesh expected;
    REQUIRE(incremental({points, triangles}, expected));
    CHECK(difference(expected, *built) == "");
  }
  // Refused: a flipped neighbour, a third triangle on an edge, a repeated vertex (after a
  // face that is fine, and before one add_face would refuse).
  const std::vector<std::pair<T, std::ptrdiff_t>> refusals = {
      {T{{0, 1, 2}, {0, 2, 3}, {0, 1, 4}}, 2},
      {T{{0, 1, 2}, {1, 0, 4}, {1, 0, 6}}, 2},
      {T{{0, 1, 2}, {2, 5, 2}, {0, 1, 4}}, 1},
  };
  for (const auto& [triangles, face] : refusals) {
    std::ptrdiff_t refused = -1;
    CHECK_FALSE(buildTriangleMesh(points, triangles, refused));
    CHECK(refused == face);
  }
}

TEST_CASE("one-pass half-edges of the shared surface and planar meshes", "[mesh][halfedges]") {
  const fs::path dir = DIFFREG_SHARED_MESHES;
  if (!fs::exists(dir)) {
    WARN("shared meshes not found at " << dir << "; skipping");
    return;
  }
  for (const char* name : {"planar-woody.obj", "planar-crocodile.obj", "surface-fertility.off",
                           "surface-rocker-arm.obj", "surface-beetle-20k.off"}) {
    const fs::path p = dir / name;
    if (!fs::exists(p)) continue;
    INFO(name);
    const std::string text = readFileLimited(p.string(), "mesh file", limits::meshBytes);
    const RawMesh raw =
        p.extension() == ".obj" ? parseObj(text, p.string()) : parseOff(text, p.string());
    Soup s{raw.points, {}};
    for (const RawFace& f : raw.faces)
      s.triangles.push_back({int(f.ids[0]), int(f.ids[1]), int(f.ids[2])});
    checkSame(s);
  }
}
