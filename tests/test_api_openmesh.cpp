// The public one-shot API on a caller's own OpenMesh mesh (include/diffreg/openmesh.h): results
// as named properties, the caller's other properties and connectivity untouched, and the same
// results as the library's sessions, measures and pipelines.
#include <diffreg/diffreg.h>

#include <OpenMesh/Core/Mesh/PolyMesh_ArrayKernelT.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <catch2/catch.hpp>

#include <string>
#include <vector>

using namespace diffreg;

namespace {

struct DoubleTraits : public OpenMesh::DefaultTraits {
  typedef OpenMesh::Vec3d Point;
  typedef OpenMesh::Vec3d Normal;
};
using CallerTri = OpenMesh::TriMesh_ArrayKernelT<DoubleTraits>;
using CallerTriFloat = OpenMesh::TriMesh_ArrayKernelT<>;  // OpenMesh's defaults: float points
using CallerPoly = OpenMesh::PolyMesh_ArrayKernelT<DoubleTraits>;

/// A caller's mesh built face by face from one of diffreg's shapes.
template <class M>
M toCaller(const Mesh& shape) {
  M mesh;
  const Eigen::MatrixXd P = shape.positions();
  const Eigen::MatrixXi E = shape.elements();
  std::vector<typename M::VertexHandle> vh;
  for (Eigen::Index i = 0; i < P.rows(); ++i)
    vh.push_back(mesh.add_vertex(typename M::Point(static_cast<typename M::Scalar>(P(i, 0)),
                                                   static_cast<typename M::Scalar>(P(i, 1)),
                                                   static_cast<typename M::Scalar>(P(i, 2)))));
  for (Eigen::Index k = 0; k < E.rows(); ++k)
    mesh.add_face(std::vector<typename M::VertexHandle>{vh[E(k, 0)], vh[E(k, 1)], vh[E(k, 2)]});
  return mesh;
}

template <class M>
Eigen::MatrixXd pointsOf(const M& mesh) {
  Eigen::MatrixXd P(mesh.n_vertices(), 3);
  for (auto v : mesh.vertices())
    for (int c = 0; c < 3; ++c) P(v.idx(), c) = mesh.point(v)[c];
  return P;
}

template <class M>
std::vector<std::vector<int>> facesOf(const M& mesh) {
  std::vector<std::vector<int>> faces;
  for (auto f : mesh.faces()) {
    faces.emplace_back();
    for (auto v : mesh.fv_range(f)) faces.back().push_back(v.idx());
  }
  return faces;
}

template <class M>
Eigen::VectorXd vertexDoubles(const M& mesh, const std::string& name) {
  OpenMesh::VPropHandleT<double> h;
  REQUIRE(mesh.get_property_handle(h, name));
  Eigen::VectorXd x(mesh.n_vertices());
  for (auto v : mesh.vertices()) x[v.idx()] = mesh.property(h, v);
  return x;
}

template <class M>
Eigen::VectorXd faceDoubles(const M& mesh, const std::string& name) {
  OpenMesh::FPropHandleT<double> h;
  REQUIRE(mesh.get_property_handle(h, name));
  Eigen::VectorXd x(mesh.n_faces());
  for (auto f : mesh.faces()) x[f.idx()] = mesh.property(h, f);
  return x;
}

double maxAbsDiff(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  REQUIRE(a.rows() == b.rows());
  REQUIRE(a.cols() == b.cols());
  return (a - b).cwiseAbs().maxCoeff();
}

/// The planar bar [0, 4] x [0, 1]: left end clamped, a point at the middle held, the right
/// end's upper corner raised by 1.
HandleSet barHandles(const Mesh& shape) {
  const Eigen::MatrixXd P = shape.positions();
  HandleSet set;
  Handle left, tip, middle;
  left.name = "left";
  tip.name = "tip";
  middle.name = "middle";
  int tipVertex = -1, middleVertex = -1;
  for (int i = 0; i < P.rows(); ++i) {
    if (P(i, 0) == 0.0) left.vertices.push_back(i);
    if (P(i, 0) == 4.0 && P(i, 1) == 1.0) tipVertex = i;
    if (P(i, 0) == 2.0 && P(i, 1) == 0.0) middleVertex = i;
  }
  REQUIRE(tipVertex >= 0);
  REQUIRE(middleVertex >= 0);
  left.targets.resize(static_cast<Eigen::Index>(left.vertices.size()), 3);
  for (size_t j = 0; j < left.vertices.size(); ++j) left.targets.row(j) = P.row(left.vertices[j]);
  left.magnitude = 0.5;
  middle.vertices = {middleVertex};
  middle.targets = P.row(middleVertex);
  middle.magnitude = 0.5;
  tip.vertices = {tipVertex};
  tip.targets = P.row(tipVertex);
  tip.targets(0, 1) += 1.0;
  tip.magnitude = 0.5;
  tip.range = 2.0;
  set.handles = {left, middle, tip};
  return set;
}

/// The same handle set on a surface: the cylinder's bottom ring clamped, its top ring moved.
HandleSet cylinderHandles(const Mesh& shape) {
  const Eigen::MatrixXd P = shape.positions();
  const double zMax = P.col(2).maxCoeff();
  Handle bottom, top;
  bottom.name = "bottom";
  top.name = "top";
  for (int i = 0; i < P.rows(); ++i) {
    if (P(i, 2) == 0.0) bottom.vertices.push_back(i);
    if (P(i, 2) == zMax) top.vertices.push_back(i);
  }
  bottom.targets.resize(static_cast<Eigen::Index>(bottom.vertices.size()), 3);
  for (size_t j = 0; j < bottom.vertices.size(); ++j)
    bottom.targets.row(j) = P.row(bottom.vertices[j]);
  top.targets.resize(static_cast<Eigen::Index>(top.vertices.size()), 3);
  for (size_t j = 0; j < top.vertices.size(); ++j) {
    top.targets.row(j) = P.row(top.vertices[j]);
    top.targets(j, 0) += 0.4;
  }
  HandleSet set;
  set.handles = {bottom, top};
  return set;
}

void stack(const HandleSet& handles, std::vector<int>& vertices, Eigen::MatrixXd& targets) {
  vertices = handles.allVertices();
  targets.resize(static_cast<Eigen::Index>(vertices.size()), 3);
  Eigen::Index row = 0;
  for (const Handle& h : handles.handles) {
    targets.middleRows(row, h.targets.rows()) = h.targets;
    row += h.targets.rows();
  }
}

/// The caller's own data on its mesh: standard attributes and custom properties of every kind.
struct CallerData {
  OpenMesh::VPropHandleT<int> label;
  OpenMesh::VPropHandleT<double> scalar;  // a double, like diffreg's, under its own name
  OpenMesh::FPropHandleT<std::string> name;
  OpenMesh::EPropHandleT<float> crease;
  OpenMesh::HPropHandleT<int> corner;
  OpenMesh::MPropHandleT<std::string> title;
};

template <class M>
CallerData addCallerData(M& mesh) {
  CallerData d;
  mesh.add_property(d.label, "my:label");
  mesh.add_property(d.scalar, "my:scalar");
  mesh.add_property(d.name, "my:name");
  mesh.add_property(d.crease, "my:crease");
  mesh.add_property(d.corner, "my:corner");
  mesh.add_property(d.title, "my:title");
  mesh.request_vertex_colors();
  mesh.request_face_normals();
  for (auto v : mesh.vertices()) {
    mesh.property(d.label, v) = 3 * v.idx() + 1;
    mesh.property(d.scalar, v) = 0.25 * v.idx();
    mesh.set_color(v, typename M::Color(v.idx() % 256, 7, 9));
  }
  for (auto f : mesh.faces()) {
    mesh.property(d.name, f) = "face" + std::to_string(f.idx());
    mesh.set_normal(f, typename M::Normal(0, 0, f.idx()));
  }
  for (auto e : mesh.edges()) mesh.property(d.crease, e) = 0.5f * e.idx();
  for (auto h : mesh.halfedges()) mesh.property(d.corner, h) = -h.idx();
  mesh.property(d.title) = "caller's title";
  return d;
}

template <class M>
void checkCallerData(const M& mesh, const CallerData& d) {
  bool same = true;
  for (auto v : mesh.vertices()) {
    same = same && mesh.property(d.label, v) == 3 * v.idx() + 1;
    same = same && mesh.property(d.scalar, v) == 0.25 * v.idx();
    same = same && mesh.color(v) == typename M::Color(v.idx() % 256, 7, 9);
  }
  for (auto f : mesh.faces()) {
    same = same && mesh.property(d.name, f) == "face" + std::to_string(f.idx());
    same = same && mesh.normal(f) == typename M::Normal(0, 0, f.idx());
  }
  for (auto e : mesh.edges()) same = same && mesh.property(d.crease, e) == 0.5f * e.idx();
  for (auto h : mesh.halfedges()) same = same && mesh.property(d.corner, h) == -h.idx();
  CHECK(same);
  CHECK(mesh.property(d.title) == "caller's title");
  CHECK(mesh.has_vertex_colors());
  CHECK(mesh.has_face_normals());
}

}  // namespace

TEST_CASE("fromOpenMesh keeps indices, points and the diffreg: properties only", "[api]") {
  const Mesh shape = makeRectangle(4.0, 1.0, 8, 2);
  CallerTriFloat mesh = toCaller<CallerTriFloat>(shape);
  addCallerData(mesh);
  OpenMesh::VPropHandleT<double> w;
  mesh.add_property(w, prop::weight);
  for (auto v : mesh.vertices()) mesh.property(w, v) = 0.125 * v.idx();

  const Mesh copy = fromOpenMesh(mesh);
  CHECK(copy.kind() == MeshKind::Planar);
  CHECK(copy.elements() == shape.elements());
  CHECK(maxAbsDiff(copy.positions(), pointsOf(mesh)) == 0.0);
  CHECK(copy.hasVertexScalar(prop::weight));
  CHECK(copy.vertexScalar(prop::weight) == vertexDoubles(mesh, prop::weight));
  CHECK_FALSE(copy.hasVertexScalar("my:scalar"));
}

TEST_CASE("the caller's mesh keeps its own data after every operator", "[api]") {
  const Mesh shape = makeRectangle(4.0, 1.0, 16, 4);
  const HandleSet handles = barHandles(shape);
  CallerTriFloat mesh = toCaller<CallerTriFloat>(shape);
  const CallerData data = addCallerData(mesh);
  const auto faces = facesOf(mesh);
  const CallerTriFloat rest = mesh;

  const Eigen::VectorXd w = computeDiffusedWeights(mesh, handles);
  checkCallerData(mesh, data);
  CHECK(pointsOf(mesh) == pointsOf(rest));  // weights do not move anything

  DeformationOptions options;
  options.regularization = Regularization::Nonuniform;
  const DeformationResult result = deform(mesh, handles, options);
  checkCallerData(mesh, data);
  CHECK(facesOf(mesh) == faces);
  CHECK(mesh.n_vertices() == rest.n_vertices());
  CHECK(vertexDoubles(mesh, prop::weight) == w);  // deform reads the weights, keeps them
  // The tip went where its handle says (to float precision), the rest of the bar followed.
  const int tip = handles.handles[2].vertices[0];
  CHECK(mesh.point(OpenMesh::VertexHandle(tip))[1] ==
        Approx(handles.handles[2].targets(0, 1)).margin(1e-6));
  CHECK(maxAbsDiff(pointsOf(mesh), pointsOf(rest)) > 0.5);

  measure(rest, mesh, options);
  checkCallerData(mesh, data);

  Pipeline pipeline;
  pipeline.add("diffuse_weights").add("deform", {{"regularization", "nonuniform"}}).add("measure");
  CallerTriFloat piped = rest;
  const CallerData pipedData = addCallerData(piped);
  runPipeline(pipeline, piped, handles);
  checkCallerData(piped, pipedData);
  CHECK(facesOf(piped) == faces);
  CHECK(result.iterations > 0);
}

TEST_CASE("one-shot weights equal the DiffusionWeights session's", "[api]") {
  const Mesh shape = makeRectangle(4.0, 1.0, 16, 4);
  const HandleSet handles = barHandles(shape);
  for (DiffusionOrder order : {DiffusionOrder::First, DiffusionOrder::Second}) {
    DiffusionParams params;
    params.order = order;
    params.t = 0.02;
    CallerTri mesh = toCaller<CallerTri>(shape);
    const Eigen::VectorXd w = computeDiffusedWeights(mesh, handles, params);

    const Discretization disc(shape);
    DiffusionWeights session(disc);
    session.setHandles(handles);
    session.setParams(params);
    const Eigen::VectorXd expected = session.solve();
    CHECK(maxAbsDiff(w, expected) <= 1e-12);
    CHECK(vertexDoubles(mesh, prop::weight) == w);
    // The handles carry their magnitudes.
    for (const Handle& h : handles.handles)
      for (int v : h.vertices) CHECK(w[v] == Approx(h.magnitude).margin(1e-12));
  }
}

TEST_CASE("one-shot deform and measure equal the DeformationSession and the metrics", "[api]") {
  struct Case {
    Mesh shape;
    HandleSet handles;
    Energy energy;
    Regularization regularization;
  };
  const Mesh bar = makeRectangle(4.0, 1.0, 16, 4);
  const Mesh cylinder = makeCylinder(0.5, 2.0, 12, 8);
  const std::vector<Case> cases = {
      {bar, barHandles(bar), Energy::Arap, Regularization::Nonuniform},
      {bar, barHandles(bar), Energy::Asap, Regularization::Uniform},
      {cylinder, cylinderHandles(cylinder), Energy::Arap, Regularization::Nonuniform},
      {cylinder, cylinderHandles(cylinder), Energy::Larap, Regularization::None}};
  for (const Case& c : cases) {
    CAPTURE(toString(c.shape.kind()), toString(c.energy), toString(c.regularization));
    CallerTri mesh = toCaller<CallerTri>(c.shape);
    const CallerTri rest = mesh;
    const Eigen::VectorXd w = computeDiffusedWeights(mesh, c.handles);
    DeformationOptions options;
    options.energy = c.energy;
    options.regularization = c.regularization;
    options.beta = 0.3;
    const DeformationResult result = deform(mesh, c.handles, options);

    const Discretization disc(c.shape);
    DeformationOptions sessionOptions = options;
    if (c.regularization == Regularization::Nonuniform) sessionOptions.weights = w;
    DeformationSession session(disc, sessionOptions);
    std::vector<int> vertices;
    Eigen::MatrixXd targets;
    stack(c.handles, vertices, targets);
    session.setHandles(vertices);
    session.setTargets(targets);
    const DeformationResult expected = session.solve();
    CHECK(maxAbsDiff(result.positions, expected.positions) <= 1e-12);
    CHECK(result.iterations == expected.iterations);
    CHECK(maxAbsDiff(pointsOf(mesh).leftCols(disc.dim()), expected.positions) <= 1e-12);
    if (disc.dim() == 2) CHECK(pointsOf(mesh).col(2).cwiseAbs().maxCoeff() == 0.0);
    CHECK(maxAbsDiff(faceDoubles(mesh, prop::distortion),
                     elementDistortion(disc, c.energy, expected.positions)) <= 1e-12);
    CHECK(maxAbsDiff(faceDoubles(mesh, prop::smoothness),
                     elementSmoothness(disc, facetSmoothness(disc, c.energy,
                                                             expected.positions))) <= 1e-12);

    // measure against the unregularized edit as the reference (Dist).
    CallerTri plain = rest;
    DeformationOptions plainOptions;
    plainOptions.energy = c.energy;
    deform(plain, c.handles, plainOptions);
    CallerTri measured = mesh;
    const DeformationMetrics m = measure(rest, measured, options, &plain);
    const RegularizationWeights weights =
        makeRegularizationWeights(disc, c.regularization, options.beta, w);
    const Eigen::MatrixXd reference = pointsOf(plain).leftCols(disc.dim());
    const DeformationMetrics e =
        measureDeformation(disc, c.energy, expected.positions, weights, &reference);
    CHECK(m.dMax == Approx(e.dMax).epsilon(1e-12));
    CHECK(m.dAve == Approx(e.dAve).epsilon(1e-12));
    CHECK(m.dDev == Approx(e.dDev).epsilon(1e-12));
    CHECK(m.energy == Approx(e.energy).epsilon(1e-12));
    CHECK(m.inverted == e.inverted);
    REQUIRE(m.dist.has_value());
    CHECK(*m.dist == Approx(*e.dist).margin(1e-12));
    CHECK((c.regularization == Regularization::None) == (*m.dist < 1e-9));
  }
}

TEST_CASE("runPipeline on a caller's mesh equals the one-shot functions", "[api]") {
  const Mesh shape = makeRectangle(4.0, 1.0, 16, 4);
  const HandleSet handles = barHandles(shape);
  CallerTri oneShot = toCaller<CallerTri>(shape);
  computeDiffusedWeights(oneShot, handles);
  DeformationOptions options;
  options.regularization = Regularization::Nonuniform;
  deform(oneShot, handles, options);

  CallerTri piped = toCaller<CallerTri>(shape);
  Pipeline pipeline;
  pipeline.add("diffuse_weights").add("deform", {{"regularization", "nonuniform"}});
  const nlohmann::json report = runPipeline(pipeline, piped, handles);
  REQUIRE(report["filters"].size() == 2);
  CHECK(maxAbsDiff(pointsOf(piped), pointsOf(oneShot)) <= 1e-12);
  CHECK(maxAbsDiff(vertexDoubles(piped, prop::weight), vertexDoubles(oneShot, prop::weight)) <=
        1e-12);
  CHECK(maxAbsDiff(faceDoubles(piped, prop::distortion), faceDoubles(oneShot, prop::distortion)) <=
        1e-12);
}

TEST_CASE("a PolyMesh of triangles gives the TriMesh's results", "[api]") {
  const Mesh shape = makeRectangle(4.0, 1.0, 8, 2);
  const HandleSet handles = barHandles(shape);
  CallerTri tri = toCaller<CallerTri>(shape);
  CallerPoly poly = toCaller<CallerPoly>(shape);
  CHECK(computeDiffusedWeights(poly, handles) == computeDiffusedWeights(tri, handles));
  DeformationOptions options;
  options.regularization = Regularization::Nonuniform;
  deform(tri, handles, options);
  deform(poly, handles, options);
  CHECK(maxAbsDiff(pointsOf(poly), pointsOf(tri)) <= 1e-12);
}

TEST_CASE("bad input fails with a clear error and leaves the caller's mesh as it was", "[api]") {
  const Mesh shape = makeRectangle(4.0, 1.0, 8, 2);
  const HandleSet handles = barHandles(shape);

  SECTION("non-uniform regularization without weights") {
    CallerTri mesh = toCaller<CallerTri>(shape);
    const Eigen::MatrixXd before = pointsOf(mesh);
    DeformationOptions options;
    options.regularization = Regularization::Nonuniform;
    CHECK_THROWS_AS(deform(mesh, handles, options), MissingProperty);
    CHECK_THROWS_WITH(deform(mesh, handles, options), Catch::Contains("diffreg:weight"));
    CHECK(pointsOf(mesh) == before);
    OpenMesh::FPropHandleT<double> h;
    CHECK_FALSE(mesh.get_property_handle(h, prop::distortion));
  }
  SECTION("a property of another type under diffreg's name") {
    CallerTri mesh = toCaller<CallerTri>(shape);
    OpenMesh::FPropHandleT<float> clash;
    mesh.add_property(clash, prop::distortion);
    const Eigen::MatrixXd before = pointsOf(mesh);
    CHECK_THROWS_AS(deform(mesh, handles), InvalidParameter);
    CHECK_THROWS_WITH(deform(mesh, handles), Catch::Contains("diffreg:distortion"));
    CHECK(pointsOf(mesh) == before);
  }
  SECTION("a quad face") {
    CallerPoly poly;
    std::vector<CallerPoly::VertexHandle> vh;
    for (auto p : {CallerPoly::Point(0, 0, 0), CallerPoly::Point(1, 0, 0),
                   CallerPoly::Point(1, 1, 0), CallerPoly::Point(0, 1, 0)})
      vh.push_back(poly.add_vertex(p));
    poly.add_face(vh);
    CHECK_THROWS_AS(fromOpenMesh(poly), InvalidMesh);
    CHECK_THROWS_WITH(fromOpenMesh(poly), Catch::Contains("face 0"));
    OpenMesh::VPropHandleT<double> h;
    HandleSet one;
    one.handles.resize(1);
    one.handles[0].vertices = {0};
    one.handles[0].targets = Eigen::RowVector3d(0, 0, 0);
    CHECK_THROWS_AS(computeDiffusedWeights(poly, one), InvalidMesh);
    CHECK_FALSE(poly.get_property_handle(h, prop::weight));
  }
  SECTION("deleted elements") {
    CallerTri mesh = toCaller<CallerTri>(shape);
    mesh.request_face_status();
    mesh.request_edge_status();
    mesh.request_vertex_status();
    mesh.delete_face(OpenMesh::FaceHandle(0), false);
    CHECK_THROWS_AS(fromOpenMesh(mesh), InvalidMesh);
    CHECK_THROWS_WITH(fromOpenMesh(mesh), Catch::Contains("garbage_collection"));
  }
  SECTION("no handles") {
    CallerTri mesh = toCaller<CallerTri>(shape);
    CHECK_THROWS_AS(deform(mesh, HandleSet{}), InvalidParameter);
    CHECK_THROWS_AS(computeDiffusedWeights(mesh, HandleSet{}), InvalidParameter);
  }
}

TEST_CASE("handle files resolve on a caller's mesh as on diffreg's", "[api]") {
  const Mesh shape = makeRectangle(4.0, 1.0, 8, 2);
  const CallerTriFloat mesh = toCaller<CallerTriFloat>(shape);
  const std::string json =
      R"({"handles": [{"name": "corner", "nearest": [4.1, 1.1, 0], "translate": [0, 1, 0]},
                      {"name": "left", "within": {"center": [0, 0.5, 0], "radius": 0.6}}]})";
  const HandleSet onCaller = parseHandles(json, mesh, "test");
  const HandleSet onShape = parseHandles(json, shape, "test");
  REQUIRE(onCaller.handles.size() == 2);
  for (size_t j = 0; j < 2; ++j) {
    CHECK(onCaller.handles[j].vertices == onShape.handles[j].vertices);
    CHECK(maxAbsDiff(onCaller.handles[j].targets, onShape.handles[j].targets) == 0.0);
  }
}
