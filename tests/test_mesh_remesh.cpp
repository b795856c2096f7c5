// Mesh edits for the paper's experiments: random edge flips (Fig. 8) and subdivision (Fig. 9).
#include <diffreg/core/error.h>
#include <diffreg/mesh/remesh.h>
#include <diffreg/mesh/shapes.h>

#include <catch2/catch.hpp>

#include <Eigen/Geometry>

#include <cmath>
#include <vector>

using namespace diffreg;

namespace {

int interiorEdges(const Mesh& mesh) {
  int count = 0;
  for (auto e : mesh.tri().edges()) count += mesh.tri().is_boundary(e) ? 0 : 1;
  return count;
}

Eigen::Vector3d cross(const Mesh& mesh, int face) {
  const Eigen::MatrixXd p = mesh.positions();
  const Eigen::MatrixXi f = mesh.elements();
  const Eigen::Vector3d a = p.row(f(face, 0)), b = p.row(f(face, 1)), c = p.row(f(face, 2));
  return (b - a).cross(c - a);
}

double totalArea(const Mesh& mesh) {
  double area = 0.0;
  for (int k = 0; k < mesh.numElements(); ++k) area += 0.5 * cross(mesh, k).norm();
  return area;
}

int euler(const Mesh& mesh) {
  const TriMesh& t = mesh.tri();
  return int(t.n_vertices()) - int(t.n_edges()) + int(t.n_faces());
}

}  // namespace

TEST_CASE("flipEdges flips the requested fraction, deterministically, without folding",
          "[mesh][edit]") {
  const Mesh rest = makeDisc(1.0, 8);
  Mesh mesh = rest;
  mesh.setVertexScalar("w", rest.positions().col(0));
  mesh.setElementScalar("e", Eigen::VectorXd::Ones(rest.numElements()));
  const int interior = interiorEdges(rest);
  for (int k = 0; k < rest.numElements(); ++k) REQUIRE(cross(rest, k).z() > 0.0);

  const int flipped = flipEdges(mesh, 0.3, 42);
  const int target = int(std::lround(0.3 * interior));
  CHECK(flipped <= target);
  CHECK(flipped >= int(0.9 * target));  // most edges of a disc qualify
  CHECK(mesh.kind() == MeshKind::Planar);
  CHECK(interiorEdges(mesh) == interior);
  // Positions, ids and vertex properties unchanged; element properties dropped.
  CHECK(mesh.positions() == rest.positions());
  CHECK(mesh.vertexScalar("w") == rest.positions().col(0));
  CHECK_FALSE(mesh.hasElementScalar("e"));
  // All triangles stay counter-clockwise and cover the same area.
  for (int k = 0; k < mesh.numElements(); ++k) CHECK(cross(mesh, k).z() > 0.0);
  CHECK(totalArea(mesh) == Approx(totalArea(rest)).epsilon(1e-12));
  // The triangulation did change, by exactly the flips made.
  int changed = 0;
  const Eigen::MatrixXi before = rest.elements(), after = mesh.elements();
  for (int k = 0; k < mesh.numElements(); ++k) changed += before.row(k) != after.row(k);
  CHECK(changed > 0);

  SECTION("the same seed gives the same mesh, another seed another") {
    Mesh again = rest, other = rest;
    CHECK(flipEdges(again, 0.3, 42) == flipped);
    CHECK(again.elements() == mesh.elements());
    flipEdges(other, 0.3, 7);
    CHECK(other.elements() != mesh.elements());
  }
  SECTION("fraction 0 changes nothing") {
    Mesh same = rest;
    CHECK(flipEdges(same, 0.0, 1) == 0);
    CHECK(same.elements() == rest.elements());
  }
}

TEST_CASE("flipEdges never makes degenerate triangles on a cell mesh", "[mesh][edit]") {
  // Each cell is cut into 4 triangles around its centre; flipping a centre-corner edge would
  // put the centre on the new edge, so only the cell sides may flip.
  Mesh mesh = makeRectangle(4, 3, 8, 6);
  const double area = totalArea(mesh);
  const int flipped = flipEdges(mesh, 1.0, 3);
  CHECK(flipped > 0);
  CHECK(flipped < interiorEdges(mesh));
  for (int k = 0; k < mesh.numElements(); ++k) {
    const Eigen::Vector3d c = cross(mesh, k);
    CHECK(c.z() > 0.0);
    CHECK(c.z() > 0.02 * 0.25);  // twice the area, against (longest edge)^2 <= 0.25
  }
  CHECK(totalArea(mesh) == Approx(area).epsilon(1e-12));
}

TEST_CASE("flipEdges keeps the shape of a surface", "[mesh][edit]") {
  SECTION("a finely divided cylinder (dihedral angles of 11.25 degrees) gets flips") {
    const Mesh rest = makeCylinder(1.0, 2.0, 32, 8);
    Mesh mesh = rest;
    const int flipped = flipEdges(mesh, 0.3, 5);
    CHECK(flipped > 0);
    CHECK(mesh.kind() == MeshKind::Surface);
    CHECK(euler(mesh) == euler(rest));
    // Every face still faces the same way as before (outward or inward, like the rest mesh).
    const Eigen::MatrixXd p = mesh.positions();
    const Eigen::MatrixXi f = mesh.elements();
    const double side = [&] {
      const Eigen::MatrixXi f0 = rest.elements();
      const Eigen::Vector3d c = (rest.positions().row(f0(0, 0)) + rest.positions().row(f0(0, 1)) +
                                 rest.positions().row(f0(0, 2))) /
                                3.0;
      return cross(rest, 0).dot(Eigen::Vector3d(c.x(), c.y(), 0)) > 0 ? 1.0 : -1.0;
    }();
    for (int k = 0; k < mesh.numElements(); ++k) {
      const Eigen::Vector3d c = (p.row(f(k, 0)) + p.row(f(k, 1)) + p.row(f(k, 2))) / 3.0;
      const Eigen::Vector3d radial(c.x(), c.y(), 0.0);
      CHECK(side * cross(mesh, k).normalized().dot(radial.normalized()) > std::cos(0.6));
    }
    CHECK(totalArea(mesh) == Approx(totalArea(rest)).epsilon(0.01));
  }
  SECTION("an octahedron (neighbouring normals 70.5 degrees apart) is left alone") {
    const Mesh rest = makeSphere(1.0, 4, 2);
    REQUIRE(rest.numElements() == 8);
    Mesh mesh = rest;
    CHECK(flipEdges(mesh, 1.0, 5) == 0);
    CHECK(mesh.elements() == rest.elements());
  }
}

TEST_CASE("flipEdges rejects tets and bad fractions", "[mesh][edit]") {
  Mesh tet = makeTetBox(1, 1, 1, 2, 2, 2);
  CHECK_THROWS_AS(flipEdges(tet, 0.3, 1), InvalidParameter);
  Mesh tri = makeRectangle(1, 1, 2, 2);
  CHECK_THROWS_AS(flipEdges(tri, 1.5, 1), InvalidParameter);
  CHECK_THROWS_AS(flipEdges(tri, -0.1, 1), InvalidParameter);
  CHECK_THROWS_AS(flipEdges(tri, std::nan(""), 1), InvalidParameter);
}

TEST_CASE("midpoint subdivision is 1-to-4, keeps old vertices, area and flatness", "[mesh][edit]") {
  const Mesh rest = makeLShape(2.0, 1.0, 3);
  Mesh mesh = rest;
  const Eigen::MatrixXd p0 = rest.positions();
  const Eigen::VectorXd linear =
      p0.col(0) * 2.0 - p0.col(1) + Eigen::VectorXd::Constant(p0.rows(), 0.5);
  mesh.setVertexScalar("f", linear);
  mesh.setElementScalar("e", Eigen::VectorXd::Ones(rest.numElements()));
  const int n = rest.numVertices();
  const int edges = int(rest.tri().n_edges());

  subdivide(mesh, 1, "midpoint");
  CHECK(mesh.numElements() == 4 * rest.numElements());
  CHECK(mesh.numVertices() == n + edges);
  CHECK(mesh.kind() == MeshKind::Planar);
  CHECK(euler(mesh) == euler(rest));
  CHECK(mesh.positions().topRows(n) == p0);
  CHECK(totalArea(mesh) == Approx(totalArea(rest)).epsilon(1e-12));
  for (int k = 0; k < mesh.numElements(); ++k) CHECK(cross(mesh, k).z() > 0.0);
  // Each new vertex is the midpoint of an old edge; a linear vertex field stays exact.
  const Eigen::MatrixXd p = mesh.positions();
  const Eigen::VectorXd f = mesh.vertexScalar("f");
  for (int v = 0; v < mesh.numVertices(); ++v)
    CHECK(f[v] == Approx(2.0 * p(v, 0) - p(v, 1) + 0.5).margin(1e-12));
  CHECK_FALSE(mesh.hasElementScalar("e"));

  subdivide(mesh, 1, "midpoint");
  CHECK(mesh.numElements() == 16 * rest.numElements());
  CHECK(mesh.positions().topRows(n) == p0);
  CHECK(totalArea(mesh) == Approx(totalArea(rest)).epsilon(1e-12));
  CHECK(euler(mesh) == euler(rest));

  Mesh twice = rest;
  subdivide(twice, 2, "midpoint");
  CHECK(twice.positions() == mesh.positions());
  CHECK(twice.elements() == mesh.elements());
}

TEST_CASE("Loop subdivision keeps the ids and valences of the old vertices", "[mesh][edit]") {
  const Mesh rest = makeSphere(1.0, 12, 8);
  Mesh mesh = rest;
  const int n = rest.numVertices();
  subdivide(mesh, 1, "loop");
  CHECK(mesh.numElements() == 4 * rest.numElements());
  CHECK(mesh.numVertices() == n + int(rest.tri().n_edges()));
  CHECK(euler(mesh) == 2);
  const Eigen::MatrixXd p0 = rest.positions(), p = mesh.positions();
  for (int v = 0; v < n; ++v) {
    const auto a = rest.tri().vertex_handle(v), b = mesh.tri().vertex_handle(v);
    CHECK(mesh.tri().valence(b) == rest.tri().valence(a));
    CHECK((p.row(v) - p0.row(v)).norm() < 0.2);  // smoothed, but near where it was
  }
  // Loop smoothing shrinks a convex shape slightly, never grows it.
  for (int v = 0; v < mesh.numVertices(); ++v) CHECK(p.row(v).norm() <= 1.0 + 1e-12);

  Mesh flat = makeRectangle(2, 1, 4, 2);
  subdivide(flat, 2, "loop");
  CHECK(flat.kind() == MeshKind::Planar);
  CHECK(flat.numElements() == 16 * makeRectangle(2, 1, 4, 2).numElements());
}

TEST_CASE("subdivide rejects tets, bad schemes and counts", "[mesh][edit]") {
  Mesh tet = makeTetBox(1, 1, 1, 1, 1, 1);
  CHECK_THROWS_AS(subdivide(tet, 1, "midpoint"), InvalidParameter);
  Mesh tri = makeRectangle(1, 1, 1, 1);
  CHECK_THROWS_WITH(subdivide(tri, 1, "butterfly"),
                    Catch::Contains("butterfly") && Catch::Contains("midpoint, loop"));
  CHECK_THROWS_AS(subdivide(tri, -1, "loop"), InvalidParameter);
  Mesh same = tri;
  subdivide(same, 0, "loop");
  CHECK(same.elements() == tri.elements());
}
