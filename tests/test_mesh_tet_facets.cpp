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

using namespace diffreg;

TEST_CASE("sortedTetFacets: every facet once, in the order of one sort of them all", "[mesh]") {
  const Mesh box = makeTetBox(1, 1, 1, 3, 2, 2);
  const TetMesh& tet = box.tet();
  const int tets = static_cast<int>(tet.tets.size());
  // Brute force: every facet as (its sorted vertices, tet, opposite vertex, odd), and the
  // parity of sorting its outward order counted by inversions.
  struct Record {
    std::array<int, 3> key;
    int tet, opposite;
    bool odd;
  };
  std::vector<Record> expected;
  for (int k = 0; k < tets; ++k)
    for (int i = 0; i < 4; ++i) {
      std::array<int, 3> v{};
      for (int c = 0; c < 3; ++c)
        v[static_cast<size_t>(c)] = tet.tets[static_cast<size_t>(k)][kOutwardFacet[i][c]];
      const int inversions = int(v[0] > v[1]) + int(v[0] > v[2]) + int(v[1] > v[2]);
      std::array<int, 3> key = v;
      std::sort(key.begin(), key.end());
      expected.push_back({key, k, i, inversions % 2 == 1});
    }
  std::stable_sort(expected.begin(), expected.end(), [](const Record& a, const Record& b) {
    return a.key != b.key ? a.key < b.key : a.tet < b.tet;
  });
  std::vector<Record> listed;
  std::map<std::array<int, 3>, int> shared;
  forEachFacet(
      sortedTetFacets(tets, static_cast<int>(tet.points.size()),
                      [&tet](int k, int j) { return tet.tets[static_cast<size_t>(k)][j]; }),
      [&](const std::array<int, 3>& key, const TetFacet* first, int count) {
        shared[key] = count;
        for (int c = 0; c < count; ++c)
          listed.push_back({key, first[c].tet, first[c].opposite, first[c].odd});
      });
  REQUIRE(listed.size() == expected.size());
  for (size_t i = 0; i < listed.size(); ++i) {
    CHECK(listed[i].key == expected[i].key);
    CHECK(listed[i].tet == expected[i].tet);
    CHECK(listed[i].opposite == expected[i].opposite);
    CHECK(listed[i].odd == expected[i].odd);
  }
  // A conforming mesh: every facet is on one or two tets, and two tets on a facet lie on its
  // two sides.
  for (const auto& [key, n] : shared) CHECK((n == 1 || n == 2));
  for (size_t i = 0; i + 1 < listed.size(); ++i)
    if (listed[i].key == listed[i + 1].key) CHECK(listed[i].odd != listed[i + 1].odd);
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
