// The rbf_weights filter: the Gaussian sum of docs/method.md, "The RBF baseline" on the rest shape,
// the paper's argument against it (two nearby handles: RBF weights between them exceed the handle
// values, diffused weights obey the maximum principle; paper §3.2.2, Fig. 10), tet meshes and
// errors.
#include <diffreg/core/error.h>
#include <diffreg/mesh/shapes.h>
#include <diffreg/pipeline/pipeline.h>
#include "plugins.h"
#include <diffreg/weights/rbf.h>

#include "test_support.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <string>

using namespace diffreg;
using namespace diffreg::testing;

namespace {

nlohmann::json runOne(Document& doc, const std::string& filter,
                      const std::map<std::string, std::string>& values) {
  Pipeline p;
  p.add(filter, values);
  return p.run(doc)["filters"][0];
}

// Two one-vertex handles 0.4 apart, both with magnitude 1, on a 4 x 2 rectangle of right
// triangles (non-negative cotangent weights, so the maximum principle holds for heat flow).
const std::string kNearPair = R"({"handles": [
    {"name": "a", "nearest": [1.8, 1, 0], "translate": [0, 0, 0]},
    {"name": "b", "nearest": [2.2, 1, 0], "translate": [0, 0, 0]}]})";

}  // namespace

TEST_CASE("rbf_weights in a pipeline is the library's Gaussian sum on the rest shape",
          "[filter][rbf]") {
  Document doc = Document::load(shipped("bar.obj"), shipped("bar-bend.json"));
  const Document input = doc;
  const double diagonal = (doc.rest.colwise().maxCoeff() - doc.rest.colwise().minCoeff()).norm();
  for (const std::string distance : {"euclidean", "geodesic"}) {
    INFO(distance);
    Document d = input;
    const nlohmann::json entry = runOne(d, "rbf_weights", {{"distance", distance}});
    const Eigen::VectorXd expected =
        rbfWeights(input.mesh, input.handles, 0.1 * diagonal, parseEnum<RbfDistance>(distance));
    const Eigen::VectorXd got = d.mesh.vertexScalar(prop::weight);
    CHECK((got - expected).cwiseAbs().maxCoeff() < 1e-12);
    CHECK(entry["sigma_absolute"].get<double>() == Approx(0.1 * diagonal));
    CHECK(entry["max"].get<double>() == Approx(got.maxCoeff()));
    CHECK(entry["max_magnitude"].get<double>() == 0.5);
    // The handle vertices carry at least their magnitude (other handles only add).
    for (const Handle& h : input.handles.handles)
      for (int v : h.vertices) CHECK(got[v] >= h.magnitude - 1e-12);
  }

  // sigma_unit=absolute takes sigma in length units.
  Document a = input;
  runOne(a, "rbf_weights", {{"sigma", "0.7"}, {"sigma_unit", "absolute"}});
  const Eigen::VectorXd absolute =
      rbfWeights(input.mesh, input.handles, 0.7, RbfDistance::Geodesic);
  CHECK((a.mesh.vertexScalar(prop::weight) - absolute).cwiseAbs().maxCoeff() < 1e-12);

  // After a deform step the weights are still those of the rest shape.
  Document moved = input;
  Pipeline p;
  p.add("deform", {{"energy", "asap"}});
  p.add("rbf_weights");
  p.run(moved);
  REQUIRE((moved.mesh.positions() - input.rest).norm() > 0.1);
  Document still = input;
  runOne(still, "rbf_weights", {});
  CHECK((moved.mesh.vertexScalar(prop::weight) - still.mesh.vertexScalar(prop::weight))
            .cwiseAbs()
            .maxCoeff() < 1e-12);
}

TEST_CASE(
    "Two nearby handles: RBF weights between them exceed the handle values, diffused "
    "weights do not (maximum principle, paper Fig. 10)",
    "[filter][rbf][paper]") {
  const Document input = inCode(makeRectangle(4, 2, 40, 20), kNearPair);
  const int a = input.handles.handles[0].vertices[0], b = input.handles.handles[1].vertices[0];
  const int mid = nearest(input.mesh, {2.0, 1, 0});
  REQUIRE(a != b);
  REQUIRE(mid != a);
  REQUIRE(mid != b);

  // RBF: each Gaussian gives exp(-(0.2 / 0.4)^2) = 0.78 midway; their sum 1.56 exceeds the
  // handle value 1, and the weights at the handles themselves exceed it too.
  for (const std::string distance : {"euclidean", "geodesic"}) {
    INFO(distance);
    Document doc = input;
    const nlohmann::json entry = runOne(
        doc, "rbf_weights", {{"distance", distance}, {"sigma", "0.4"}, {"sigma_unit", "absolute"}});
    const Eigen::VectorXd x = doc.mesh.vertexScalar(prop::weight);
    CHECK(x[mid] > 1.4);
    CHECK(x[a] > 1.0);
    CHECK(x[b] > 1.0);
    CHECK(entry["max"].get<double>() > entry["max_magnitude"].get<double>());
    // Such weights cannot serve as beta: deform says why, and what to do.
    // The message names the vertex farthest outside.
    Eigen::Index top = 0;
    x.maxCoeff(&top);
    CHECK_THROWS_WITH(
        runOne(doc, "deform", {{"regularization", "nonuniform"}}),
        Catch::Contains("outside [0, 1]") && Catch::Contains("clamp=true") &&
            Catch::Contains("the weight of vertex " + std::to_string(top) + " is 1 + "));

    // clamp=true cuts the sum at 1.
    Document clamped = input;
    runOne(
        clamped, "rbf_weights",
        {{"distance", distance}, {"sigma", "0.4"}, {"sigma_unit", "absolute"}, {"clamp", "true"}});
    const Eigen::VectorXd c = clamped.mesh.vertexScalar(prop::weight);
    CHECK(c.maxCoeff() == 1.0);
    CHECK(c.minCoeff() >= 0.0);
  }

  // Diffusion over a comparable range (t = 2 sigma^2) stays within [0, max m_j]: exactly for
  // the first-order scheme, to 1e-3 for the second-order one (docs/method.md, "Diffused weights");
  // it still covers the region between the handles.
  for (const std::string order : {"first", "second"}) {
    INFO(order);
    Document doc = input;
    runOne(doc, "diffuse_weights", {{"t", "0.32"}, {"t_unit", "absolute"}, {"order", order}});
    const Eigen::VectorXd x = doc.mesh.vertexScalar(prop::weight);
    const double slack = order == "first" ? 1e-12 : 1e-3;
    CHECK(x.maxCoeff() <= 1.0 + slack);
    CHECK(x.minCoeff() >= -slack);
    CHECK(x[a] == Approx(1.0));
    CHECK(x[b] == Approx(1.0));
    CHECK(x[mid] <= 1.0 + slack);
    CHECK(x[mid] > 0.5);
  }
}

TEST_CASE(
    "Unclamped RBF weights above 1 are refused by non-uniform regularization; clamped "
    "ones are used",
    "[filter][rbf]") {
  // Two nearby point handles, one pulled: a real edit.
  const std::string json = R"({"handles": [
      {"name": "left", "within": {"center": [0, 1, 0], "radius": 0.05}, "translate": [0, 0, 0]},
      {"name": "a", "nearest": [3.8, 1, 0], "translate": [0, 0, 0]},
      {"name": "b", "nearest": [4.0, 1, 0], "translate": [0, 0.5, 0]}]})";
  const Document input = inCode(makeRectangle(4, 2, 20, 10), json);
  Document raw = input;
  Pipeline unclamped;
  unclamped.add("rbf_weights", {{"sigma", "0.05"}});
  unclamped.add("deform", {{"regularization", "nonuniform"}});
  CHECK_THROWS_AS(unclamped.run(raw), InvalidParameter);

  Document clamped = input;
  Pipeline p;
  p.add("rbf_weights", {{"sigma", "0.05"}, {"clamp", "true"}});
  p.add("deform", {{"regularization", "nonuniform"}});
  p.add("measure");
  const nlohmann::json report = p.run(clamped);
  CHECK(report["filters"][0]["max"].get<double>() == 1.0);
  CHECK(std::isfinite(report["filters"][2]["metrics"]["D_max"].get<double>()));
}

TEST_CASE("rbf_weights on a tet mesh: geodesic distance through the solid", "[filter][rbf]") {
  Document doc = Document::load(shipped("tetbar.mesh"), shipped("tetbar-bend.json"));
  const Document input = doc;
  runOne(doc, "rbf_weights", {{"distance", "geodesic"}});
  const Eigen::VectorXd x = doc.mesh.vertexScalar(prop::weight);
  for (const Handle& h : input.handles.handles)
    for (int v : h.vertices) CHECK(x[v] >= h.magnitude - 1e-9);
  CHECK(x.minCoeff() >= 0.0);
  CHECK(std::isfinite(x.sum()));
  // Far-apart handles on a 4-long bar: the weights fall off between them and do not add up
  // above the handle values.
  CHECK(x.maxCoeff() <= 0.5 + 1e-6);
  const int middle = nearest(input.mesh, {2.0, 0.5, 0.5});
  CHECK(x[middle] < 0.1);
}

TEST_CASE("rbf_weights: parameter errors and missing handles are reported before any work",
          "[filter][rbf]") {
  Document doc = Document::load(shipped("bar.obj"), shipped("bar-bend.json"));
  const Registry& registry = Registry::builtin();
  REQUIRE(registry.has("rbf_weights"));
  const Filter& filter = registry.get("rbf_weights");
  CHECK_THAT(filter.description(),
             Catch::Contains("tet") && Catch::Contains("Zhu") && Catch::Contains("Heat_method_3"));
  const ParamMap defaults("rbf_weights", filter.params(), {});
  CHECK(filter.produces(defaults) == std::vector<std::string>{prop::weight});

  auto check = [&](std::map<std::string, std::string> values) {
    Pipeline p;
    p.add("rbf_weights", values);
    p.check(doc);
  };
  CHECK_THROWS_WITH(check({{"distance", "manhattan"}}),
                    Catch::Contains("distance") && Catch::Contains("euclidean, geodesic"));
  CHECK_THROWS_WITH(check({{"sigma", "0"}}), Catch::Contains("sigma") && Catch::Contains("range"));
  CHECK_THROWS_WITH(check({{"sigma_unit", "mean_edge"}}), Catch::Contains("sigma_unit"));
  CHECK_THROWS_WITH(check({{"clamp", "maybe"}}), Catch::Contains("clamp"));
  CHECK_NOTHROW(check({{"sigma", "0.2"}, {"clamp", "yes"}}));

  Document bare = Document::load(shipped("bar.obj"));
  Pipeline p;
  p.add("rbf_weights");
  CHECK_THROWS_WITH(p.run(bare), Catch::Contains("rbf_weights") && Catch::Contains("handles"));
  CHECK_FALSE(bare.mesh.hasVertexScalar(prop::weight));
}
