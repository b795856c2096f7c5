// The measure filter: Dist against the unregularized solve or a reference file, the energy
// of the deform filter, a rest mesh for already-deformed input, and its errors.
#include <diffreg/core/error.h>
#include <diffreg/deformation/metrics.h>
#include <diffreg/mesh/io.h>
#include <diffreg/pipeline/pipeline.h>
#include "plugins.h"

#include "test_support.h"

#include <catch2/catch.hpp>

#include <cmath>

#include <filesystem>
#include <string>

#include <unistd.h>

using namespace diffreg;
using namespace diffreg::testing;
namespace fs = std::filesystem;

namespace {

Document bar() { return Document::load(shipped("bar.obj"), shipped("bar-bend.json")); }

/// Runs deform (with these values) then measure (with those) and returns measure's entry.
nlohmann::json deformAndMeasure(Document& doc, std::map<std::string, std::string> deform,
                                std::map<std::string, std::string> measure = {}) {
  Pipeline p;
  p.add("deform", deform);
  p.add("measure", measure);
  return p.run(doc)["filters"][1];
}

struct Scratch {
  fs::path dir = fs::temp_directory_path() / ("diffreg-measure-" + std::to_string(::getpid()));
  Scratch() { fs::create_directories(dir); }
  ~Scratch() { fs::remove_all(dir); }
};

}  // namespace

TEST_CASE("measure: Dist is 0 without regularization and the RMS distance to the plain "
          "solve with it",
          "[filter][measure]") {
  Document plain = bar();
  const nlohmann::json none = deformAndMeasure(plain, {{"energy", "asap"}});
  CHECK(none["metrics"]["dist"].get<double>() == 0.0);
  CHECK(none["dist_reference"] == "unregularized solve");
  CHECK(none["energy"] == "asap");  // taken from the deform filter

  Document reg = bar();
  const nlohmann::json uniform =
      deformAndMeasure(reg, {{"energy", "asap"}, {"regularization", "uniform"}, {"beta", "0.3"}});
  const double expected = rmsDistance(reg.mesh.positions(), plain.mesh.positions());
  CHECK(expected > 1e-3);
  CHECK(uniform["metrics"]["dist"].get<double>() == Approx(expected).epsilon(1e-9));
  CHECK(uniform["solves"].get<int>() >= 1);  // the reference solve

  // The same against the plain result written to a file.
  Scratch scratch;
  const std::string reference = (scratch.dir / "plain.ply").string();
  writeMesh(reference, plain.mesh);
  Document again = bar();
  const nlohmann::json fromFile =
      deformAndMeasure(again, {{"energy", "asap"}, {"regularization", "uniform"}, {"beta", "0.3"}},
                       {{"reference", reference}});
  CHECK(fromFile["dist_reference"] == reference);
  CHECK(fromFile["metrics"]["dist"].get<double>() == Approx(expected).epsilon(1e-6));
}

TEST_CASE("measure: metrics match the library's and a rest mesh measures deformed input",
          "[filter][measure]") {
  Document doc = bar();
  const nlohmann::json entry = deformAndMeasure(doc, {{"energy", "arap"}});
  const Discretization disc(bar().mesh);
  const DeformationMetrics m =
      measureDeformation(disc, Energy::Arap, doc.mesh.positions().leftCols(2),
                         makeRegularizationWeights(disc, Regularization::None, 0.0));
  const auto& metrics = entry["metrics"];
  CHECK(metrics["D_max"].get<double>() == Approx(m.dMax));
  CHECK(metrics["D_ave"].get<double>() == Approx(m.dAve));
  CHECK(metrics["D_dev"].get<double>() == Approx(m.dDev));
  CHECK(metrics["inverted"].get<int>() == m.inverted);
  CHECK(metrics["energy"].get<double>() == Approx(m.energy));
  CHECK(metrics["D_max"].get<double>() > 0.0);
  CHECK(doc.mesh.elementScalar(prop::distortion).maxCoeff() == Approx(m.dMax));

  // Deformed output read back and measured against the rest mesh: same distortion.
  Scratch scratch;
  const std::string deformed = (scratch.dir / "deformed.obj").string();
  writeMesh(deformed, doc.mesh);
  Document input = Document::load(deformed);
  Pipeline p;
  p.add("measure", {{"rest", shipped("bar.obj")}});
  nlohmann::json later;
  const std::string warned = stderrOf([&] { later = p.run(input)["filters"][0]; });
  CHECK(later["metrics"]["D_max"].get<double>() == Approx(m.dMax).epsilon(1e-5));
  CHECK(later["metrics"]["dist"].is_null());
  CHECK(later["dist_reference"].is_null());
  CHECK(warned.find("warning: measure: Dist is null: no deform filter ran before it") !=
        std::string::npos);
}

TEST_CASE("measure without a deformation reports an undistorted mesh", "[filter][measure]") {
  Document doc = bar();
  Pipeline p;
  p.add("measure");
  const nlohmann::json entry = p.run(doc)["filters"][0];
  CHECK(entry["metrics"]["D_max"].get<double>() < 1e-20);
  CHECK(entry["metrics"]["inverted"] == 0);
  CHECK(entry["metrics"]["dist"].is_null());
}

TEST_CASE("measure rejects reference and rest meshes that do not match", "[filter][measure]") {
  Scratch scratch;
  const std::string other = shipped("disc.obj");
  for (const char* param : {"reference", "rest"}) {
    Document doc = bar();
    Pipeline p;
    p.add("deform");
    p.add("measure", {{param, other}});
    try {
      p.run(doc);
      FAIL("no error");
    } catch (const InvalidParameter& e) {
      const std::string message = e.what();
      CHECK(message.find(param) != std::string::npos);
      CHECK(message.find("disc.obj") != std::string::npos);
    }
  }
  Document doc = bar();
  Pipeline p;
  p.add("measure", {{"reference", (scratch.dir / "missing.ply").string()}});
  CHECK_THROWS_AS(p.run(doc), IoError);
}

TEST_CASE("measure refuses to flatten: a planar rest with a mesh or reference out of its plane",
          "[filter][measure]") {
  Scratch scratch;
  const Document flat = bar();
  // The flat bar with its z set by `z(x)`, written as `name` in the scratch directory.
  const auto written = [&](const std::string& name, const auto& z) {
    Eigen::MatrixXd X = flat.mesh.positions();
    for (Eigen::Index i = 0; i < X.rows(); ++i) X(i, 2) = z(X(i, 0));
    Mesh moved = flat.mesh;
    moved.setPositions(X);
    const std::string path = (scratch.dir / name).string();
    writeMesh(path, moved);
    return path;
  };
  // The bar bent out of its plane: measured against the flat bar it is not undistorted.
  const std::string bump = written("bump.obj", [](double x) { return 0.5 * std::sin(x); });
  {
    Document input = Document::load(bump);
    Pipeline p;
    p.add("measure", {{"rest", shipped("bar.obj")}});
    CHECK_THROWS_WITH(p.run(input), Catch::Contains("leaves its plane") &&
                                        Catch::Contains("the mesh being measured"));
  }
  {
    Document doc = bar();
    Pipeline p;
    p.add("deform");
    p.add("measure", {{"reference", bump}});
    CHECK_THROWS_WITH(p.run(doc),
                      Catch::Contains("leaves its plane") && Catch::Contains("bump.obj"));
  }
  // A plane moved along z stays measurable: only the spread matters.
  const std::string up = written("lifted.obj", [](double) { return 3.0; });
  Document input = Document::load(up);
  Pipeline p;
  p.add("measure", {{"rest", shipped("bar.obj")}});
  CHECK(p.run(input)["filters"][0]["metrics"]["D_max"].get<double>() < 1e-20);
}
