// Discretization (docs/method.md, "Discretization"): properties of K, M, G_e, a_e and the facet
// adjacency.
#include <diffreg/discretization/discretization.h>

#include <diffreg/core/error.h>
#include <diffreg/mesh/shapes.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <map>
#include <thread>
#include <vector>

using namespace diffreg;

namespace {

// Deformation gradient of the rest positions: sum_i x_i g_i^T over the element's vertices.
Eigen::MatrixXd restGradient(const Discretization& d, int e) {
  Eigen::MatrixXd F = Eigen::MatrixXd::Zero(d.dim(), d.dim());
  for (int i = 0; i < d.elementSize(); ++i)
    F += d.rest().row(d.elements()(e, i)).transpose() * d.gradient(e).row(i);
  return F;
}

std::vector<bool> boundaryVertices(const Discretization& d) {
  // A vertex is interior when every facet through it is shared: count facet incidences.
  std::vector<bool> boundary(d.numVertices(), false);
  std::map<std::vector<int>, int> count;
  const int k = d.elementSize();
  for (int e = 0; e < d.numElements(); ++e)
    for (int i = 0; i < k; ++i) {
      std::vector<int> f;
      for (int j = 0; j < k; ++j)
        if (j != i) f.push_back(d.elements()(e, j));
      std::sort(f.begin(), f.end());
      ++count[f];
    }
  for (const auto& [f, c] : count)
    if (c == 1)
      for (int v : f) boundary[v] = true;
  return boundary;
}

// Element e's terms of K, measure * g g^T for its hat gradients g (K x 3, zero third column
// on planar meshes), as (row, column, value) in row-major order.
template <int K>
void elementTerms(const Discretization& d, int e, std::vector<Eigen::Triplet<double>>& terms) {
  Eigen::Matrix<double, K, 3> g = Eigen::Matrix<double, K, 3>::Zero();
  g.leftCols(d.dim()) = d.gradient(e);
  const Eigen::Matrix<double, K, K> Ke = d.measures()(e) * g * g.transpose();
  for (int i = 0; i < K; ++i)
    for (int j = 0; j < K; ++j)
      terms.emplace_back(d.elements()(e, i), d.elements()(e, j), Ke(i, j));
}

}  // namespace

TEST_CASE("K annihilates constants and its rows sum to zero", "[discretization]") {
  for (const Mesh& mesh : {makeRectangle(3, 2, 6, 4), makeCylinder(1, 2, 12, 6),
                           makeSphere(1, 12, 8), makeTetBox(2, 1, 1, 4, 2, 2)}) {
    const Discretization d(mesh);
    const Eigen::VectorXd k1 = d.stiffness() * Eigen::VectorXd::Ones(d.numVertices());
    CHECK(k1.cwiseAbs().maxCoeff() < 1e-10);
    // Symmetric positive semidefinite: x^T K x >= 0 for a few random x.
    for (int trial = 0; trial < 5; ++trial) {
      const Eigen::VectorXd x = Eigen::VectorXd::Random(d.numVertices());
      CHECK(x.dot(d.stiffness() * x) >= -1e-10);
    }
    const SparseMatrix asym = SparseMatrix(d.stiffness().transpose()) - d.stiffness();
    CHECK(asym.norm() < 1e-12);
  }
}

TEST_CASE("K sums each element's terms in element order, into every pair of its vertices",
          "[discretization]") {
  // The assembly against setFromTriplets on the same terms, bit for bit, with the vertices
  // numbered out of order (a shuffled tet box), on a planar, a surface and a tet mesh.
  const Discretization box(makeTetBox(2, 1, 1, 4, 3, 2));
  const int n = box.numVertices();
  Eigen::MatrixXd P(n, 3);
  Eigen::MatrixXi T = box.elements();
  const auto to = [n](int v) { return (v * 37 + 11) % n; };  // 37 is coprime to n = 60
  for (int v = 0; v < n; ++v) P.row(to(v)) = box.rest().row(v);
  for (Eigen::Index e = 0; e < T.rows(); ++e)
    for (Eigen::Index i = 0; i < T.cols(); ++i) T(e, i) = to(T(e, i));
  std::vector<Discretization> meshes;
  meshes.emplace_back(makeRectangle(3, 2, 6, 4));
  meshes.emplace_back(makeSphere(1, 12, 8));
  meshes.emplace_back(MeshKind::Tet, P, T);
  for (const Discretization& d : meshes) {
    const int k = d.elementSize();
    std::vector<Eigen::Triplet<double>> terms;
    for (int e = 0; e < d.numElements(); ++e)
      if (k == 4)
        elementTerms<4>(d, e, terms);
      else
        elementTerms<3>(d, e, terms);
    SparseMatrix expected(d.numVertices(), d.numVertices());
    expected.setFromTriplets(terms.begin(), terms.end());
    expected.makeCompressed();
    const SparseMatrix& K = d.stiffness();
    REQUIRE(K.nonZeros() == expected.nonZeros());
    const Eigen::Index nnz = K.nonZeros();
    CHECK(std::equal(K.outerIndexPtr(), K.outerIndexPtr() + K.outerSize() + 1,
                     expected.outerIndexPtr()));
    CHECK(std::equal(K.innerIndexPtr(), K.innerIndexPtr() + nnz, expected.innerIndexPtr()));
    // Within a few ulps is not enough here: the same sums in the same order.
    CHECK(std::memcmp(K.valuePtr(), expected.valuePtr(), sizeof(double) * nnz) == 0);
  }
}

TEST_CASE("Tets: facets in the order of their sorted vertices, the mean over unique edges",
          "[discretization]") {
  const Discretization d(makeTetBox(2, 1, 1, 3, 2, 2));
  for (size_t f = 1; f < d.facets().size(); ++f)
    CHECK(d.facets()[f - 1].vertices < d.facets()[f].vertices);
  std::vector<std::pair<int, int>> edges;
  for (int e = 0; e < d.numElements(); ++e)
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) {
        const int a = d.elements()(e, i), b = d.elements()(e, j);
        edges.emplace_back(std::min(a, b), std::max(a, b));
      }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  double sum = 0.0;
  for (const auto& [a, b] : edges) sum += (d.rest().row(a) - d.rest().row(b)).norm();
  CHECK(d.meanEdgeLength() == sum / static_cast<double>(edges.size()));
}

TEST_CASE("K is assembled once, on first use, the same on every thread and in every copy",
          "[discretization]") {
  for (const Mesh& mesh :
       {makeRectangle(3, 2, 30, 20), makeSphere(1, 24, 16), makeTetBox(2, 1, 1, 8, 4, 4)}) {
    const Discretization d(mesh);
    const Discretization copy = d;  // before K exists
    std::vector<const SparseMatrix*> seen(4, nullptr);
    std::vector<std::thread> threads;
    for (size_t i = 0; i < seen.size(); ++i)
      threads.emplace_back([&, i] { seen[i] = &(i % 2 ? copy : d).stiffness(); });
    for (std::thread& t : threads) t.join();
    for (const SparseMatrix* K : seen) CHECK(K == &d.stiffness());
    // The same matrix as a discretization of the same mesh asked on one thread, bit for bit.
    const Discretization fresh(mesh);
    CHECK(d.stiffness().isApprox(fresh.stiffness(), 0.0));
    CHECK(d.stiffness().nonZeros() == fresh.stiffness().nonZeros());
    Discretization moved(mesh), to = std::move(moved);
    CHECK(moved.stiffness().nonZeros() == 0);  // moved from: empty, not a crash
    CHECK(to.stiffness().isApprox(fresh.stiffness(), 0.0));
  }
}

TEST_CASE("K reproduces linear functions at interior vertices", "[discretization]") {
  for (const Mesh& mesh :
       {makeRectangle(3, 2, 6, 4), makeDisc(1, 5), makeTetBox(2, 1, 1, 4, 2, 2)}) {
    const Discretization d(mesh);
    const std::vector<bool> boundary = boundaryVertices(d);
    Eigen::VectorXd f(d.numVertices());
    for (int v = 0; v < d.numVertices(); ++v)
      f(v) = 0.3 + 1.7 * d.rest()(v, 0) - 0.9 * d.rest()(v, 1) +
             (d.dim() == 3 ? 2.1 * d.rest()(v, 2) : 0.0);
    const Eigen::VectorXd Kf = d.stiffness() * f;
    int interior = 0;
    for (int v = 0; v < d.numVertices(); ++v)
      if (!boundary[v]) {
        ++interior;
        CHECK(std::abs(Kf(v)) < 1e-10);
      }
    CHECK(interior > 0);
  }
}

TEST_CASE("Element measures and lumped mass add up to the area or volume", "[discretization]") {
  const Discretization rect(makeRectangle(3, 2, 6, 4));
  CHECK(rect.measures().sum() == Approx(6.0).epsilon(1e-12));
  CHECK(rect.lumpedMass().sum() == Approx(6.0).epsilon(1e-12));
  const Discretization box(makeTetBox(2, 1, 0.5, 4, 2, 2));
  CHECK(box.measures().sum() == Approx(1.0).epsilon(1e-12));
  CHECK(box.lumpedMass().sum() == Approx(1.0).epsilon(1e-12));
  CHECK((box.measures().array() > 0).all());
  const Discretization cyl(makeCylinder(1, 2, 64, 8));
  // An inscribed 64-gon prism: lateral area 2 * 64 * sin(pi / 64) * height.
  CHECK(cyl.measures().sum() == Approx(2 * 64 * std::sin(M_PI / 64) * 2).epsilon(1e-10));
}

TEST_CASE("The rest deformation gradient is the identity or the tangent projector",
          "[discretization]") {
  for (const Mesh& mesh :
       {makeRectangle(3, 2, 3, 2), makeCylinder(1, 2, 10, 3), makeTetBox(1, 1, 1, 2, 2, 2)}) {
    const Discretization d(mesh);
    for (int e = 0; e < d.numElements(); ++e) {
      const Eigen::MatrixXd F = restGradient(d, e);
      CHECK((F - d.restFrame(e)).norm() < 1e-12);
    }
    if (d.kind() == MeshKind::Surface) {
      // Tangential gradients: orthogonal to the rest normal.
      for (int e = 0; e < d.numElements(); ++e)
        CHECK((d.gradient(e) * d.normals().row(e).transpose()).norm() < 1e-12);
    }
  }
}

TEST_CASE("K equals the textbook cotangent formula on a triangle pair", "[discretization]") {
  // Two triangles sharing edge (1, 2): 0 = (0,0), 1 = (2,0), 2 = (0.5,1.5), 3 = (2.5, 2).
  Eigen::MatrixXd P(4, 3);
  P << 0, 0, 0, 2, 0, 0, 0.5, 1.5, 0, 2.5, 2, 0;
  Eigen::MatrixXi F(2, 3);
  F << 0, 1, 2, 1, 3, 2;
  const Discretization d(MeshKind::Planar, P, F);
  auto cotAt = [&](int apex, int a, int b) {
    const Eigen::Vector3d u = (P.row(a) - P.row(apex)).transpose();
    const Eigen::Vector3d v = (P.row(b) - P.row(apex)).transpose();
    return u.dot(v) / u.cross(v).norm();
  };
  Eigen::Matrix4d expected = Eigen::Matrix4d::Zero();
  auto addEdge = [&](int i, int j, double w) {
    expected(i, j) -= w;
    expected(j, i) -= w;
    expected(i, i) += w;
    expected(j, j) += w;
  };
  addEdge(0, 1, 0.5 * cotAt(2, 0, 1));
  addEdge(0, 2, 0.5 * cotAt(1, 0, 2));
  addEdge(1, 2, 0.5 * (cotAt(0, 1, 2) + cotAt(3, 1, 2)));
  addEdge(1, 3, 0.5 * cotAt(2, 1, 3));
  addEdge(2, 3, 0.5 * cotAt(1, 2, 3));
  CHECK((Eigen::MatrixXd(d.stiffness()) - expected).norm() < 1e-12);
  REQUIRE(d.facets().size() == 1);
  CHECK(d.facets()[0].c == Approx((P.row(1) - P.row(2)).norm()));
  CHECK(d.facets()[0].size == 2);
}

TEST_CASE("Facets: interior edges for triangles, interior triangles for tets", "[discretization]") {
  const Discretization rect(makeRectangle(2, 1, 2, 1));
  // 2 cells x 4 triangles: 8 faces; edges: interior = (3 * 8 - boundary 6) / 2 = 9.
  CHECK(rect.facets().size() == 9);
  const Discretization box(makeTetBox(1, 1, 1, 1, 1, 1));
  // 6 tets in a cube: 24 facets, 12 on the boundary, so 6 interior triangles.
  REQUIRE(box.facets().size() == 6);
  for (const Facet& f : box.facets()) {
    CHECK(f.size == 3);
    CHECK(f.c > 0.0);
  }
}

TEST_CASE("Components, unreferenced vertices and unit lengths", "[discretization]") {
  Eigen::MatrixXd P(7, 3);
  P << 0, 0, 0, 1, 0, 0, 0, 1, 0, 5, 5, 0, 6, 5, 0, 5, 6, 0, 9, 9, 0;
  Eigen::MatrixXi F(2, 3);
  F << 0, 1, 2, 3, 4, 5;
  const Discretization d(MeshKind::Planar, P, F);
  CHECK(d.numComponents() == 2);
  CHECK(d.component()[0] != d.component()[3]);
  CHECK_FALSE(d.active()[6]);
  CHECK(d.component()[6] == -1);
  CHECK(d.meanEdgeLength() == Approx((2 + std::sqrt(2.0)) / 3));
  CHECK(d.boundingBoxDiagonal() == Approx(std::sqrt(2.0) * 6));
}

TEST_CASE("Degenerate elements are rejected, naming the element", "[discretization]") {
  Eigen::MatrixXd P(4, 3);
  P << 0, 0, 0, 1, 0, 0, 2, 0, 0, 0, 1, 0;
  Eigen::MatrixXi F(2, 3);
  F << 0, 1, 3, 2, 1, 0;  // the second has zero area
  CHECK_THROWS_AS(Discretization(MeshKind::Planar, P, F), InvalidMesh);
  CHECK_THROWS_WITH(Discretization(MeshKind::Planar, P, F),
                    Catch::Contains("triangle 1") && Catch::Contains("degenerate"));
  // Triangles that no oriented edge-manifold holds (edge 0-1 twice in the same direction)
  // are named, not merged.
  Eigen::MatrixXi twisted(2, 3);
  twisted << 0, 1, 3, 0, 1, 2;
  CHECK_THROWS_WITH(Discretization(MeshKind::Planar, P, twisted),
                    Catch::Contains("triangle 1") && Catch::Contains("edge-manifold"));
  Eigen::MatrixXi bad(1, 3);
  bad << 0, 1, 9;
  CHECK_THROWS_WITH(Discretization(MeshKind::Planar, P, bad), Catch::Contains("out of range"));
}

TEST_CASE("A planar discretization of points off their plane is refused, not flattened",
          "[discretization][hostile]") {
  Eigen::MatrixXd P(4, 3);
  P << 0, 0, 5, 1, 0, 5, 1, 1, 5, 0, 1, 5;
  Eigen::MatrixXi F(2, 3);
  F << 0, 1, 2, 0, 2, 3;
  // Any constant z, and 2 columns, are a plane.
  CHECK(Discretization(MeshKind::Planar, P, F).dim() == 2);
  CHECK(Discretization(MeshKind::Planar, P.leftCols(2), F).dim() == 2);
  P(2, 2) = 5.5;
  CHECK_THROWS_WITH(Discretization(MeshKind::Planar, P, F),
                    Catch::Contains("planar mesh lies in a plane z = const") &&
                        Catch::Contains("z spans 0.5") && Catch::Contains("as a surface"));
  CHECK(Discretization(MeshKind::Surface, P, F).dim() == 3);
  // Mesh and Discretization decide by the same points, the used ones: an unused vertex far
  // away does not make the used ones' z spread of 1e-11 look flat (it did, for both).
  Eigen::MatrixXd Q(5, 3);
  Q << 0, 0, 0, 1, 0, 0, 1, 1, 1e-11, 0, 1, 0, 1000, 0, 0;
  TriMesh tri;
  for (Eigen::Index i = 0; i < Q.rows(); ++i)
    tri.add_vertex(TriMesh::Point(Q(i, 0), Q(i, 1), Q(i, 2)));
  tri.add_face(tri.vertex_handle(0), tri.vertex_handle(1), tri.vertex_handle(2));
  tri.add_face(tri.vertex_handle(0), tri.vertex_handle(2), tri.vertex_handle(3));
  const Mesh far(std::move(tri));
  CHECK(far.kind() == MeshKind::Surface);
  CHECK(Discretization(far).dim() == 3);
  CHECK_THROWS_WITH(Discretization(MeshKind::Planar, Q, F), Catch::Contains("z spans 1e-11"));
  // And one with another z does not make a flat mesh a surface.
  Q(2, 2) = 0.0;
  Q(4, 2) = 7.0;
  CHECK(Discretization(MeshKind::Planar, Q, F).numElements() == 2);
}

TEST_CASE("A mesh too large or too small for double precision is refused by its size",
          "[discretization][hostile]") {
  // At 1e60 a tet's squared volume overflows, at 1e-60 it underflows: the solve used to end in
  // "the solution is not finite" without saying why.
  for (const Mesh& shape :
       {makeRectangle(2.0, 1.0, 4, 2), makeSphere(1.0, 8, 6), makeTetBox(3.0, 1.0, 1.0, 3, 1, 1)}) {
    for (const double scale : {1e60, 1e-60, 1e31, 1e-31}) {
      INFO(toString(shape.kind()) << " scaled by " << scale);
      CHECK_THROWS_WITH(Discretization(shape.kind(), shape.positions() * scale, shape.elements()),
                        Catch::Contains("discretization: the mesh's size (bounding-box diagonal") &&
                            Catch::Contains("is outside [1e-30, 1e30]"));
    }
    // Inside the range the rest shape is as scale-free as ever: measures scale by its power.
    const Discretization unit(shape.kind(), shape.positions(), shape.elements());
    for (const double scale : {1e29, 1e-29}) {
      INFO(toString(shape.kind()) << " scaled by " << scale);
      const Discretization d(shape.kind(), shape.positions() * scale, shape.elements());
      const double power = std::pow(scale, shape.kind() == MeshKind::Tet ? 3 : 2);
      CHECK(d.measures().isApprox(unit.measures() * power, 1e-12));
    }
  }
}
