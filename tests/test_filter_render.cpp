// The render filter: the PNG shows the chosen property with the documented colour map and
// scale, handles marked; tet meshes by their boundary; the document is left untouched; the
// file is written atomically, relative to the working directory, and every failure is one
// clear error with no file left behind.
#include <diffreg/core/colormap.h>
#include <diffreg/core/error.h>
#include <diffreg/pipeline/pipeline.h>
#include "plugins.h"
#include <diffreg/render/render.h>

#include "test_support.h"

#include <catch2/catch.hpp>

#include <filesystem>
#include <random>
#include <string>

#include <unistd.h>

using namespace diffreg;
using namespace diffreg::testing;
namespace fs = std::filesystem;

namespace {

/// The bar bent with diffused weights and non-uniform regularization (README's example).
Document bentBar() {
  Document doc = Document::load(shipped("bar.obj"), shipped("bar-bend.json"));
  Pipeline p;
  p.add("diffuse_weights");
  p.add("deform", {{"regularization", "nonuniform"}});
  p.run(doc);
  return doc;
}

nlohmann::json render(Document& doc, const std::map<std::string, std::string>& values) {
  Pipeline p;
  p.add("render", values);
  return p.run(doc)["filters"][0];
}

int distance(const Rgb& a, const Rgb& b) {
  int d = 0;
  for (int c = 0; c < 3; ++c) d += std::abs(int(a[c]) - int(b[c]));
  return d;
}

Rgb pixelAt(const Image& image, const Eigen::Vector3d& projected) {
  return image.get(static_cast<int>(std::floor(projected.x())),
                   static_cast<int>(std::floor(projected.y())));
}

bool sameImage(const Image& a, const Image& b) {
  return a.width == b.width && a.height == b.height && a.rgb == b.rgb;
}

/// Everything a filter could change on a document.
void requireUnchanged(const Document& before, const Document& after) {
  REQUIRE(after.mesh.positions() == before.mesh.positions());
  REQUIRE(after.mesh.elements() == before.mesh.elements());
  REQUIRE(after.rest == before.rest);
  REQUIRE(after.mesh.vertexScalarNames() == before.mesh.vertexScalarNames());
  REQUIRE(after.mesh.elementScalarNames() == before.mesh.elementScalarNames());
  for (const auto& name : before.mesh.vertexScalarNames())
    REQUIRE(after.mesh.vertexScalar(name) == before.mesh.vertexScalar(name));
  for (const auto& name : before.mesh.elementScalarNames())
    REQUIRE(after.mesh.elementScalar(name) == before.mesh.elementScalar(name));
  REQUIRE(after.handles.allVertices() == before.handles.allVertices());
}

}  // namespace

TEST_CASE("render: weights in viridis from 0, handles marked, the document untouched",
          "[filter][render]") {
  TempDir dir;
  const Document bent = bentBar();
  Document doc = bent;
  const std::string file = dir / "weights.png";
  const nlohmann::json entry = render(doc, {{"file", file}, {"property", "weight"}});
  requireUnchanged(bent, doc);
  REQUIRE(fs::exists(file));
  CHECK(dir.entries() == 1);  // no temporary file left behind
  const Image image = readPng(file);
  CHECK(image.width == 800);
  CHECK(image.height == 600);
  const Eigen::VectorXd w = bent.mesh.vertexScalar(prop::weight);
  CHECK(entry["scale_min"].get<double>() == 0.0);
  CHECK(entry["scale_max"].get<double>() == Approx(w.maxCoeff()));
  // A field of zeros is drawn, and reported, on [0, 1]: above the bottom the filter fixes at 0
  // (it was centred on [-1, 1], and the report said 0 to 0).
  {
    Document zero = bent;
    zero.mesh.setVertexScalar(prop::weight, Eigen::VectorXd::Zero(w.size()));
    const nlohmann::json flat = render(zero, {{"file", dir / "zero.png"}, {"property", "weight"}});
    CHECK(flat["scale_min"].get<double>() == 0.0);
    CHECK(flat["scale_max"].get<double>() == 1.0);
    fs::remove(dir / "zero.png");
  }

  // The same picture as the renderer with the documented options.
  RenderOptions options;
  options.property = prop::weight;
  options.site = ScalarSite::Vertex;
  options.rangeMin = 0.0;
  options.colormap = Colormap::Viridis;
  options.colorBarLabel = "weight";
  options.handles = bent.handles.allVertices();
  CHECK(sameImage(image, renderMesh(bent.mesh, options)));

  // Handle vertices are red dots; a vertex far from every handle has the low end's colour.
  const Projection proj(bent.mesh, options, renderLayout(bent.mesh, options).viewport);
  const Eigen::MatrixXd p = bent.mesh.positions();
  for (int v : options.handles)
    CHECK(pixelAt(image, proj.project(p.row(v).transpose())) == options.handleColor);
  // Away from the handles (the vertex of least weight inside the bar) the colour is viridis
  // at weight / max, in the dark low quarter of the map.
  int low = -1;
  for (int v = 0; v < w.size(); ++v)
    if (std::abs(bent.rest(v, 1) - 0.5) < 0.3 && (low < 0 || w[v] < w[low])) low = v;
  REQUIRE(low >= 0);
  CHECK(w[low] < 0.25 * w.maxCoeff());
  CHECK(distance(pixelAt(image, proj.project(p.row(low).transpose())),
                 colormap(Colormap::Viridis, w[low] / w.maxCoeff())) < 30);

  // handles=false leaves the dots out.
  Document plain = bent;
  render(plain, {{"file", file}, {"handles", "false"}});
  options.handles.clear();
  CHECK(sameImage(readPng(file), renderMesh(bent.mesh, options)));
}

TEST_CASE("render: distortion per element in turbo; the most distorted element is the hottest",
          "[filter][render]") {
  TempDir dir;
  const Document bent = bentBar();
  Document doc = bent;
  const std::string file = dir / "distortion.png";
  render(doc, {{"file", file}, {"property", "distortion"}, {"handles", "false"}});
  requireUnchanged(bent, doc);
  const Image image = readPng(file);

  RenderOptions options;
  options.property = prop::distortion;
  options.site = ScalarSite::Element;
  options.rangeMin = 0.0;
  options.colormap = Colormap::Turbo;
  options.colorBarLabel = "distortion";
  CHECK(sameImage(image, renderMesh(bent.mesh, options)));

  const Eigen::VectorXd d = bent.mesh.elementScalar(prop::distortion);
  const Eigen::MatrixXi e = bent.mesh.elements();
  const Eigen::MatrixXd p = bent.mesh.positions();
  const Projection proj(bent.mesh, options, renderLayout(bent.mesh, options).viewport);
  Eigen::Index hottest, coolest;
  d.maxCoeff(&hottest);
  d.minCoeff(&coolest);
  auto centroid = [&](Eigen::Index k) {
    return ((p.row(e(k, 0)) + p.row(e(k, 1)) + p.row(e(k, 2))) / 3.0).transpose().eval();
  };
  CHECK(distance(pixelAt(image, proj.project(centroid(hottest))), colormap(Colormap::Turbo, 1.0)) <
        30);
  CHECK(distance(pixelAt(image, proj.project(centroid(coolest))),
                 colormap(Colormap::Turbo, d[coolest] / d.maxCoeff())) < 30);

  // scale_max puts several pictures on one scale: twice the maximum halves every colour.
  render(doc, {{"file", file},
               {"property", "distortion"},
               {"handles", "false"},
               {"scale_max", std::to_string(2.0 * d.maxCoeff())}});
  CHECK(distance(pixelAt(readPng(file), proj.project(centroid(hottest))),
                 colormap(Colormap::Turbo, 0.5)) < 30);
}

TEST_CASE("render: smoothness with wireframe, no property, and a tet mesh by its boundary",
          "[filter][render]") {
  TempDir dir;
  Document doc = bentBar();
  render(doc, {{"file", dir / "smooth.png"}, {"property", "smoothness"}, {"wireframe", "true"}});
  RenderOptions options;
  options.property = prop::smoothness;
  options.site = ScalarSite::Element;
  options.rangeMin = 0.0;
  options.colormap = Colormap::Turbo;
  options.colorBarLabel = "smoothness";
  options.wireframe = true;
  options.handles = doc.handles.allVertices();
  CHECK(sameImage(readPng(dir / "smooth.png"), renderMesh(doc.mesh, options)));

  // property=none needs nothing: a grey mesh without colour bar.
  Document bare = Document::load(shipped("bar.obj"));
  render(bare, {{"file", dir / "none.png"},
                {"property", "none"},
                {"width", "400"},
                {"height", "300"},
                {"title", "rest shape"}});
  RenderOptions grey;
  grey.width = 400;
  grey.height = 300;
  grey.title = "rest shape";
  const Image none = readPng(dir / "none.png");
  CHECK(sameImage(none, renderMesh(bare.mesh, grey)));
  CHECK(renderLayout(bare.mesh, grey).colorBar.w == 0);

  // A tet mesh after deform: its boundary faces coloured by their tets' distortion.
  Document tet = Document::load(shipped("tetbar.mesh"), shipped("tetbar-bend.json"));
  Pipeline p;
  p.add("deform", {{"iterations", "5"}});
  p.add("render", {{"file", dir / "tet.png"}, {"property", "distortion"}});
  p.run(tet);
  const Image image = readPng(dir / "tet.png");
  RenderOptions t;
  t.property = prop::distortion;
  t.site = ScalarSite::Element;
  t.rangeMin = 0.0;
  t.colormap = Colormap::Turbo;
  t.colorBarLabel = "distortion";
  t.handles = tet.handles.allVertices();
  t.upAxis = 0;  // up=auto: the bar's longest side, x (its handles move along z)
  CHECK(sameImage(image, renderMesh(tet.mesh, t)));
  const PixelRect vp = renderLayout(tet.mesh, t).viewport;
  int painted = 0;
  for (int y = vp.y; y < vp.y + vp.h; ++y)
    for (int x = vp.x; x < vp.x + vp.w; ++x) painted += image.get(x, y) != t.background;
  CHECK(painted > vp.w * vp.h / 20);
  // up= given: that axis, not auto's.
  Pipeline upright;
  upright.add("render", {{"file", dir / "tet-z.png"}, {"property", "distortion"}, {"up", "z"}});
  upright.run(tet);
  t.upAxis = 2;
  const Image z = readPng(dir / "tet-z.png");
  CHECK(sameImage(z, renderMesh(tet.mesh, t)));
  CHECK(!sameImage(z, image));
}

TEST_CASE("render: the file is relative to the working directory and replaced atomically",
          "[filter][render]") {
  TempDir dir;
  Document doc = bentBar();
  const fs::path previous = fs::current_path();
  fs::current_path(dir.path);
  render(doc, {{"file", "relative.png"}, {"property", "distortion"}});
  render(doc, {{"file", "relative.png"}, {"property", "weight"}});  // replaces it
  fs::current_path(previous);
  REQUIRE(fs::exists(dir.path / "relative.png"));
  CHECK(dir.entries() == 1);
  RenderOptions options;
  options.property = prop::weight;
  options.site = ScalarSite::Vertex;
  options.rangeMin = 0.0;
  options.colorBarLabel = "weight";
  options.handles = doc.handles.allVertices();
  CHECK(sameImage(readPng(dir / "relative.png"), renderMesh(doc.mesh, options)));
}

TEST_CASE("render: bad paths and missing properties are one clear error, no file written",
          "[filter][render]") {
  TempDir dir;
  Document doc = Document::load(shipped("bar.obj"), shipped("bar-bend.json"));
  const Document before = doc;
  auto run = [&](std::map<std::string, std::string> values) {
    Pipeline p;
    p.add("render", values);
    p.run(doc);
  };
  auto oneLine = [](const std::string& message) { return message.find('\n') == std::string::npos; };

  // Missing property: caught by the pipeline's check, before any step runs.
  try {
    Pipeline p;
    p.add("render", {{"file", dir / "a.png"}, {"property", "distortion"}});
    p.run(doc);
    FAIL("no error");
  } catch (const MissingProperty& e) {
    CHECK_THAT(e.what(), Catch::Contains("diffreg:distortion") && Catch::Contains("deform"));
    CHECK(oneLine(e.what()));
  }
  // ... and by the filter itself when applied directly.
  const Filter& filter = Registry::builtin().get("render");
  CHECK_THROWS_AS(filter.apply(doc, ParamMap("render", filter.params(), {{"file", dir / "b.png"}})),
                  MissingProperty);

  Document weighted = doc;
  Pipeline w;
  w.add("diffuse_weights");
  w.run(weighted);
  auto runWeighted = [&](std::map<std::string, std::string> values) {
    Pipeline p;
    p.add("render", values);
    p.run(weighted);
  };
  // Unwritable places: a missing directory, a file in place of a directory, a read-only
  // directory (not for root, who may write anywhere).
  CHECK_THROWS_WITH(runWeighted({{"file", dir / "missing/w.png"}}),
                    Catch::Contains("missing/w.png") && Catch::Contains("does not exist"));
  CHECK_THROWS_AS(runWeighted({{"file", "/proc/diffreg.png"}}), IoError);
  if (::geteuid() != 0) {
    fs::create_directories(dir.path / "ro");
    fs::permissions(dir.path / "ro", fs::perms::owner_read | fs::perms::owner_exec);
    CHECK_THROWS_AS(runWeighted({{"file", dir / "ro/w.png"}}), IoError);
    fs::permissions(dir.path / "ro", fs::perms::owner_all);
  }
  // The file parameter is required and must name a PNG.
  CHECK_THROWS_WITH(run({{"property", "none"}}), Catch::Contains("'file' is required"));
  CHECK_THROWS_WITH(run({{"file", dir / "picture.ply"}, {"property", "none"}}),
                    Catch::Contains("picture.ply") && Catch::Contains(".png"));
  CHECK_THROWS_WITH(run({{"file", dir / "a.png"}, {"property", "energy"}}),
                    Catch::Contains("weight, distortion, smoothness, none"));
  CHECK_THROWS_AS(run({{"file", dir / "a.png"}, {"width", "10"}}), InvalidParameter);
  for (const auto& entry : fs::recursive_directory_iterator(dir.path))
    CHECK_FALSE(entry.is_regular_file());  // nothing written anywhere
  requireUnchanged(before, doc);

  // Every error of the filter is one line.
  for (const auto& values : std::vector<std::map<std::string, std::string>>{
           {{"file", dir / "missing/w.png"}}, {{"file", ""}}, {{"file", "x.jpg"}}}) {
    try {
      runWeighted(values);
      FAIL("no error");
    } catch (const Error& e) {
      CHECK(oneLine(e.what()));
    }
  }
}
