// The flip_edges and subdivide filters: what they keep consistent in the document (vertex ids,
// rest positions, handles), the paper's robustness experiments through a pipeline
// (triangulation, Fig. 8; resolution, Fig. 9 and docs/method.md, "Diffused weights" "Units of t"),
// and their errors.
#include <diffreg/core/error.h>
#include <diffreg/mesh/remesh.h>
#include <diffreg/mesh/shapes.h>
#include <diffreg/pipeline/pipeline.h>
#include "plugins.h"

#include "test_support.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <sstream>
#include <string>
#include <vector>

using namespace diffreg;
using namespace diffreg::testing;

namespace {

/// Runs the steps on a copy of `input` and returns the result (and the report).
Document run(const Document& input, const std::vector<Step>& steps,
             nlohmann::json* report = nullptr) {
  Document doc = input;
  Pipeline p;
  for (const Step& s : steps) p.add(s.filter, s.values);
  const nlohmann::json r = p.run(doc);
  if (report) *report = r;
  return doc;
}

/// Vertices farther than `radius` from (cx, cy).
std::vector<int> outside(const Eigen::MatrixXd& p, double cx, double cy, double radius) {
  std::vector<int> ids;
  for (int v = 0; v < p.rows(); ++v)
    if (std::hypot(p(v, 0) - cx, p(v, 1) - cy) > radius + 1e-9) ids.push_back(v);
  return ids;
}

Eigen::VectorXd at(const Eigen::VectorXd& x, const std::vector<int>& ids) {
  Eigen::VectorXd y(ids.size());
  for (std::size_t i = 0; i < ids.size(); ++i) y[i] = x[ids[i]];
  return y;
}

double rms(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return std::sqrt((a - b).rowwise().squaredNorm().mean());
}

}  // namespace

TEST_CASE("flip_edges keeps vertices, rest positions and handles; flips as the library does",
          "[filter][mesh_edit]") {
  const Document input = Document::load(shipped("bar.obj"), shipped("bar-bend.json"));
  nlohmann::json report;
  const Document flipped =
      run(input, {{"flip_edges", {{"fraction", "0.3"}, {"seed", "7"}}}}, &report);
  Mesh expected = input.mesh;
  const int count = flipEdges(expected, 0.3, 7);
  const auto& entry = report["filters"][0];
  CHECK(entry["flipped"] == count);
  CHECK(entry["requested"].get<int>() >= count);
  CHECK(count > 0.8 * entry["requested"].get<int>());
  CHECK(flipped.mesh.elements() == expected.elements());
  CHECK(flipped.mesh.elements() != input.mesh.elements());
  CHECK(flipped.mesh.positions() == input.mesh.positions());
  CHECK(flipped.rest == input.rest);
  CHECK(flipped.handles.allVertices() == input.handles.allVertices());
  CHECK(flipped.mesh.kind() == MeshKind::Planar);

  // The same seed gives the same mesh; another seed another one.
  CHECK(run(input, {{"flip_edges", {{"seed", "7"}}}}).mesh.elements() ==
        run(input, {{"flip_edges", {{"seed", "7"}}}}).mesh.elements());
  CHECK(run(input, {{"flip_edges", {{"seed", "7"}}}}).mesh.elements() !=
        run(input, {{"flip_edges", {{"seed", "8"}}}}).mesh.elements());

  // After a deform step the flips are decided on the rest shape and the deformed positions
  // stay; element maps of the old triangles are removed, vertex weights kept.
  const Document moved = run(input, {{"diffuse_weights", {}},
                                     {"deform", {{"energy", "asap"}}},
                                     {"flip_edges", {{"fraction", "0.3"}, {"seed", "7"}}}});
  const Document deformed = run(input, {{"diffuse_weights", {}}, {"deform", {{"energy", "asap"}}}});
  CHECK(moved.mesh.elements() == expected.elements());
  CHECK(moved.mesh.positions() == deformed.mesh.positions());
  CHECK(moved.rest == input.rest);
  CHECK(moved.mesh.vertexScalar(prop::weight) == deformed.mesh.vertexScalar(prop::weight));
  CHECK_FALSE(moved.mesh.hasElementScalar(prop::distortion));
  CHECK_FALSE(moved.mesh.hasElementScalar(prop::smoothness));
}

TEST_CASE(
    "Weights and the non-uniform deformation barely change when 30% of the edges are "
    "flipped (paper Fig. 8)",
    "[filter][mesh_edit][paper]") {
  // Measured (seed 2016): the bar (bar-bend.json, 30% requested) changes its weights by at most
  // 0.042 (mean 0.014; peak weight 0.5) and its converged deformed positions by less than 2% of
  // the RMS motion; the cylinder pulled at one vertex changes its weights by at most 0.083 (mean
  // 0.0025), the point handle's spike following its one-ring. The cylinder's converged
  // positions move by 36% of the motion: the thin shell's ARAP energy is nearly flat along
  // bending modes, so two triangulations settle in visibly different, nearly equal-energy
  // shapes; positions are compared on the bar only.
  struct Scenario {
    std::string mesh, handles;
    double weightMax, weightMean, motionFraction;  // bounds, ~1.4x the measured values
  };
  const std::string pull = R"({"handles": [
      {"name": "bottom", "within": {"center": [0, 0, -1], "radius": 1.5}, "translate": [0, 0, 0],
       "magnitude": 0.5},
      {"name": "pull", "nearest": [1, 0, 4], "translate": [0.6, 0, 0.3], "magnitude": 0.5}]})";
  for (const Scenario& s : {Scenario{"bar.obj", "bar-bend.json", 0.06, 0.02, 0.02},
                            Scenario{"cylinder.obj", "", 0.12, 0.0035, 0.0}}) {
    INFO(s.mesh);
    Document input = Document::load(shipped(s.mesh), s.handles.empty() ? "" : shipped(s.handles));
    if (s.handles.empty()) input.handles = parseHandles(pull, input.mesh, "pull");
    const std::vector<Step> edit = {
        {"diffuse_weights", {}}, {"deform", {{"regularization", "nonuniform"}}}, {"measure", {}}};
    std::vector<Step> flippedEdit = edit;
    flippedEdit.insert(flippedEdit.begin(),
                       Step{"flip_edges", {{"fraction", "0.3"}, {"seed", "2016"}}});
    nlohmann::json a, b;
    const Document plain = run(input, edit, &a);
    const Document flipped = run(input, flippedEdit, &b);
    const auto& flips = b["filters"][0];
    CHECK(flips["flipped"].get<int>() > 0.2 * flips["interior_edges"].get<int>());

    const Eigen::VectorXd wa = plain.mesh.vertexScalar(prop::weight);
    const Eigen::VectorXd wb = flipped.mesh.vertexScalar(prop::weight);
    const double motion = rms(plain.mesh.positions(), input.rest);
    const double apart = rms(plain.mesh.positions(), flipped.mesh.positions());
    CAPTURE((wa - wb).cwiseAbs().maxCoeff(), (wa - wb).cwiseAbs().mean(), apart / motion);
    CHECK((wa - wb).cwiseAbs().maxCoeff() < s.weightMax);
    CHECK((wa - wb).cwiseAbs().mean() < s.weightMean);
    CHECK(wb.maxCoeff() <= 0.5 + 1e-3);
    if (s.motionFraction > 0.0) CHECK(apart < s.motionFraction * motion);
    CHECK(b["filters"][3]["metrics"]["inverted"] == a["filters"][2]["metrics"]["inverted"]);
  }
}

TEST_CASE("subdivide keeps the old vertex ids, subdivides the rest shape and grows the handles",
          "[filter][mesh_edit]") {
  const Document input = Document::load(shipped("bar.obj"), shipped("bar-bend.json"));
  const int n = input.mesh.numVertices();
  nlohmann::json report;
  const Document fine = run(input, {{"subdivide", {}}}, &report);
  CHECK(fine.mesh.numElements() == 4 * input.mesh.numElements());
  CHECK(report["filters"][0]["vertices"] == fine.mesh.numVertices());
  CHECK(fine.rest.rows() == fine.mesh.numVertices());
  CHECK(fine.rest == fine.mesh.positions());
  CHECK(fine.rest.topRows(n) == input.rest);
  CHECK(fine.mesh.kind() == MeshKind::Planar);

  // Old handle vertices and their targets are unchanged; the left end (5 vertices on a line)
  // gains the 4 midpoints between them, targets at the midpoints of their targets; the point
  // handles stay single vertices.
  REQUIRE(fine.handles.handles.size() == 3);
  const Handle& left = fine.handles.handles[0];
  CHECK(left.vertices.size() == 9);
  CHECK(fine.handles.handles[1].vertices.size() == 1);
  CHECK(fine.handles.handles[2].vertices.size() == 1);
  CHECK(report["filters"][0]["added_handle_vertices"] == 4);
  for (std::size_t j = 0; j < 3; ++j) {
    const Handle& before = input.handles.handles[j];
    const Handle& after = fine.handles.handles[j];
    for (std::size_t i = 0; i < before.vertices.size(); ++i) {
      CHECK(after.vertices[i] == before.vertices[i]);
      CHECK(after.targets.row(i) == before.targets.row(i));
    }
    for (std::size_t i = before.vertices.size(); i < after.vertices.size(); ++i) {
      const int v = after.vertices[i];
      CHECK(v >= n);
      CHECK(fine.rest(v, 0) == 0.0);                                    // on the clamped end
      CHECK((after.targets.row(i) - fine.rest.row(v)).norm() < 1e-15);  // translate [0, 0, 0]
    }
  }
  // handles=keep leaves them as they were.
  const Document kept = run(input, {{"subdivide", {{"handles", "keep"}}}});
  CHECK(kept.handles.allVertices() == input.handles.allVertices());

  // The fine mesh deforms with the handles at their targets.
  const Document bent =
      run(fine, {{"diffuse_weights", {}}, {"deform", {{"regularization", "nonuniform"}}}});
  const Eigen::MatrixXd p = bent.mesh.positions();
  for (const Handle& h : fine.handles.handles)
    for (std::size_t i = 0; i < h.vertices.size(); ++i)
      CHECK((p.row(h.vertices[i]) - h.targets.row(i)).norm() < 1e-9);

  // Two iterations: 16 times the triangles, the left end 17 vertices.
  const Document finer = run(input, {{"subdivide", {{"iterations", "2"}}}});
  CHECK(finer.mesh.numElements() == 16 * input.mesh.numElements());
  CHECK(finer.handles.handles[0].vertices.size() == 17);
}

TEST_CASE("subdivide after a deform step subdivides both the rest and the deformed shape",
          "[filter][mesh_edit]") {
  const Document input = Document::load(shipped("bar.obj"), shipped("bar-bend.json"));
  const int n = input.mesh.numVertices();
  const Document deformed = run(input, {{"diffuse_weights", {}}, {"deform", {{"energy", "asap"}}}});
  const Document fine = run(deformed, {{"subdivide", {}}});
  const Eigen::MatrixXd p = fine.mesh.positions();
  CHECK(p.topRows(n) == deformed.mesh.positions());
  CHECK(fine.rest.topRows(n) == input.rest);
  CHECK(fine.mesh.hasVertexScalar(prop::weight));  // interpolated
  CHECK_FALSE(fine.mesh.hasElementScalar(prop::distortion));
  // Each new vertex sits at the midpoint of its edge, in the rest and in the deformed shape.
  const TriMesh& tri = fine.mesh.tri();
  for (int v = n; v < fine.mesh.numVertices(); ++v) {
    std::vector<int> ends;
    for (auto w : tri.vv_range(tri.vertex_handle(v)))
      if (w.idx() < n) ends.push_back(w.idx());
    REQUIRE(ends.size() == 2);
    CHECK((fine.rest.row(v) - 0.5 * (fine.rest.row(ends[0]) + fine.rest.row(ends[1]))).norm() <
          1e-12);
    CHECK((p.row(v) - 0.5 * (p.row(ends[0]) + p.row(ends[1]))).norm() < 1e-12);
  }
  // A later deform starts again from the (subdivided) rest shape.
  const Document again = run(fine, {{"deform", {{"energy", "asap"}}}});
  const Document direct = run(run(input, {{"subdivide", {}}}), {{"deform", {{"energy", "asap"}}}});
  CHECK((again.mesh.positions() - direct.mesh.positions()).norm() < 1e-9);
}

TEST_CASE("Loop subdivision moves the rest shape; handle vertices keep their displacement",
          "[filter][mesh_edit]") {
  const Document input = Document::load(shipped("bar.obj"), shipped("bar-bend.json"));
  const int n = input.mesh.numVertices();
  const Document fine = run(input, {{"subdivide", {{"scheme", "loop"}}}});
  CHECK(fine.rest == fine.mesh.positions());
  CHECK((fine.rest.topRows(n) - input.rest).norm() > 1e-3);  // smoothing moved old vertices
  CHECK(fine.mesh.kind() == MeshKind::Planar);
  for (std::size_t j = 0; j < input.handles.handles.size(); ++j) {
    const Handle& before = input.handles.handles[j];
    const Handle& after = fine.handles.handles[j];
    const Eigen::RowVector3d shift = before.targets.row(0) - input.rest.row(before.vertices[0]);
    for (std::size_t i = 0; i < after.vertices.size(); ++i)
      CHECK((after.targets.row(i) - fine.rest.row(after.vertices[i]) - shift).norm() < 1e-12);
  }
}

TEST_CASE(
    "Resolution through a pipeline: after 1-to-4 subdivision the weights at the original "
    "vertices stay with t in absolute or diagonal units and shrink with mean_edge2 "
    "(paper Fig. 9, docs/method.md: Diffused weights)",
    "[filter][mesh_edit][paper]") {
  // A disk handle (the vertices within 0.3 of (1, 1); subdivide grows it over the edges between
  // them, so it keeps its extent) and a one-vertex handle at the same place, on a 4 x 2
  // rectangle of 16 x 8 cells, refined once and twice.
  const std::string disk = R"({"handles": [{"within": {"center": [1, 1, 0], "radius": 0.3}}]})";
  const std::string point = R"({"handles": [{"nearest": [1, 1, 0]}]})";
  const Mesh base = makeRectangle(4, 2, 16, 8);
  const std::vector<int> free = outside(base.positions(), 1.0, 1.0, 0.3);
  const double diagonal2 = 20.0;  // subdivision keeps the bounding box
  const double t = 0.05;          // length^2

  /// Mean and values of the weights at the base mesh's free vertices after `levels` steps.
  auto weights = [&](const std::string& json, int levels, const std::string& tText,
                     const std::string& unit) {
    std::vector<Step> steps;
    if (levels > 0) steps.push_back({"subdivide", {{"iterations", std::to_string(levels)}}});
    steps.push_back({"diffuse_weights", {{"t", tText}, {"t_unit", unit}}});
    const Document doc = run(inCode(base, json), steps);
    return at(doc.mesh.vertexScalar(prop::weight), free);
  };
  auto text = [](double v) {
    std::ostringstream out;
    out.precision(17);
    out << v;
    return out.str();
  };

  for (const std::string unit : {"absolute", "diagonal"}) {
    INFO("t_unit " << unit);
    const std::string tText = text(unit == "absolute" ? t : t / diagonal2);
    std::vector<Eigen::VectorXd> d, p;
    for (int level = 0; level <= 2; ++level) {
      d.push_back(weights(disk, level, tText, unit));
      p.push_back(weights(point, level, tText, unit));
    }
    const double disk01 = (d[1] - d[0]).cwiseAbs().maxCoeff();
    const double disk12 = (d[2] - d[1]).cwiseAbs().maxCoeff();
    CAPTURE(d[0].mean(), d[1].mean(), d[2].mean(), disk01, disk12);
    CAPTURE(p[0].mean(), p[1].mean(), p[2].mean(), (p[2] - p[1]).cwiseAbs().maxCoeff());
    // The disk keeps its extent and converges: means 0.0470, 0.0424, 0.0408 (the change drops
    // from 0.0046 to 0.0016), largest change at an original vertex 0.040 then 0.017.
    CHECK(std::abs(d[2].mean() - d[1].mean()) < 0.5 * std::abs(d[1].mean() - d[0].mean()));
    CHECK(d[1].mean() == Approx(d[0].mean()).epsilon(0.15));
    CHECK(d[2].mean() == Approx(d[1].mean()).epsilon(0.06));
    CHECK(disk12 < 0.025);
    CHECK(disk12 < 0.6 * disk01);
    // A single vertex has vanishing capacity: its weights drift down a little at each level,
    // means 0.0092, 0.0061, 0.0047 (ratios 0.67, 0.76), largest change 0.020 at level 2.
    CHECK(p[1].mean() > 0.6 * p[0].mean());
    CHECK(p[2].mean() > 0.7 * p[1].mean());
    CHECK(p[2].mean() < p[1].mean());
    CHECK((p[2] - p[1]).cwiseAbs().maxCoeff() < 0.03);
  }

  // mean_edge2: the same physical t on the base mesh (diffuse_weights reports the absolute t:
  // with t = 1 it is the squared mean edge length), so a quarter of it per level.
  nlohmann::json report;
  run(inCode(base, disk), {{"diffuse_weights", {{"t", "1"}, {"t_unit", "mean_edge2"}}}}, &report);
  const double edge2 = report["filters"][0]["t_absolute"].get<double>();
  const std::string tEdge = text(t / edge2);
  std::vector<double> d, p;
  for (int level = 0; level <= 2; ++level) {
    d.push_back(weights(disk, level, tEdge, "mean_edge2").mean());
    p.push_back(weights(point, level, tEdge, "mean_edge2").mean());
  }
  CAPTURE(d[0], d[1], d[2], p[0], p[1], p[2]);
  CHECK(d[0] == Approx(weights(disk, 0, text(t), "absolute").mean()));
  // Measured means: disk 0.047, 0.012, 0.0014; point 0.0092, 0.00049, 2e-9 (paper Fig. 9: t
  // must grow on denser meshes).
  CHECK(d[1] < 0.4 * d[0]);
  CHECK(d[2] < 0.25 * d[1]);
  CHECK(p[1] < 0.1 * p[0]);
  CHECK(p[2] < 0.1 * p[1]);
  CHECK(d[2] < 0.1 * weights(disk, 2, text(t), "absolute").mean());
}

TEST_CASE("flip_edges and subdivide refuse tet meshes and bad parameters with one clear line",
          "[filter][mesh_edit]") {
  const Document tet = Document::load(shipped("tetbar.mesh"), shipped("tetbar-bend.json"));
  for (const std::string filter : {"flip_edges", "subdivide"}) {
    INFO(filter);
    Document doc = tet;
    try {
      run(doc, {{filter, {}}});
      FAIL("no error");
    } catch (const InvalidParameter& e) {
      const std::string message = e.what();
      CHECK_THAT(message, Catch::Contains(filter) && Catch::Contains("tet mesh"));
      CHECK(message.find('\n') == std::string::npos);
    }
    CHECK(doc.mesh.numVertices() == tet.mesh.numVertices());
  }
  const Document bar = Document::load(shipped("bar.obj"), shipped("bar-bend.json"));
  auto check = [&](const std::string& filter, std::map<std::string, std::string> values) {
    Pipeline p;
    p.add(filter, values);
    p.check(bar);
  };
  CHECK_THROWS_WITH(check("flip_edges", {{"fraction", "1.5"}}),
                    Catch::Contains("fraction") && Catch::Contains("[0, 1]"));
  CHECK_THROWS_WITH(check("flip_edges", {{"seed", "-1"}}), Catch::Contains("seed"));
  CHECK_THROWS_WITH(check("subdivide", {{"scheme", "butterfly"}}),
                    Catch::Contains("midpoint, loop"));
  CHECK_THROWS_WITH(check("subdivide", {{"iterations", "-1"}}), Catch::Contains("iterations"));
  CHECK_THROWS_WITH(check("subdivide", {{"handles", "drop"}}), Catch::Contains("grow, keep"));
  // A result beyond 2^24 triangles is refused before any work (the bar's 512 triangles, 8
  // steps: 33.5M), the mesh untouched; 7 steps (8.4M) stay within it.
  Document big = bar;
  CHECK_THROWS_WITH(run(big, {{"subdivide", {{"iterations", "8"}}}}),
                    "filter subdivide: parameter 'iterations' = 8 would make 33554432 triangles "
                    "of the mesh's 512, more than the 16777216 allowed");
  CHECK(big.mesh.numElements() == 512);
  // Zero flips or zero iterations change nothing.
  const Document same =
      run(bar, {{"flip_edges", {{"fraction", "0"}}}, {"subdivide", {{"iterations", "0"}}}});
  CHECK(same.mesh.elements() == bar.mesh.elements());
  CHECK(same.handles.allVertices() == bar.handles.allVertices());
}

TEST_CASE("after flip_edges or subdivide, element properties must be produced again",
          "[filter][mesh]") {
  const Document doc = inCode(makeRectangle(4.0, 1.0, 16, 4), R"({"handles": [
      {"name": "left", "nearest": [0, 0.5, 0], "translate": [0, 0, 0]},
      {"name": "right", "nearest": [4, 0.5, 0], "translate": [0, 1, 0]}]})");
  for (const char* edit : {"flip_edges", "subdivide"}) {
    INFO(edit);
    Pipeline stale;
    stale.add("deform").add(edit).add("render", {{"file", "x.png"}, {"property", "distortion"}});
    CHECK_THROWS_AS(stale.check(doc), MissingProperty);
    CHECK_THROWS_WITH(stale.check(doc), Catch::Contains("step 3 (filter render)") &&
                                            Catch::Contains("diffreg:distortion") &&
                                            Catch::Contains(std::string("(") + edit + ") removed it"));
    // Measuring again after the edit provides it; the weights (a vertex property) survive.
    Pipeline fresh;
    fresh.add("diffuse_weights")
        .add("deform")
        .add(edit)
        .add("measure")
        .add("render", {{"file", "x.png"}, {"property", "distortion"}})
        .add("render", {{"file", "y.png"}, {"property", "weight"}});
    CHECK_NOTHROW(fresh.check(doc));
  }
}
