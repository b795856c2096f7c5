// Mesh: kinds, positions, elements and named scalar properties (modules/mesh/mesh.h).

#include <diffreg/core/error.h>
#include <diffreg/mesh/mesh.h>

#include <catch2/catch.hpp>

#include <vector>

using namespace diffreg;

namespace {

/// Two triangles over the unit square at height z (plus a per-vertex z offset).
TriMesh square(double z, const Eigen::Vector4d& dz = Eigen::Vector4d::Zero()) {
  TriMesh m;
  const double xy[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  std::vector<TriMesh::VertexHandle> v;
  for (int i = 0; i < 4; ++i) v.push_back(m.add_vertex({xy[i][0], xy[i][1], z + dz[i]}));
  m.add_face(v[0], v[1], v[2]);
  m.add_face(v[0], v[2], v[3]);
  return m;
}

TetMesh twoTets() {
  TetMesh t;
  t.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}, {5, 5, 5}};
  t.tets = {{0, 1, 2, 3}, {1, 4, 2, 3}};
  return t;
}

}  // namespace

TEST_CASE("kind: planar iff all z are equal (to 1e-12 of the bounding box)", "[mesh]") {
  CHECK(Mesh(square(2.5)).kind() == MeshKind::Planar);
  CHECK(Mesh(square(0.0, Eigen::Vector4d(0, 1e-14, 0, 0))).kind() == MeshKind::Planar);
  CHECK(Mesh(square(0.0, Eigen::Vector4d(0, 1e-9, 0, 0))).kind() == MeshKind::Surface);
  CHECK(Mesh(square(0.0, Eigen::Vector4d(0, 0, 0.5, 0))).kind() == MeshKind::Surface);
  const Mesh tet(twoTets());
  CHECK(tet.kind() == MeshKind::Tet);
  CHECK(tet.isTet());
  CHECK(std::string(toString(MeshKind::Planar)) == "planar");
  CHECK(std::string(toString(MeshKind::Surface)) == "surface");
  CHECK(std::string(toString(MeshKind::Tet)) == "tet");
}

TEST_CASE("positions, elements and referenced vertices", "[mesh]") {
  Mesh tri(square(2.0));
  CHECK(tri.numVertices() == 4);
  CHECK(tri.numElements() == 2);
  CHECK(tri.elementSize() == 3);
  const Eigen::MatrixXi e = tri.elements();
  REQUIRE(e.rows() == 2);
  // Each face lists its vertices in the order given (up to a cyclic shift).
  for (int k = 0; k < 2; ++k) {
    const Eigen::Vector3i expect = k == 0 ? Eigen::Vector3i(0, 1, 2) : Eigen::Vector3i(0, 2, 3);
    bool match = false;
    for (int s = 0; s < 3; ++s)
      match = match || (e(k, s) == expect[0] && e(k, (s + 1) % 3) == expect[1] &&
                        e(k, (s + 2) % 3) == expect[2]);
    CHECK(match);
  }

  SECTION("n x 2 positions keep the planar z") {
    Eigen::MatrixXd xy(4, 2);
    xy << 0, 0, 2, 0, 2, 2, 0, 2;
    tri.setPositions(xy);
    const Eigen::MatrixXd p = tri.positions();
    CHECK(p.col(2).isConstant(2.0));
    CHECK(p.leftCols(2) == xy);
  }
  SECTION("n x 3 positions") {
    Eigen::MatrixXd p = tri.positions();
    p.col(0) *= 3.0;
    tri.setPositions(p);
    CHECK(tri.positions() == p);
    const TriMesh::Point q = tri.tri().point(tri.tri().vertex_handle(1));
    CHECK(q[0] == 3.0);
  }
  SECTION("wrong shape or non-finite positions") {
    CHECK_THROWS_AS(tri.setPositions(Eigen::MatrixXd::Zero(3, 3)), InvalidParameter);
    CHECK_THROWS_AS(tri.setPositions(Eigen::MatrixXd::Zero(4, 1)), InvalidParameter);
    Eigen::MatrixXd p = tri.positions();
    p(1, 1) = NAN;
    CHECK_THROWS_AS(tri.setPositions(p), InvalidParameter);
    Mesh surf(square(0.0, Eigen::Vector4d(0, 0, 1, 0)));
    CHECK_THROWS_AS(surf.setPositions(Eigen::MatrixXd::Zero(4, 2)), InvalidParameter);
  }
  SECTION("tets and an unreferenced vertex") {
    Mesh tet(twoTets());
    CHECK(tet.numVertices() == 6);
    CHECK(tet.numElements() == 2);
    CHECK(tet.elementSize() == 4);
    CHECK(tet.elements().row(1) == Eigen::RowVector4i(1, 4, 2, 3));
    CHECK(tet.referenced() == std::vector<bool>{true, true, true, true, true, false});
    Eigen::MatrixXd p = tet.positions();
    p.array() += 1.0;
    tet.setPositions(p);
    CHECK(tet.tet().points[5] == Eigen::Vector3d(6, 6, 6));
  }
}

TEST_CASE("points: the positions without a copy, for every kind", "[mesh]") {
  const Eigen::Vector4d dz(0.0, 0.5, -0.25, 1.0);
  for (Mesh mesh : {Mesh(square(2.0)), Mesh(square(0.0, dz)), Mesh(twoTets())}) {
    INFO(toString(mesh.kind()));
    const Mesh::PointRows p = mesh.points();
    REQUIRE(p.rows() == mesh.numVertices());
    CHECK(Eigen::MatrixXd(p) == mesh.positions());
    // A view of the mesh's own storage: it follows new positions.
    Eigen::MatrixXd moved = mesh.positions();
    moved.col(0).array() += 3.0;
    mesh.setPositions(moved);
    CHECK(Eigen::MatrixXd(p) == moved);
  }
  CHECK(Mesh().points().rows() == 0);
  CHECK(Mesh(TetMesh{}).points().rows() == 0);
}

TEST_CASE("scalar properties live on the OpenMesh mesh and survive copies", "[mesh]") {
  Mesh mesh(square(0.0));
  CHECK_FALSE(mesh.hasVertexScalar(prop::weight));
  CHECK_THROWS_AS(mesh.vertexScalar(prop::weight), MissingProperty);
  CHECK_THROWS_AS(mesh.elementScalar(prop::distortion), MissingProperty);

  const Eigen::Vector4d w(0.1, 0.2, 0.3, 0.4);
  mesh.setVertexScalar(prop::weight, w);
  mesh.setElementScalar(prop::distortion, Eigen::Vector2d(1.0, 2.0));
  CHECK(mesh.vertexScalar(prop::weight) == w);
  CHECK(mesh.elementScalar(prop::distortion) == Eigen::Vector2d(1.0, 2.0));
  CHECK(mesh.vertexScalarNames() == std::vector<std::string>{prop::weight});
  CHECK(mesh.elementScalarNames() == std::vector<std::string>{prop::distortion});

  // OpenMesh code sees them as double properties with the same names.
  OpenMesh::VPropHandleT<double> vh;
  OpenMesh::FPropHandleT<double> fh;
  REQUIRE(mesh.tri().get_property_handle(vh, prop::weight));
  REQUIRE(mesh.tri().get_property_handle(fh, prop::distortion));
  CHECK(mesh.tri().property(vh, mesh.tri().vertex_handle(2)) == 0.3);
  CHECK(mesh.tri().property(fh, mesh.tri().face_handle(1)) == 2.0);

  // A copy carries the values and is independent.
  Mesh copy = mesh;
  copy.setVertexScalar(prop::weight, Eigen::Vector4d::Zero());
  CHECK(copy.hasElementScalar(prop::distortion));
  CHECK(mesh.vertexScalar(prop::weight) == w);
  CHECK(copy.vertexScalar(prop::weight).isZero());

  // A Mesh wrapped around an OpenMesh mesh finds its double properties.
  const Mesh wrapped(mesh.tri());
  CHECK(wrapped.vertexScalarNames() == std::vector<std::string>{prop::weight});
  CHECK(wrapped.vertexScalar(prop::weight) == w);

  SECTION("size mismatch") {
    CHECK_THROWS_AS(mesh.setVertexScalar("x", Eigen::VectorXd::Zero(3)), InvalidParameter);
    CHECK_THROWS_AS(mesh.setElementScalar("x", Eigen::VectorXd::Zero(4)), InvalidParameter);
    CHECK_FALSE(mesh.hasVertexScalar("x"));
  }
}

TEST_CASE("tet meshes keep their properties in the Mesh", "[mesh]") {
  Mesh tet(twoTets());
  tet.setVertexScalar(prop::weight, Eigen::VectorXd::LinSpaced(6, 0, 1));
  tet.setElementScalar(prop::smoothness, Eigen::Vector2d(3, 4));
  CHECK(tet.hasVertexScalar(prop::weight));
  CHECK_FALSE(tet.hasVertexScalar(prop::smoothness));
  CHECK(tet.hasElementScalar(prop::smoothness));
  CHECK(tet.elementScalar(prop::smoothness) == Eigen::Vector2d(3, 4));
  const Mesh copy = tet;
  CHECK(copy.vertexScalar(prop::weight) == Eigen::VectorXd::LinSpaced(6, 0, 1));
  CHECK_THROWS_AS(tet.setVertexScalar("w", Eigen::VectorXd::Zero(5)), InvalidParameter);
  CHECK_THROWS_AS(tet.vertexScalar("none"), MissingProperty);
}

TEST_CASE("a Mesh moves its OpenMesh mesh without a copy and copies it deeply", "[mesh]") {
  Mesh a(square(0.0));
  a.setVertexScalar("w", Eigen::Vector4d(1, 2, 3, 4));
  const TriMesh* held = &a.tri();
  Mesh b = std::move(a);
  CHECK(&b.tri() == held);  // the same OpenMesh mesh, moved by pointer
  CHECK(b.numVertices() == 4);
  CHECK(b.vertexScalar("w") == Eigen::Vector4d(1, 2, 3, 4));
  CHECK(a.tri().n_vertices() == 0);  // moved from: an empty, usable mesh

  Mesh c = b;  // deep: its own OpenMesh mesh and properties
  CHECK(&c.tri() != &b.tri());
  c.setVertexScalar("w", Eigen::Vector4d::Zero());
  Eigen::MatrixXd p = c.positions();
  p(0, 0) = 7.0;
  c.setPositions(p);
  CHECK(b.vertexScalar("w") == Eigen::Vector4d(1, 2, 3, 4));
  CHECK(b.positions()(0, 0) == 0.0);

  Mesh d(std::make_unique<TriMesh>(square(1.0)));  // taken over
  CHECK(d.numElements() == 2);
  CHECK(Mesh(std::unique_ptr<TriMesh>()).numVertices() == 0);

  // Move assignment leaves an empty mesh that can be written to and assigned again.
  Mesh e(square(2.0));
  e = std::move(d);
  CHECK(e.numElements() == 2);
  const Mesh& readOnly = d;
  CHECK(readOnly.numVertices() == 0);
  CHECK(readOnly.tri().n_faces() == 0);
  CHECK(d.tri().add_vertex(TriMesh::Point(0, 0, 0)).idx() == 0);  // its own, new mesh
  CHECK(d.numVertices() == 1);
  CHECK(Mesh().numVertices() == 0);
  d = e;
  CHECK(d.numElements() == 2);
  CHECK(&d.tri() != &e.tri());
}

TEST_CASE("a growing vector of meshes moves them instead of copying", "[mesh]") {
  std::vector<Mesh> meshes;
  meshes.reserve(1);
  meshes.emplace_back(square(0.0));
  const TriMesh* first = &meshes[0].tri();
  for (int i = 1; i < 9; ++i) meshes.emplace_back(square(i));  // reallocates a few times
  CHECK(&meshes[0].tri() == first);
  CHECK(meshes[0].numVertices() == 4);
}
