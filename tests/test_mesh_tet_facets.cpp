// sortedTetFacets (modules/mesh/tet_facets.h) and the boundary built on it
// (modules/mesh/boundary.h).
#include <diffreg/core/error.h>
#include <diffreg/mesh/boundary.h>
#include <diffreg/mesh/shapes.h>
#include <diffreg/mesh/tet_facets.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <catch2/catch.hpp>
#include <map>
#include <set>

using namespace diffreg;

TEST_CASE("sortedTetFacets: every facet once, in the order of one sort of them all", "[mesh]") {
  const Mesh box = makeTetBox(1, 1, 1, 3, 2, 2);
  const TetMesh& tet = box.tet();
  const int tets = static_cast<int>(tet.tets.size());
  const std::vector<TetFacet> facets =
      sortedTetFacets(tets, static_cast<int>(tet.points.size()),
                      [&tet](int k, int j) { return tet.tets[static_cast<size_t>(k)][j]; });
  REQUIRE(facets.size() == static_cast<size_t>(tets) * 4);
  std::vector<TetFacet> sorted = facets;
  std::sort(sorted.begin(), sorted.end());
  for (size_t i = 0; i < facets.size(); ++i) {
    CHECK(facets[i].key == sorted[i].key);
    CHECK(facets[i].tet == sorted[i].tet);
    CHECK(facets[i].opposite == sorted[i].opposite);
  }
  // Each facet is its tet's three other vertices, sorted.
  std::set<std::pair<int, int>> seen;
  for (const TetFacet& f : facets) {
    std::array<int, 3> key{};
    int c = 0;
    for (int j = 0; j < 4; ++j)
      if (j != f.opposite) key[static_cast<size_t>(c++)] = tet.tets[static_cast<size_t>(f.tet)][j];
    std::sort(key.begin(), key.end());
    CHECK(key == f.key);
    CHECK(seen.insert({f.tet, f.opposite}).second);
  }
  // A conforming mesh: every key is shared by one or two tets.
  std::map<std::array<int, 3>, int> count;
  for (const TetFacet& f : facets) ++count[f.key];
  for (const auto& [key, n] : count) CHECK((n == 1 || n == 2));
}

TEST_CASE("tetBoundary: the facets of one tet, outward, in key order", "[mesh]") {
  const Mesh box = makeTetBox(2, 1, 1, 4, 2, 2);
  const BoundaryFaces boundary = tetBoundary(box.tet());
  // 2 x 1 x 1 box of 4 x 2 x 2 cells, two triangles per boundary square.
  CHECK(boundary.faces.size() == 2u * (4 * 2 + 4 * 2 + 2 * 2) * 2);
  REQUIRE(boundary.element.size() == boundary.faces.size());
  std::array<int, 3> previous{-1, -1, -1};
  const Eigen::Vector3d centre(1.0, 0.5, 0.5);
  for (size_t i = 0; i < boundary.faces.size(); ++i) {
    std::array<int, 3> key = boundary.faces[i];
    std::sort(key.begin(), key.end());
    CHECK(previous < key);
    previous = key;
    const auto& p = box.tet().points;
    const Eigen::Vector3d a = p[static_cast<size_t>(boundary.faces[i][0])],
                          b = p[static_cast<size_t>(boundary.faces[i][1])],
                          c = p[static_cast<size_t>(boundary.faces[i][2])];
    CHECK((b - a).cross(c - a).dot((a + b + c) / 3.0 - centre) > 0);
    // The face belongs to its tet.
    const auto& t = box.tet().tets[static_cast<size_t>(boundary.element[i])];
    for (int v : boundary.faces[i]) CHECK(std::find(t.begin(), t.end(), v) != t.end());
  }
}

TEST_CASE(
    "tetBoundary: a single tet is its own boundary; a vertex id outside the points is an "
    "error",
    "[mesh]") {
  TetMesh one;
  one.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  one.tets = {{0, 1, 2, 3}};
  CHECK(tetBoundary(one).faces.size() == 4u);
  one.tets = {{0, 1, -2, 3}};
  CHECK_THROWS_AS(tetBoundary(one), InvalidMesh);
  one.tets = {{0, 1, 2, 4}};
  CHECK_THROWS_AS(tetBoundary(one), InvalidMesh);
}
