// The shipped meshes (meshes/) are the generator's output, and every shipped scenario parses
// against its mesh and selects the vertices its README entry describes.
#include <diffreg/core/error.h>
#include <diffreg/handles/handles.h>
#include <diffreg/mesh/io.h>
#include <diffreg/mesh/shapes.h>

#include <catch2/catch.hpp>

#include <Eigen/Geometry>

#include <cmath>
#include <functional>
#include <string>

using namespace diffreg;

namespace {

const std::string kDir = std::string(DIFFREG_SOURCE_DIR) + "/meshes/";

const Handle& handleNamed(const HandleSet& set, const std::string& name) {
  for (const Handle& h : set.handles)
    if (h.name == name) return h;
  FAIL("no handle named " << name);
  throw std::logic_error("unreachable");
}

/// Rest position of vertex v.
Eigen::Vector3d rest(const Eigen::MatrixXd& positions, int v) {
  return positions.row(v).transpose();
}

/// Checks that `handle` moves every vertex by `motion` (rest -> target).
void checkMotion(const Eigen::MatrixXd& positions, const Handle& handle,
                 const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& motion) {
  REQUIRE(handle.targets.rows() == int(handle.vertices.size()));
  for (std::size_t k = 0; k < handle.vertices.size(); ++k) {
    const Eigen::Vector3d expected = motion(rest(positions, handle.vertices[k]));
    const Eigen::Vector3d target = handle.targets.row(int(k)).transpose();
    CHECK((target - expected).norm() < 1e-9);
  }
}

Eigen::Vector3d still(const Eigen::Vector3d& p) { return p; }

}  // namespace

TEST_CASE("shipped meshes equal the generator's output", "[scenarios]") {
  struct Entry {
    const char* file;
    std::function<Mesh()> make;
  };
  const Entry entries[] = {
      {"bar.obj", [] { return makeRectangle(8.0, 1.0, 32, 4); }},
      {"lshape.obj", [] { return makeLShape(2.0, 1.0, 8); }},
      {"ushape.obj", [] { return makeUShape(1.0, 1.0, 4.0, 4); }},
      {"disc.obj", [] { return makeDisc(1.0, 8); }},
      {"cylinder.obj", [] { return makeCylinder(1.0, 4.0, 24, 16); }},
      {"tetbar.mesh", [] { return makeTetBox(4.0, 1.0, 1.0, 16, 4, 4); }},
  };
  for (const Entry& e : entries) {
    INFO(e.file);
    const Mesh shipped = readMesh(kDir + e.file);
    const Mesh generated = e.make();
    CHECK(shipped.kind() == generated.kind());
    REQUIRE(shipped.numVertices() == generated.numVertices());
    REQUIRE(shipped.numElements() == generated.numElements());
    CHECK(shipped.elements() == generated.elements());
    // OBJ stores float coordinates (exact for the cell shapes and the tet box).
    CHECK((shipped.positions() - generated.positions()).cwiseAbs().maxCoeff() < 2e-6);
  }
}

TEST_CASE("bar-bend: left column fixed, middle point fixed, tip point raised by 2", "[scenarios]") {
  const Mesh mesh = readMesh(kDir + "bar.obj");
  const HandleSet set = readHandles(kDir + "bar-bend.json", mesh);
  const Eigen::MatrixXd p = mesh.positions();
  REQUIRE(set.handles.size() == 3);
  const Handle& left = handleNamed(set, "left-end");
  CHECK(left.vertices.size() == 5);
  for (int v : left.vertices) CHECK(p(v, 0) == 0.0);
  checkMotion(p, left, still);
  const Handle& middle = handleNamed(set, "middle");
  REQUIRE(middle.vertices.size() == 1);
  CHECK(rest(p, middle.vertices[0]) == Eigen::Vector3d(4.0, 0.5, 0.0));
  checkMotion(p, middle, still);
  const Handle& tip = handleNamed(set, "tip");
  REQUIRE(tip.vertices.size() == 1);
  CHECK(rest(p, tip.vertices[0]) == Eigen::Vector3d(7.5, 0.5, 0.0));
  checkMotion(p, tip, [](const Eigen::Vector3d& q) -> Eigen::Vector3d {
    return q + Eigen::Vector3d(0, 2, 0);
  });
  CHECK(tip.range == 2.0);
  CHECK(tip.magnitude == 0.5);
}

TEST_CASE("ushape-pull: bottom edge fixed, right arm tip pulled outward", "[scenarios]") {
  const Mesh mesh = readMesh(kDir + "ushape.obj");
  const HandleSet set = readHandles(kDir + "ushape-pull.json", mesh);
  const Eigen::MatrixXd p = mesh.positions();
  REQUIRE(set.handles.size() == 2);
  const Handle& base = handleNamed(set, "base");
  CHECK(base.vertices.size() == 13);
  for (int v : base.vertices) CHECK(p(v, 1) == 0.0);
  checkMotion(p, base, still);
  const Handle& tip = handleNamed(set, "right-tip");
  REQUIRE(tip.vertices.size() == 1);
  CHECK(rest(p, tip.vertices[0]) == Eigen::Vector3d(2.5, 4.0, 0.0));
  checkMotion(p, tip, [](const Eigen::Vector3d& q) -> Eigen::Vector3d {
    return q + Eigen::Vector3d(1.5, 0, 0);
  });
}

TEST_CASE("lshape-bend: top of the vertical arm fixed, horizontal arm tip raised", "[scenarios]") {
  const Mesh mesh = readMesh(kDir + "lshape.obj");
  const HandleSet set = readHandles(kDir + "lshape-bend.json", mesh);
  const Eigen::MatrixXd p = mesh.positions();
  REQUIRE(set.handles.size() == 2);
  const Handle& top = handleNamed(set, "top");
  CHECK(top.vertices.size() > 10);
  for (int v : top.vertices) CHECK((rest(p, v) - Eigen::Vector3d(0.5, 2.0, 0.0)).norm() <= 0.51);
  checkMotion(p, top, still);
  const Handle& tip = handleNamed(set, "tip");
  REQUIRE(tip.vertices.size() == 1);
  CHECK(rest(p, tip.vertices[0]) == Eigen::Vector3d(2.0, 0.5, 0.0));
  checkMotion(p, tip, [](const Eigen::Vector3d& q) -> Eigen::Vector3d {
    return q + Eigen::Vector3d(0, 1, 0);
  });
}

TEST_CASE("disc-drag: rim fixed, centre point dragged", "[scenarios]") {
  const Mesh mesh = readMesh(kDir + "disc.obj");
  const HandleSet set = readHandles(kDir + "disc-drag.json", mesh);
  const Eigen::MatrixXd p = mesh.positions();
  REQUIRE(set.handles.size() == 2);
  const Handle& rim = handleNamed(set, "rim");
  CHECK(rim.vertices.size() == 48);
  for (int v : rim.vertices) CHECK(std::abs(rest(p, v).norm() - 1.0) < 2e-6);
  checkMotion(p, rim, still);
  const Handle& centre = handleNamed(set, "centre");
  REQUIRE(centre.vertices.size() == 1);
  CHECK(rest(p, centre.vertices[0]).norm() == 0.0);
  checkMotion(p, centre, [](const Eigen::Vector3d& q) -> Eigen::Vector3d {
    return q + Eigen::Vector3d(0.3, 0.2, 0);
  });
}

TEST_CASE("cylinder-twist: bottom ring fixed, top ring turned 90 degrees", "[scenarios]") {
  const Mesh mesh = readMesh(kDir + "cylinder.obj");
  const HandleSet set = readHandles(kDir + "cylinder-twist.json", mesh);
  const Eigen::MatrixXd p = mesh.positions();
  REQUIRE(set.handles.size() == 2);
  const Handle& bottom = handleNamed(set, "bottom");
  CHECK(bottom.vertices.size() == 24);
  for (int v : bottom.vertices) CHECK(p(v, 2) == 0.0);
  checkMotion(p, bottom, still);
  const Handle& top = handleNamed(set, "top");
  CHECK(top.vertices.size() == 24);
  for (int v : top.vertices) CHECK(p(v, 2) == 4.0);
  checkMotion(p, top, [](const Eigen::Vector3d& q) -> Eigen::Vector3d {
    return Eigen::Vector3d(-q.y(), q.x(), q.z());
  });
}

TEST_CASE("tetbar-bend: left face fixed, right end pushed down by 1", "[scenarios]") {
  const Mesh mesh = readMesh(kDir + "tetbar.mesh");
  const HandleSet set = readHandles(kDir + "tetbar-bend.json", mesh);
  const Eigen::MatrixXd p = mesh.positions();
  REQUIRE(set.handles.size() == 2);
  const Handle& left = handleNamed(set, "left-face");
  CHECK(left.vertices.size() == 25);
  for (int v : left.vertices) CHECK(p(v, 0) == 0.0);
  checkMotion(p, left, still);
  const Handle& right = handleNamed(set, "right-end");
  CHECK(right.vertices.size() == 5);
  for (int v : right.vertices) CHECK(p(v, 0) == 4.0);
  checkMotion(p, right, [](const Eigen::Vector3d& q) -> Eigen::Vector3d {
    return q + Eigen::Vector3d(0, 0, -1);
  });
}
