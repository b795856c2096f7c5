// The elements' storage order (element_order.h): Discretization::withElementOrder keeps every
// per-element quantity with its element and every facet between the same elements, and the
// Morton order brings a scrambled mesh's neighbours back together.
#include <diffreg/discretization/element_order.h>

#include <diffreg/core/error.h>
#include <diffreg/mesh/shapes.h>

#include <catch2/catch.hpp>

#include <algorithm>
#include <numeric>
#include <random>
#include <set>

using namespace diffreg;

namespace {

// `mesh`'s elements in a random order (a mesh written with no spatial order).
Discretization scrambled(const Mesh& mesh, unsigned seed) {
  Eigen::MatrixXi elements = mesh.elements();
  std::vector<int> order(static_cast<size_t>(elements.rows()));
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), std::mt19937(seed));
  Eigen::MatrixXi shuffled(elements.rows(), elements.cols());
  for (size_t i = 0; i < order.size(); ++i)
    shuffled.row(static_cast<Eigen::Index>(i)) = elements.row(order[i]);
  return Discretization(mesh.kind(), mesh.positions(), shuffled);
}

std::vector<Mesh> meshes() {
  return {makeRectangle(2.0, 1.0, 60, 30), makeSphere(1.0, 48, 48),
          makeTetBox(3.0, 1.0, 1.0, 24, 8, 8)};
}

// The set of vertices of each facet, with the sets of vertices of its two elements.
std::multiset<std::vector<int>> facetRecords(const Discretization& d) {
  std::multiset<std::vector<int>> records;
  for (const Facet& f : d.facets()) {
    std::vector<int> r(f.vertices.begin(), f.vertices.begin() + f.size);
    std::sort(r.begin(), r.end());
    std::vector<int> a, b;
    for (int i = 0; i < d.elementSize(); ++i) {
      a.push_back(d.elements()(f.k, i));
      b.push_back(d.elements()(f.l, i));
    }
    std::sort(a.begin(), a.end());
    std::sort(b.begin(), b.end());
    if (b < a) std::swap(a, b);
    r.insert(r.end(), a.begin(), a.end());
    r.insert(r.end(), b.begin(), b.end());
    r.push_back(static_cast<int>(f.c * 1e9));
    records.insert(r);
  }
  return records;
}

}  // namespace

TEST_CASE("an element order keeps each element's quantities and each facet's elements",
          "[discretization][element_order]") {
  for (const Mesh& mesh : meshes()) {
    const Discretization d = scrambled(mesh, 7);
    INFO(toString(d.kind()));
    const std::vector<int> order = mortonElementOrder(d);
    const Discretization o = d.withElementOrder(order);
    REQUIRE(o.numElements() == d.numElements());
    for (int i = 0; i < o.numElements(); ++i) {
      const int e = order[static_cast<size_t>(i)];
      CHECK(o.elements().row(i) == d.elements().row(e));
      CHECK(o.measures()(i) == d.measures()(e));
      CHECK(o.gradient(i) == d.gradient(e));
      if (d.kind() == MeshKind::Surface) CHECK(o.normals().row(i) == d.normals().row(e));
    }
    CHECK(facetRecords(o) == facetRecords(d));
    CHECK(o.stiffness().isApprox(d.stiffness(), 0.0));
    CHECK(o.lumpedMass() == d.lumpedMass());
    CHECK(o.rest() == d.rest());
    CHECK(o.component() == d.component());
    CHECK(o.meanEdgeLength() == d.meanEdgeLength());
    CHECK_THROWS_AS(d.withElementOrder({0, 1}), InvalidParameter);
  }
}

TEST_CASE("the Morton order is a permutation that brings scrambled neighbours together",
          "[discretization][element_order]") {
  for (const Mesh& mesh : meshes()) {
    const Discretization d = scrambled(mesh, 11);
    INFO(toString(d.kind()));
    std::vector<int> order = mortonElementOrder(d);
    std::vector<int> sorted = order;
    std::sort(sorted.begin(), sorted.end());
    std::vector<int> all(static_cast<size_t>(d.numElements()));
    std::iota(all.begin(), all.end(), 0);
    CHECK(sorted == all);
    // Scrambled, nearly every facet is far; in Morton order few are.
    CHECK(farFacetShare(d) > 0.5);
    CHECK(farFacetShare(d.withElementOrder(order)) < 0.1);
  }
}

TEST_CASE("the locality order is taken only for large meshes whose neighbours are far apart",
          "[discretization][element_order]") {
  for (const Mesh& mesh : meshes()) {
    const Discretization d(mesh);
    INFO(toString(d.kind()));
    REQUIRE(d.numElements() >= kLocalityMinElements);
    CHECK(farFacetShare(d) <= kLocalityFarShare);  // generated in rows: kept
    CHECK(localityElementOrder(d).empty());
    CHECK(localityElementOrder(scrambled(mesh, 3)) == mortonElementOrder(scrambled(mesh, 3)));
  }
  const Mesh small = makeSphere(1.0, 16, 16);
  REQUIRE(Discretization(small).numElements() < kLocalityMinElements);
  CHECK(localityElementOrder(scrambled(small, 3)).empty());
}
