// The software renderer: PNG files, colours at known pixels, the colour bar, handle markers
// (including occlusion), tet boundaries, shared framing, the bitmap font and error cases.

#include <diffreg/core/colormap.h>
#include <diffreg/core/error.h>
#include <diffreg/mesh/shapes.h>
#include <diffreg/render/render.h>

#include "test_support.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

using namespace diffreg;
using namespace diffreg::testing;
namespace fs = std::filesystem;

namespace {

int distance(const Rgb& a, const Rgb& b) {
  int d = 0;
  for (int c = 0; c < 3; ++c) d += std::abs(int(a[c]) - int(b[c]));
  return d;
}

int countNot(const Image& image, const Rgb& background) {
  int count = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) count += image.get(x, y) != background;
  return count;
}

Rgb pixelAt(const Image& image, const Eigen::Vector3d& projected) {
  return image.get(static_cast<int>(std::floor(projected.x())),
                   static_cast<int>(std::floor(projected.y())));
}

}  // namespace

TEST_CASE("3D views stand a shape on its longest side unless told otherwise", "[render]") {
  // A figure taller than wide stays upright whatever its handles do (compare, resolution and
  // render's up=auto all use this axis).
  const Eigen::AlignedBox3d standing(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0.5, 0.9, 0.3));
  CHECK(uprightAxis(standing) == 1);
  const Eigen::AlignedBox3d part(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0.3, 0.5, 1.0));
  CHECK(uprightAxis(part) == 2);
  CHECK(uprightAxis(Eigen::AlignedBox3d()) == 1);  // nothing to frame: y
  CHECK(uprightAxis(Eigen::AlignedBox3d(Eigen::Vector3d(-1, -1, -1), Eigen::Vector3d(1, 1, 1))) ==
        1);  // a sphere or a cube: y, as MeshLab shows a model
}

TEST_CASE("writePng writes a PNG that decodes to the same pixels") {
  TempDir dir;
  Image image(37, 21, {10, 20, 30});
  image.set(3, 4, {200, 100, 50});
  image.fillRect(30, 15, 5, 5, {0, 255, 0});
  const std::string path = (dir.path / "out.png").string();
  writePng(path, image);

  std::ifstream in(path, std::ios::binary);
  char signature[8] = {};
  in.read(signature, 8);
  const unsigned char expected[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  CHECK(std::equal(expected, expected + 8, reinterpret_cast<unsigned char*>(signature)));

  const Image back = readPng(path);
  CHECK(back.width == 37);
  CHECK(back.height == 21);
  CHECK(back.rgb == image.rgb);
  CHECK(dir.entries() == 1);  // no temporary file left next to it
}

TEST_CASE("a rendered picture round-trips through PNG at the requested size") {
  TempDir dir;
  RenderOptions options;
  options.width = 320;
  options.height = 200;
  const Image image = renderMesh(makeRectangle(2, 1, 4, 2), options);
  CHECK(image.width == 320);
  CHECK(image.height == 200);
  const std::string path = (dir.path / "mesh.png").string();
  writePng(path, image);
  const Image back = readPng(path);
  CHECK(back.width == 320);
  CHECK(back.height == 200);
  CHECK(back.rgb == image.rgb);
}

TEST_CASE("writePng failures throw IoError and leave nothing behind") {
  TempDir dir;
  const Image image(8, 8);
  SECTION("missing directory") {
    CHECK_THROWS_AS(writePng((dir.path / "missing" / "x.png").string(), image), IoError);
    CHECK(dir.entries() == 0);
  }
  SECTION("target is a directory: the temporary file is removed") {
    fs::create_directory(dir.path / "sub");
    CHECK_THROWS_AS(writePng((dir.path / "sub").string(), image), IoError);
    CHECK(dir.entries() == 1);
  }
  SECTION("empty image") {
    CHECK_THROWS_AS(writePng((dir.path / "x.png").string(), Image()), InvalidParameter);
    CHECK(dir.entries() == 0);
  }
  CHECK_THROWS_AS(readPng((dir.path / "none.png").string()), IoError);
}

TEST_CASE("a PNG name with a NUL byte is refused: the system would use the name cut there") {
  TempDir dir;
  const Image image(8, 8);
  writePng((dir.path / "cut").string(), image);  // a real PNG under the cut name
  const std::string named = (dir.path / "cut").string() + std::string(1, '\0') + ".png";
  CHECK_THROWS_WITH(readPng(named), Catch::EndsWith("the name has a NUL byte"));
  CHECK_THROWS_WITH(writePng(named, Image(4, 4)), Catch::EndsWith("the name has a NUL byte"));
  CHECK(readPng((dir.path / "cut").string()).width == 8);
  CHECK(dir.entries() == 1);
}

TEST_CASE("readPng rejects a file that is not a PNG") {
  TempDir dir;
  const std::string path = (dir.path / "fake.png").string();
  std::ofstream(path) << "not a png";
  CHECK_THROWS_AS(readPng(path), IoError);
}

TEST_CASE("a planar square with a constant scalar shows that colour") {
  Mesh square = makeRectangle(1, 1, 4, 4);
  RenderOptions options;
  options.values = Eigen::VectorXd::Constant(square.numVertices(), 0.3);
  auto centre = [&](const Image& image) {
    const PixelRect vp = renderLayout(square, options).viewport;
    return image.get(vp.x + vp.w / 2, vp.y + vp.h / 2);
  };

  SECTION("explicit range") {
    options.rangeMin = 0.0;
    options.rangeMax = 1.0;
    const Image image = renderMesh(square, options);
    CHECK(centre(image) == viridis(0.3));
    CHECK(image.get(options.width / 2, options.height / 2) == viridis(0.3));
  }
  SECTION("automatic range of constant data: the middle colour") {
    const Image image = renderMesh(square, options);
    CHECK(centre(image) == viridis(0.5));
  }
  SECTION("the value is stored as a vertex property") {
    square.setVertexScalar("diffreg:weight", options.values);
    options.values.resize(0);
    options.property = "diffreg:weight";
    options.rangeMin = 0.0;
    options.rangeMax = 0.6;
    const Image image = renderMesh(square, options);
    CHECK(centre(image) == viridis(0.5));
  }
}

TEST_CASE("a scalar ramp in x is dark on the left and bright on the right") {
  Mesh bar = makeRectangle(4, 1, 16, 4);
  const Eigen::MatrixXd p = bar.positions();
  bar.setVertexScalar("ramp", p.col(0) / 4.0);
  RenderOptions options;
  options.property = "ramp";
  options.wireframe = true;
  const Image image = renderMesh(bar, options);
  const Projection proj(bar, options, renderLayout(bar, options).viewport);
  const Rgb left = pixelAt(image, proj.project({0.2, 0.5, 0.0}));
  const Rgb right = pixelAt(image, proj.project({3.8, 0.5, 0.0}));
  CHECK(distance(left, viridis(0)) < distance(left, viridis(1)));
  CHECK(distance(right, viridis(1)) < distance(right, viridis(0)));
  // Along the bar the colour follows the map (away from edges, within rounding).
  const Rgb middle = pixelAt(image, proj.project({2.1, 0.55, 0.0}));
  CHECK(distance(middle, viridis(2.1 / 4.0)) <= 24);
}

TEST_CASE("the colour bar runs from the low colour at the bottom to the high colour at the top") {
  Mesh mesh = makeRectangle(2, 1, 4, 2);
  mesh.setVertexScalar("x", mesh.positions().col(0));
  for (Colormap map : {Colormap::Viridis, Colormap::Coolwarm, Colormap::Turbo}) {
    RenderOptions options;
    options.property = "x";
    options.colormap = map;
    RenderLayout drawn;
    const Image image = renderMesh(mesh, options, &drawn);
    const RenderLayout layout = renderLayout(mesh, options);
    // The layout drawn is renderLayout's, its colour ends the data's range.
    CHECK(drawn.colorBar.x == layout.colorBar.x);
    CHECK(drawn.colorBar.h == layout.colorBar.h);
    CHECK(drawn.viewport.w == layout.viewport.w);
    CHECK(drawn.colorMin == 0.0);
    CHECK(drawn.colorMax == 2.0);
    const PixelRect bar = drawn.colorBar;
    REQUIRE(bar.h > 100);
    const int x = bar.x + bar.w / 2;
    CHECK(image.get(x, bar.y) == colormap(map, 1.0));
    CHECK(image.get(x, bar.y + bar.h - 1) == colormap(map, 0.0));
    CHECK(distance(image.get(x, bar.y + bar.h / 2), colormap(map, 0.5)) <= 6);
    // Tick labels are drawn to the right of the bar.
    int ink = 0;
    for (int y = bar.y - 10; y < bar.y + bar.h + 10; ++y)
      for (int xx = bar.x + bar.w + 2; xx < options.width; ++xx)
        ink += image.get(xx, y) != colors::white;
    CHECK(ink > 50);
  }
}

TEST_CASE("no scalar: no colour bar, the mesh in a neutral colour") {
  const Mesh square = makeRectangle(1, 1, 2, 2);
  RenderOptions options;
  const Image image = renderMesh(square, options);
  CHECK(renderLayout(square, options).colorBar.w == 0);
  CHECK(image.get(options.width / 2, options.height / 2) == options.noDataColor);
  // A reserved colour bar keeps the layout of the panels that show one, and stays blank.
  options.reserveColorBar = true;
  RenderOptions coloured = options;
  coloured.values = square.positions().col(0);
  coloured.rangeMin = 0.0;
  coloured.rangeMax = 1.0;
  options.rangeMin = 0.0;
  options.rangeMax = 1.0;
  const RenderLayout reserved = renderLayout(square, options);
  const RenderLayout shown = renderLayout(square, coloured);
  CHECK(reserved.viewport.w == shown.viewport.w);
  CHECK(reserved.colorBar.x == shown.colorBar.x);
  const Image blank = renderMesh(square, options);
  CHECK(blank.get(reserved.colorBar.x + 2, reserved.colorBar.y + 2) == colors::white);
}

TEST_CASE("element scalars colour each element flat") {
  Mesh square = makeRectangle(1, 1, 1, 1);  // 4 triangles around the centre
  const Eigen::MatrixXi e = square.elements();
  const Eigen::MatrixXd p = square.positions();
  Eigen::VectorXd d(e.rows());
  for (int k = 0; k < e.rows(); ++k) d[k] = k;
  square.setElementScalar("diffreg:distortion", d);
  RenderOptions options;
  options.property = "diffreg:distortion";
  options.colormap = Colormap::Turbo;
  const Image image = renderMesh(square, options);
  const Projection proj(square, options, renderLayout(square, options).viewport);
  for (int k = 0; k < e.rows(); ++k) {
    const Eigen::Vector3d centroid =
        (p.row(e(k, 0)) + p.row(e(k, 1)) + p.row(e(k, 2))).transpose() / 3.0;
    CHECK(pixelAt(image, proj.project(centroid)) == colormap(Colormap::Turbo, k / 3.0));
  }
}

TEST_CASE("diverging maps: blue is low, red is high") {
  for (Colormap map : {Colormap::Coolwarm, Colormap::Turbo}) {
    const Rgb low = colormap(map, 0.0), high = colormap(map, 1.0);
    CHECK(low[2] > low[0]);
    CHECK(high[0] > high[2]);
  }
  CHECK(colormap(Colormap::Viridis, 0.25) == viridis(0.25));
  CHECK(colormapFromString("turbo") == Colormap::Turbo);
  CHECK_THROWS_AS(colormapFromString("jet"), InvalidParameter);
}

TEST_CASE("handle markers are drawn at the projected vertex, hidden ones are not") {
  SECTION("planar") {
    Mesh bar = makeRectangle(4, 1, 8, 2);
    RenderOptions options;
    options.values = bar.positions().col(0);
    options.handles = {0, bar.numVertices() / 2};
    const Image image = renderMesh(bar, options);
    const Projection proj(bar, options, renderLayout(bar, options).viewport);
    const Eigen::MatrixXd p = bar.positions();
    for (int v : options.handles)
      CHECK(pixelAt(image, proj.project(p.row(v).transpose())) == options.handleColor);
  }
  SECTION("sphere seen from the side of one pole") {
    const Mesh sphere = makeSphere(1.0, 24, 12);
    const Eigen::MatrixXd p = sphere.positions();
    int front = 0, back = 0;  // largest and smallest z: the poles
    for (int i = 0; i < p.rows(); ++i) {
      if (p(i, 2) > p(front, 2)) front = i;
      if (p(i, 2) < p(back, 2)) back = i;
    }
    RenderOptions options;
    options.view = ViewMode::Orbit;
    options.yaw = 0;
    options.pitch = 0;
    options.upAxis = 1;  // looking along -z: the front pole faces the viewer
    const Projection proj(sphere, options, renderLayout(sphere, options).viewport);
    options.handles = {back};
    const Image hidden = renderMesh(sphere, options);
    CHECK(pixelAt(hidden, proj.project(p.row(back).transpose())) != options.handleColor);
    options.handles = {front};
    const Image shown = renderMesh(sphere, options);
    CHECK(pixelAt(shown, proj.project(p.row(front).transpose())) == options.handleColor);
  }
}

TEST_CASE("tet meshes are drawn by their boundary faces") {
  const Mesh box = makeTetBox(1, 1, 1, 3, 3, 3);
  const BoundaryFaces boundary = tetBoundary(box.tet());
  CHECK(boundary.faces.size() == 6u * 3 * 3 * 2);
  // Outward orientation: each face normal points away from the box centre.
  for (const auto& f : boundary.faces) {
    const Eigen::Vector3d a = box.tet().points[f[0]], b = box.tet().points[f[1]],
                          c = box.tet().points[f[2]];
    const Eigen::Vector3d centre(0.5, 0.5, 0.5);
    CHECK((b - a).cross(c - a).dot((a + b + c) / 3.0 - centre) > 0);
  }
  RenderOptions options;
  options.values = box.positions().col(2);
  options.wireframe = true;
  const Image image = renderMesh(box, options);
  const PixelRect vp = renderLayout(box, options).viewport;
  CHECK(image.get(vp.x + vp.w / 2, vp.y + vp.h / 2) != options.background);
}

TEST_CASE("3D views are shaded but keep the colour map's hue") {
  const Mesh cylinder = makeCylinder(0.5, 2.0, 24, 8);
  RenderOptions options;
  options.values = Eigen::VectorXd::Constant(cylinder.numVertices(), 1.0);
  options.rangeMin = 0.0;
  options.rangeMax = 1.0;
  options.upAxis = 2;
  const Image image = renderMesh(cylinder, options);
  const PixelRect vp = renderLayout(cylinder, options).viewport;
  const Rgb c = image.get(vp.x + vp.w / 2, vp.y + vp.h / 2);
  const Rgb yellow = viridis(1.0);
  // Darker or equal in every channel, never below the ambient share, green still dominant.
  for (int k = 0; k < 3; ++k) {
    CHECK(c[k] <= yellow[k]);
    CHECK(c[k] >= std::floor(0.35 * yellow[k]) - 1);
  }
  CHECK(c[1] > c[2]);
}

TEST_CASE("a shared frame draws several shapes at one scale") {
  const Mesh big = makeRectangle(2, 2, 4, 4);
  Mesh small = makeRectangle(2, 2, 4, 4);
  small.setPositions(small.positions() * 0.5);
  RenderOptions options;
  options.frame = meshBounds(big).extend(meshBounds(small));
  const double ratio = double(countNot(renderMesh(small, options), colors::white)) /
                       countNot(renderMesh(big, options), colors::white);
  CHECK(ratio == Approx(0.25).margin(0.02));
  // Without the frame each fills the viewport alike.
  options.frame.reset();
  CHECK(countNot(renderMesh(small, options), colors::white) ==
        Approx(countNot(renderMesh(big, options), colors::white)).epsilon(0.01));
}

TEST_CASE("wireframe darkens edges without hiding the colours") {
  const Mesh bar = makeRectangle(2, 1, 4, 2);
  RenderOptions options;
  options.values = bar.positions().col(0);
  const Image plain = renderMesh(bar, options);
  options.wireframe = true;
  const Image wired = renderMesh(bar, options);
  int darker = 0, same = 0;
  for (std::size_t i = 0; i < plain.rgb.size(); i += 3) {
    const int a = plain.rgb[i] + plain.rgb[i + 1] + plain.rgb[i + 2];
    const int b = wired.rgb[i] + wired.rgb[i + 1] + wired.rgb[i + 2];
    darker += b < a - 30;
    same += a == b;
  }
  CHECK(darker > 1000);
  CHECK(same > 10 * darker);
}

TEST_CASE("drawText draws the string inside its box") {
  Image image(60, 30);
  drawText(image, 5, 5, "0.5", colors::black, 2);
  const int w = textWidth("0.5", 2), h = textHeight(2);
  int inside = 0, outside = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      const bool ink = image.get(x, y) != colors::white;
      const bool in = x >= 5 && x < 5 + w && y >= 5 && y < 5 + h;
      (in ? inside : outside) += ink;
    }
  CHECK(inside > 20);
  CHECK(outside == 0);
  // Different strings give different pictures; clipping at the border is safe.
  Image other(60, 30);
  drawText(other, 5, 5, "0.6", colors::black, 2);
  CHECK(other.rgb != image.rgb);
  drawText(image, 55, 25, "Clip me", colors::black, 3);
  CHECK_THROWS_AS(drawText(image, 0, 0, "x", colors::black, 0), InvalidParameter);
}

TEST_CASE("composeGrid places panels in cells") {
  const Image a(30, 20, {255, 0, 0}), b(10, 10, {0, 0, 255});
  const Image grid = composeGrid({a, b, a}, 2, 5);
  CHECK(grid.width == 2 * 30 + 3 * 5);
  CHECK(grid.height == 2 * 20 + 3 * 5);
  CHECK(grid.get(5, 5) == Rgb{255, 0, 0});
  CHECK(grid.get(5 + 30 + 5 + 15, 5 + 10) == Rgb{0, 0, 255});  // centred in its cell
  CHECK(grid.get(5 + 30 + 5, 5) == colors::white);
  CHECK(grid.get(5, 5 + 20 + 5) == Rgb{255, 0, 0});
  CHECK_THROWS_AS(composeGrid({}, 2), InvalidParameter);
  CHECK_THROWS_AS(composeGrid({a}, 0), InvalidParameter);
}

TEST_CASE("bad render options are reported") {
  Mesh bar = makeRectangle(3, 1, 3, 1);  // 11 vertices, 12 triangles
  RenderOptions options;
  SECTION("unknown property") {
    options.property = "nothing";
    CHECK_THROWS_AS(renderMesh(bar, options), MissingProperty);
  }
  SECTION("values of the wrong size") {
    options.values = Eigen::VectorXd::Zero(bar.numVertices() + 5);
    CHECK_THROWS_AS(renderMesh(bar, options), InvalidParameter);
  }
  SECTION("element site with vertex-sized values") {
    options.values = Eigen::VectorXd::Zero(bar.numVertices());
    options.site = ScalarSite::Element;
    CHECK_THROWS_AS(renderMesh(bar, options), InvalidParameter);
  }
  SECTION("handle out of range") {
    options.handles = {bar.numVertices()};
    CHECK_THROWS_AS(renderMesh(bar, options), InvalidParameter);
  }
  SECTION("inverted range") {
    options.values = Eigen::VectorXd::Zero(bar.numVertices());
    options.rangeMin = 1.0;
    options.rangeMax = 0.0;
    CHECK_THROWS_AS(renderMesh(bar, options), InvalidParameter);
  }
  SECTION("sizes") {
    options.width = 0;
    CHECK_THROWS_AS(renderMesh(bar, options), InvalidParameter);
    options.width = 100;
    options.supersample = 9;
    CHECK_THROWS_AS(renderMesh(bar, options), InvalidParameter);
  }
  SECTION("NaN values are drawn in the no-data colour, not a crash") {
    Eigen::VectorXd v = Eigen::VectorXd::Constant(bar.numVertices(), NAN);
    options.values = v;
    const Image image = renderMesh(bar, options);
    const PixelRect vp = renderLayout(bar, options).viewport;
    CHECK(image.get(vp.x + vp.w / 2, vp.y + vp.h / 2) == options.noDataColor);
  }
}

TEST_CASE("an empty mesh renders a blank picture") {
  RenderOptions options;
  options.title = "empty";
  const Mesh empty;
  const Image image = renderMesh(empty, options);
  CHECK(image.width == options.width);
  CHECK(countNot(image, colors::white) > 0);  // the title
  const PixelRect vp = renderLayout(empty, options).viewport;
  CHECK(image.get(vp.x + vp.w / 2, vp.y + vp.h / 2) == colors::white);
}
