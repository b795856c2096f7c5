// Pipeline: checks before any work (filters, parameters, handles, properties), the report, and
// the built-in diffuse_weights filter agreeing with the library's one-shot function.
#include <diffreg/pipeline/pipeline.h>

#include <diffreg/core/error.h>
#include <diffreg/discretization/discretization.h>
#include <diffreg/mesh/io.h>
#include <diffreg/mesh/shapes.h>
#include "plugins.h"
#include <diffreg/weights/diffusion.h>

#include "test_support.h"

#include <catch2/catch.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include <unistd.h>

using namespace diffreg;
using diffreg::testing::shipped;

namespace {

/// A configurable test filter that counts its applications.
class Probe : public Filter {
 public:
  Probe(std::string name, std::vector<std::string> needs, std::vector<std::string> makes,
        bool handles, int* applied)
      : name_(std::move(name)),
        needs_(std::move(needs)),
        makes_(std::move(makes)),
        handles_(handles),
        applied_(applied) {}
  std::string name() const override { return name_; }
  std::string description() const override { return "probe"; }
  std::vector<ParamSpec> params() const override {
    ParamSpec k;
    k.name = "k";
    k.type = ParamType::Int;
    k.defaultValue = "1";
    k.min = 0;
    k.max = 10;
    return {k};
  }
  std::vector<std::string>
  requires(const ParamMap&) const override { return needs_; }
  std::vector<std::string> produces(const ParamMap&) const override { return makes_; }
  bool needsHandles() const override { return handles_; }
  FilterResult apply(Document& doc, const ParamMap& params) const override {
    ++*applied_;
    for (const auto& p : makes_)
      doc.mesh.setVertexScalar(p, Eigen::VectorXd::Constant(doc.mesh.numVertices(), 1.0));
    FilterResult r;
    r.stats.numeric = params.getInt("k");
    r.data = {{"k_seen", params.getInt("k")}};
    return r;
  }

 private:
  std::string name_;
  std::vector<std::string> needs_, makes_;
  bool handles_;
  int* applied_;
};

struct Fixture {
  int applied = 0;
  Registry registry;
  Document doc;
  Fixture() {
    registry.add(std::make_unique<Probe>("make_a", std::vector<std::string>{},
                                         std::vector<std::string>{"test:a"}, false, &applied));
    registry.add(std::make_unique<Probe>("also_a", std::vector<std::string>{},
                                         std::vector<std::string>{"test:a"}, false, &applied));
    registry.add(std::make_unique<Probe>("use_a", std::vector<std::string>{"test:a"},
                                         std::vector<std::string>{}, false, &applied));
    registry.add(std::make_unique<Probe>("grab", std::vector<std::string>{},
                                         std::vector<std::string>{}, true, &applied));
    doc.mesh = makeRectangle(2.0, 1.0, 4, 2);
    doc.rest = doc.mesh.positions();
  }
};

/// Two handles on a rectangle: its left edge (m = 1) and its right edge (m = 0.5).
HandleSet edgeHandles(const Mesh& mesh, double width) {
  HandleSet set;
  set.handles.resize(2);
  set.handles[0].name = "left";
  set.handles[1].name = "right";
  set.handles[1].magnitude = 0.5;
  const Eigen::MatrixXd p = mesh.positions();
  for (int i = 0; i < p.rows(); ++i) {
    if (p(i, 0) == 0.0) set.handles[0].vertices.push_back(i);
    if (p(i, 0) == width) set.handles[1].vertices.push_back(i);
  }
  for (auto& h : set.handles) {
    h.targets.resize(static_cast<int>(h.vertices.size()), 3);
    for (int r = 0; r < h.targets.rows(); ++r) h.targets.row(r) = p.row(h.vertices[r]);
  }
  return set;
}

}  // namespace

TEST_CASE("Pipeline::check names the missing property, the step and who provides it") {
  Fixture f;
  Pipeline pipeline(f.registry);
  pipeline.add("grab_not").add("use_a");
  CHECK_THROWS_WITH(pipeline.check(f.doc),
                    "unknown filter 'grab_not' (filters: also_a, grab, make_a, use_a)");

  Pipeline missing(f.registry);
  missing.add("make_a", {{"k", "2"}}).add("use_a").add("use_a");
  missing.check(f.doc);  // make_a provides test:a to both later steps

  Pipeline first(f.registry);
  first.add("use_a").add("make_a");
  CHECK_THROWS_AS(first.check(f.doc), MissingProperty);
  CHECK_THROWS_WITH(first.check(f.doc),
                    "step 1 (filter use_a) needs property 'test:a', which neither the mesh nor an "
                    "earlier step provides; run also_a, make_a before it");

  // A property the mesh already carries satisfies the requirement.
  f.doc.mesh.setVertexScalar("test:a", Eigen::VectorXd::Zero(f.doc.mesh.numVertices()));
  first.check(f.doc);
  CHECK(f.applied == 0);
}

TEST_CASE("Pipeline::check rejects bad parameters and missing handles") {
  Fixture f;
  Pipeline bad(f.registry);
  bad.add("make_a").add("use_a", {{"k", "11"}});
  CHECK_THROWS_WITH(bad.check(f.doc), "filter use_a: parameter 'k' = '11' is out of range [0, 10]");
  Pipeline unknown(f.registry);
  unknown.add("make_a", {{"kk", "1"}});
  CHECK_THROWS_WITH(unknown.check(f.doc), "filter make_a has no parameter 'kk' (parameters: k)");
  Pipeline handles(f.registry);
  handles.add("grab");
  CHECK_THROWS_WITH(handles.check(f.doc), "filter grab needs handles: give --handles");
}

TEST_CASE("Pipeline::run does no work when a later step is invalid") {
  Fixture f;
  Pipeline pipeline(f.registry);
  pipeline.add("make_a").add("use_a", {{"k", "x"}});
  CHECK_THROWS_AS(pipeline.run(f.doc), InvalidParameter);
  CHECK(f.applied == 0);
  CHECK_FALSE(f.doc.mesh.hasVertexScalar("test:a"));
}

TEST_CASE("Pipeline::run reports every step with canonical parameters and counters") {
  Fixture f;
  f.doc.path = "in-memory";
  Pipeline pipeline(f.registry);
  pipeline.add("make_a", {{"k", "03"}}).add("use_a");
  const nlohmann::json report = pipeline.run(f.doc);
  CHECK(f.applied == 2);
  CHECK(report["mesh"]["path"] == "in-memory");
  CHECK(report["mesh"]["kind"] == "planar");
  CHECK(report["mesh"]["vertices"] == f.doc.mesh.numVertices());
  CHECK(report["mesh"]["elements"] == f.doc.mesh.numElements());
  REQUIRE(report["filters"].size() == 2);
  const auto& first = report["filters"][0];
  CHECK(first["name"] == "make_a");
  CHECK(first["params"] == nlohmann::json{{"k", "3"}});
  CHECK(first["numeric"] == 3);
  CHECK(first["symbolic"] == 0);
  CHECK(first["k_seen"] == 3);
  CHECK(first["seconds"].get<double>() >= 0.0);
  CHECK(report["filters"][1]["params"] == nlohmann::json{{"k", "1"}});
}

TEST_CASE("The built-in registry holds diffuse_weights with its parameter table") {
  const Registry& registry = Registry::builtin();
  CHECK(&registry == &Registry::builtin());
  REQUIRE(registry.has("diffuse_weights"));
  const Filter& filter = registry.get("diffuse_weights");
  CHECK(filter.needsHandles());
  const auto specs = filter.params();
  REQUIRE(specs.size() == 5);
  CHECK(specs[0].name == "t");
  CHECK(specs[0].type == ParamType::Float);
  CHECK(specs[1].name == "t_unit");
  CHECK(specs[1].choices == std::vector<std::string>{"absolute", "diagonal", "mean_edge2"});
  CHECK(specs[2].name == "order");
  CHECK(specs[2].choices == std::vector<std::string>{"first", "second", "implicit_euler"});
  CHECK(specs[3].name == "steps");
  CHECK(specs[3].type == ParamType::Int);
  CHECK(specs[4].name == "solve");
  CHECK(specs[4].choices == std::vector<std::string>{"pcg", "direct"});
  const ParamMap defaults("diffuse_weights", specs, {});
  CHECK(defaults.text() == std::map<std::string, std::string>{{"t", "0.01"},
                                                              {"t_unit", "diagonal"},
                                                              {"order", "second"},
                                                              {"steps", "100"},
                                                              {"solve", "pcg"}});
  CHECK(filter.produces(defaults) == std::vector<std::string>{prop::weight});
  CHECK(filter.description().find("Computer-Aided Design") != std::string::npos);
  // Every parameter choice maps onto the library's own names.
  for (const auto& unit : specs[1].choices) CHECK(toString(parseEnum<TimeUnit>(unit)) == unit);
  for (const auto& order : specs[2].choices) CHECK(toString(parseEnum<DiffusionOrder>(order)) == order);
  for (const auto& solve : specs[4].choices) CHECK(toString(parseEnum<DiffusionSolve>(solve)) == solve);
}

TEST_CASE("diffuse_weights in a pipeline equals the one-shot library function") {
  Document doc;
  doc.mesh = makeRectangle(2.0, 1.0, 8, 4);
  doc.rest = doc.mesh.positions();
  doc.handles = edgeHandles(doc.mesh, 2.0);
  REQUIRE(doc.handles.handles[0].vertices.size() > 1);

  for (const std::string order : {"first", "second", "implicit_euler"}) {
    Document work = doc;
    Pipeline pipeline;
    pipeline.add("diffuse_weights", {{"t", "0.02"}, {"order", order}, {"steps", "20"}});
    const nlohmann::json report = pipeline.run(work);
    REQUIRE(work.mesh.hasVertexScalar(prop::weight));
    const Eigen::VectorXd x = work.mesh.vertexScalar(prop::weight);

    DiffusionParams params;
    params.t = 0.02;
    params.order = parseEnum<DiffusionOrder>(order);
    params.steps = 20;
    const Eigen::VectorXd expected = diffuseWeights(Discretization(doc.mesh), doc.handles, params);
    CHECK((x - expected).cwiseAbs().maxCoeff() <= 1e-12);

    // Handle values are the magnitudes; everything stays within [0, max m] (small tolerance
    // for the second-order scheme).
    for (int v : doc.handles.handles[0].vertices) CHECK(x[v] == Approx(1.0));
    for (int v : doc.handles.handles[1].vertices) CHECK(x[v] == Approx(0.5));
    CHECK(x.minCoeff() >= -1e-3);
    CHECK(x.maxCoeff() <= 1.0 + 1e-3);

    const auto& entry = report["filters"][0];
    CHECK(entry["name"] == "diffuse_weights");
    CHECK(entry["params"]["order"] == order);
    CHECK(entry["params"]["t_unit"] == "diagonal");
    CHECK(entry["symbolic"] == 1);
    CHECK(entry["numeric"] == 1);
    CHECK(entry["solves"].get<int>() >= 1);
    CHECK(entry["t_absolute"].get<double>() == Approx(0.02 * (4.0 + 1.0)));
    CHECK(entry["min"].get<double>() == Approx(x.minCoeff()));
    CHECK(entry["max"].get<double>() == Approx(x.maxCoeff()));
    CHECK(entry["mean"].get<double>() == Approx(x.mean()));
    // The second order runs CG against its preconditioner (solve=pcg, the default).
    if (order == "second") {
      CHECK(entry["params"]["solve"] == "pcg");
      CHECK(entry["cg_iterations"].get<int>() >= 1);
      CHECK(entry["cg_iterations"].get<int>() <= 15);
      CHECK(entry["cg_residual"].get<double>() <= kDiffusionCgTolerance);
    } else {
      CHECK(entry["cg_iterations"] == 0);
    }
  }
}

TEST_CASE("diffuse_weights solve=direct gives the pcg weights without CG") {
  Document doc;
  doc.mesh = makeRectangle(2.0, 1.0, 8, 4);
  doc.rest = doc.mesh.positions();
  doc.handles = edgeHandles(doc.mesh, 2.0);
  Eigen::VectorXd x[2];
  nlohmann::json entries[2];
  const std::string solves[] = {"pcg", "direct"};
  for (int i = 0; i < 2; ++i) {
    Document work = doc;
    Pipeline pipeline;
    pipeline.add("diffuse_weights", {{"t", "0.05"}, {"solve", solves[i]}});
    entries[i] = pipeline.run(work)["filters"][0];
    x[i] = work.mesh.vertexScalar(prop::weight);
  }
  CHECK((x[0] - x[1]).cwiseAbs().maxCoeff() <= 1e-9);
  CHECK(entries[0]["cg_iterations"].get<int>() >= 1);
  CHECK(entries[1]["cg_iterations"] == 0);
  CHECK(entries[1]["cg_residual"] == 0.0);
  CHECK(entries[1]["solves"] == 1);
  // Both factor once: pcg its preconditioner (1-ring pattern), direct the 2-ring matrix.
  for (const auto& entry : entries) CHECK(entry["numeric"] == 1);
}

TEST_CASE("diffuse_weights without handles fails in check, before any work") {
  Document doc;
  doc.mesh = makeRectangle(1.0, 1.0, 2, 2);
  doc.rest = doc.mesh.positions();
  Pipeline pipeline;
  pipeline.add("diffuse_weights");
  CHECK_THROWS_WITH(pipeline.run(doc), "filter diffuse_weights needs handles: give --handles");
  CHECK_FALSE(doc.mesh.hasVertexScalar(prop::weight));
}

TEST_CASE("Document::load reads the mesh, the handles and the rest positions") {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("diffreg-doc-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string meshPath = (dir / "bar.off").string();
  const std::string handlePath = (dir / "h.json").string();
  writeMesh(meshPath, makeRectangle(2.0, 1.0, 4, 2));
  std::ofstream(handlePath) << R"({"handles": [{"name": "a", "vertices": [0, 1]},
                                               {"name": "b", "vertices": [5], "range": 2}]})";

  const Document doc = Document::load(meshPath, handlePath);
  CHECK(doc.path == meshPath);
  CHECK(doc.mesh.kind() == MeshKind::Planar);
  CHECK(doc.rest.rows() == doc.mesh.numVertices());
  CHECK((doc.rest - doc.mesh.positions()).norm() == 0.0);
  REQUIRE(doc.handles.handles.size() == 2);
  CHECK(doc.handles.handles[1].range == 2.0);
  CHECK(doc.handlesPath == handlePath);
  CHECK(Document::load(meshPath).handles.empty());
  CHECK_THROWS_AS(Document::load((dir / "none.off").string()), IoError);
  // A handle file with an empty list: a filter that needs handles names it.
  const std::string emptyPath = (dir / "empty.json").string();
  std::ofstream(emptyPath) << R"({"handles": []})";
  Document empty = Document::load(meshPath, emptyPath);
  CHECK(empty.handles.empty());
  Pipeline pipeline;
  pipeline.add("deform");
  CHECK_THROWS_WITH(pipeline.run(empty),
                    "filter deform needs handles: the handle file '" + emptyPath + "' holds none");
  fs::remove_all(dir);
}

TEST_CASE("A Document built in code without its rest positions is told so", "[pipeline]") {
  Document doc;
  doc.mesh = makeRectangle(2.0, 1.0, 4, 2);
  doc.handles = HandleSet{};
  Handle h;
  h.name = "a";
  h.vertices = {0};
  h.targets = doc.mesh.positions().topRows(1);
  doc.handles.handles.push_back(h);
  Pipeline pipeline;
  pipeline.add("deform");
  CHECK_THROWS_WITH(pipeline.run(doc),
                    Catch::Contains("'rest' holds 0 positions for the mesh's " +
                                    std::to_string(doc.mesh.numVertices()) + " vertices"));
  doc.rest = doc.mesh.positions();
  CHECK_NOTHROW(pipeline.run(doc));
}

TEST_CASE("Document::restDiscretization is built once per rest shape", "[pipeline]") {
  Document doc;
  doc.mesh = makeRectangle(2.0, 1.0, 4, 2);
  doc.rest = doc.mesh.positions();
  const Discretization* first = &doc.restDiscretization();
  CHECK(&doc.restDiscretization() == first);
  CHECK(first->numVertices() == doc.mesh.numVertices());
  SECTION("deformed positions keep it") {
    Eigen::MatrixXd p = doc.mesh.positions();
    p(3, 0) += 0.25;
    doc.mesh.setPositions(p);
    CHECK(&doc.restDiscretization() == first);
    const Document copy = doc;  // copies share it
    CHECK(&copy.restDiscretization() == first);
  }
  SECTION("a new rest shape or new elements build it again") {
    doc.rest(3, 0) += 0.25;
    const Discretization& moved = doc.restDiscretization();
    CHECK(moved.rest()(3, 0) == doc.rest(3, 0));
    doc.mesh = makeRectangle(2.0, 1.0, 2, 2);
    doc.rest = doc.mesh.positions();
    CHECK(doc.restDiscretization().numVertices() == doc.mesh.numVertices());
  }
}

TEST_CASE("pipeline: the filters share the document's edit engine and its factorizations",
          "[pipeline][engine]") {
  // diffuse_weights, deform and measure drive one EditEngine (Document::engine()): a second
  // diffuse_weights with a new t refactors the weights' matrix numerically instead of
  // analysing it again, and measure's unregularized reference analyses only its own systems.
  Document doc = Document::load(shipped("bar.obj"), shipped("bar-bend.json"));
  Pipeline p;
  p.add("diffuse_weights", {{"t", "0.01"}});
  p.add("deform", {{"regularization", "nonuniform"}});
  p.add("measure");
  p.add("diffuse_weights", {{"t", "0.02"}});
  const nlohmann::json report = p.run(doc);
  const nlohmann::json& f = report["filters"];
  CHECK(f[0]["symbolic"].get<int>() == 1);
  CHECK(f[1]["symbolic"].get<int>() >= 1);
  // The reference's own systems only (as many as the deformation's: its system and the
  // initial guess's); the deformation is not solved again.
  CHECK(f[2]["symbolic"].get<int>() == f[1]["symbolic"].get<int>());
  CHECK(f[3]["symbolic"].get<int>() == 0);
  CHECK(f[3]["numeric"].get<int>() == 1);

  // The same weights as a fresh document's filter with t = 0.02.
  Document fresh = Document::load(shipped("bar.obj"), shipped("bar-bend.json"));
  Pipeline q;
  q.add("diffuse_weights", {{"t", "0.02"}});
  q.run(fresh);
  CHECK((doc.mesh.vertexScalar(prop::weight) - fresh.mesh.vertexScalar(prop::weight))
            .cwiseAbs()
            .maxCoeff() < 1e-12);

  // A copy of the document builds its own engine: the copy's filters analyse again.
  Document copy = doc;
  Pipeline again;
  again.add("diffuse_weights", {{"t", "0.03"}});
  CHECK(again.run(copy)["filters"][0]["symbolic"].get<int>() == 1);
}

namespace {

/// `mesh` with one more vertex at `p` that no element uses: the first vertex (the others
/// renumbered after it) or the last.
Mesh withStray(const Mesh& mesh, const Eigen::Vector3d& p, bool first) {
  const int shift = first ? 1 : 0;
  if (mesh.isTet()) {
    TetMesh tet = mesh.tet();
    tet.points.insert(first ? tet.points.begin() : tet.points.end(), p);
    for (auto& t : tet.tets)
      for (int& v : t) v += shift;
    return Mesh(std::move(tet));
  }
  const TriMesh& from = mesh.tri();
  TriMesh to;
  if (first) to.add_vertex({p.x(), p.y(), p.z()});
  for (auto v : from.vertices()) to.add_vertex(from.point(v));
  if (!first) to.add_vertex({p.x(), p.y(), p.z()});
  for (auto f : from.faces()) {
    std::vector<TriMesh::VertexHandle> corners;
    for (auto v : from.fv_range(f)) corners.push_back(to.vertex_handle(v.idx() + shift));
    to.add_face(corners);
  }
  return Mesh(to);
}

}  // namespace

TEST_CASE("pipeline: a vertex that no element uses changes no result", "[pipeline][hostile]") {
  // Such a vertex is kept with its number and left out of every system. Before, one far away
  // (or with another z) decided whether a mesh was planar, moved the centre that the first
  // global step subtracts (1e29 took every digit: a tet bar's energy came out 1.3e28), had its
  // weight checked and its value stretch the picture's colour range.
  struct Case {
    std::string mesh, handles;
    Eigen::Vector3d stray;
    bool first;
  };
  // Handles by position (the numbering shifts when the stray vertex comes first); the bar's
  // vectors have two entries, as a planar mesh's may.
  const std::string bar =
      R"({"handles": [{"within": {"center": [-10, 0.5], "radius": 10.05}, "magnitude": 0.5},
                      {"nearest": [8, 1], "translate": [0, 2], "range": 2}]})";
  const std::string cylinder = R"({"handles": [
      {"within": {"center": [0, 0, -1], "radius": 1.5}},
      {"within": {"center": [0, 0, 5], "radius": 1.5},
       "rotate": {"center": [0, 0, 4], "axis": [0, 0, 1], "degrees": 90}}]})";
  const std::string tetbar = R"({"handles": [
      {"within": {"center": [-10, 0.5, 0.5], "radius": 10.1}, "magnitude": 0.5},
      {"within": {"center": [4.1, 0.5, 0.5], "radius": 0.3}, "translate": [0, 0, -1]}]})";
  const Case cases[] = {
      {"bar.obj", bar, {4.0, 0.5, 7.0}, true},          // another z, first
      {"bar.obj", bar, {1e29, 1e29, 0.0}, false},       // far away in the plane
      {"cylinder.obj", cylinder, {1e13, 0, 0}, false},  // wide enough to make z look flat
      {"cylinder.obj", cylinder, {0, 0, 1e20}, true},
      {"tetbar.mesh", tetbar, {1e29, 1e29, 1e29}, false},
  };
  testing::TempDir dir;
  const auto run = [&](const Mesh& mesh, const std::string& handles, int stray,
                       const std::string& picture) {
    Document doc = testing::inCode(mesh, handles);
    Pipeline weights;
    weights.add("diffuse_weights", {{"t", "0.02"}});
    weights.run(doc);
    if (stray >= 0) {  // a value no weight may have, where no element reads it
      Eigen::VectorXd x = doc.mesh.vertexScalar(prop::weight);
      x(stray) = 5.0;
      doc.mesh.setVertexScalar(prop::weight, x);
    }
    Pipeline p;
    p.add("deform",
          {{"regularization", "nonuniform"}, {"acceleration", "none"}, {"iterations", "3"}});
    p.add("measure");
    p.add("render", {{"file", (dir.path / picture).string()},
                     {"property", "weight"},
                     {"width", "96"},
                     {"height", "64"}});
    const nlohmann::json report = p.run(doc);
    return std::make_pair(std::move(doc), report["filters"]);
  };
  for (const Case& c : cases) {
    INFO(c.mesh << " with a vertex at " << c.stray.transpose() << (c.first ? ", first" : ""));
    const Mesh clean = readMesh(shipped(c.mesh));
    const Mesh loose = withStray(clean, c.stray, c.first);
    CHECK(loose.kind() == clean.kind());
    const int stray = c.first ? 0 : clean.numVertices();
    const auto [a, ra] = run(clean, c.handles, -1, "a.png");
    const auto [b, rb] = run(loose, c.handles, stray, "b.png");
    const int shift = c.first ? 1 : 0, n = clean.numVertices();
    const Eigen::MatrixXd pa = a.mesh.positions(), pb = b.mesh.positions();
    const Eigen::VectorXd wa = a.mesh.vertexScalar(prop::weight),
                          wb = b.mesh.vertexScalar(prop::weight);
    double position = 0.0, weight = 0.0;
    for (int v = 0; v < n; ++v) {
      position = std::max(position, (pa.row(v) - pb.row(v + shift)).norm());
      weight = std::max(weight, std::abs(wa(v) - wb(v + shift)));
    }
    CHECK(position <= 1e-9);
    CHECK(weight <= 1e-12);
    CHECK(pb.row(stray) == c.stray.transpose());  // kept where it was
    const nlohmann::json &ma = ra[1]["metrics"], &mb = rb[1]["metrics"];
    for (const char* metric : {"D_max", "D_ave", "energy"})
      CHECK(mb[metric].get<double>() == Approx(ma[metric].get<double>()).epsilon(1e-9));
    CHECK(mb["inverted"] == ma["inverted"]);
    // The colour bar spans [0, the largest weight] of what is drawn.
    CHECK(ra[2]["scale_max"].get<double>() == Approx(wa.maxCoeff()));
    CHECK(rb[2]["scale_max"].get<double>() == Approx(wa.maxCoeff()));
  }
}
