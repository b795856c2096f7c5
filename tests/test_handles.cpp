// Handle files: selections, motions, errors and the JSON round trip (modules/handles).

#include <diffreg/core/error.h>
#include <diffreg/handles/handles.h>
#include <diffreg/mesh/shapes.h>

#include <catch2/catch.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>

using namespace diffreg;
using Catch::Contains;

namespace {

/// Planar 3 x 3 grid of unit cells at z = 0 (vertex 3 j + i at (i, j)), plus an unreferenced
/// vertex 9 at (5, 5).
Mesh grid() {
  TriMesh m;
  std::vector<TriMesh::VertexHandle> v;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) v.push_back(m.add_vertex({double(i), double(j), 0.0}));
  m.add_vertex({5.0, 5.0, 0.0});
  for (int j = 0; j < 2; ++j) {
    for (int i = 0; i < 2; ++i) {
      const int a = 3 * j + i;
      m.add_face(v[a], v[a + 1], v[a + 4]);
      m.add_face(v[a], v[a + 4], v[a + 3]);
    }
  }
  return Mesh(m);
}

/// Surface of the unit tetrahedron (0,0,0), (1,0,0), (0,1,0), (0,0,1).
Mesh tetSurface() {
  TriMesh m;
  auto a = m.add_vertex({0, 0, 0}), b = m.add_vertex({1, 0, 0}), c = m.add_vertex({0, 1, 0}),
       d = m.add_vertex({0, 0, 1});
  m.add_face(a, c, b);
  m.add_face(a, b, d);
  m.add_face(a, d, c);
  m.add_face(b, c, d);
  return Mesh(m);
}

HandleSet parse(const std::string& text, const Mesh& mesh) {
  return parseHandles(text, mesh, "h.json");
}

/// The InvalidParameter message for `text` (fails when it parses).
std::string error(const std::string& text, const Mesh& mesh) {
  try {
    parse(text, mesh);
  } catch (const InvalidParameter& e) {
    const std::string what = e.what();
    CHECK(what.find('\n') == std::string::npos);
    CHECK_THAT(what, Contains("h.json"));
    return what;
  }
  FAIL("no InvalidParameter for " << text);
  return "";
}

void checkRow(const Eigen::MatrixXd& m, int row, const Eigen::Vector3d& expect) {
  INFO("row " << row << ": " << m.row(row) << " expected " << expect.transpose());
  CHECK((m.row(row).transpose() - expect).norm() < 1e-12);
}

}  // namespace

TEST_CASE("selections", "[handles]") {
  const Mesh mesh = grid();
  SECTION("ids, default names, range and magnitude") {
    const HandleSet set = parse(
        R"({"handles": [{"vertices": [0, 2]}, {"vertices": [8], "range": 2.5, "magnitude": 0}]})",
        mesh);
    REQUIRE(set.handles.size() == 2);
    CHECK(set.handles[0].name == "handle0");
    CHECK(set.handles[1].name == "handle1");
    CHECK(set.handles[0].vertices == std::vector<int>{0, 2});
    CHECK(set.handles[0].range == 1.0);
    CHECK(set.handles[0].magnitude == 1.0);
    CHECK(set.handles[1].range == 2.5);
    CHECK(set.handles[1].magnitude == 0.0);
    // No motion: the targets are the rest positions.
    checkRow(set.handles[0].targets, 1, {2, 0, 0});
    CHECK(set.allVertices() == std::vector<int>{0, 2, 8});
    const auto owner = set.handleOfVertex(10);
    CHECK(owner[0] == 0);
    CHECK(owner[8] == 1);
    CHECK(owner[4] == -1);
    CHECK_THROWS_AS(set.handleOfVertex(5), InvalidParameter);
  }
  SECTION("nearest: one point or a list, referenced vertices only") {
    const HandleSet set = parse(
        R"({"handles": [{"name": "a", "nearest": [1.9, 0.2]},
                        {"name": "b", "nearest": [[0.1, 1.2, 0], [4.9, 4.9]]}]})",
        mesh);
    CHECK(set.handles[0].vertices == std::vector<int>{2});
    // (4.9, 4.9) is next to the unreferenced vertex 9, so it picks the grid corner 8.
    CHECK(set.handles[1].vertices == std::vector<int>{3, 8});
  }
  SECTION("within a radius") {
    const HandleSet set =
        parse(R"({"handles": [{"within": {"center": [0, 0], "radius": 1.0}}]})", mesh);
    CHECK(set.handles[0].vertices == std::vector<int>{0, 1, 3});
  }
}

TEST_CASE("motions", "[handles]") {
  SECTION("translate on a planar mesh with a 2-vector") {
    const HandleSet set =
        parse(R"({"handles": [{"vertices": [4, 5], "translate": [0.5, -1]}]})", grid());
    checkRow(set.handles[0].targets, 0, {1.5, 0, 0});
    checkRow(set.handles[0].targets, 1, {2.5, 0, 0});
  }
  SECTION("rotate 90 degrees about z maps (1,0,0) to (0,1,0)") {
    const HandleSet set = parse(
        R"({"handles": [{"vertices": [1], "rotate": {"center": [0,0,0], "axis": [0,0,1], "degrees": 90}},
                        {"vertices": [3], "rotate": {"center": [0,0,0], "axis": [2,0,0], "degrees": 90}}]})",
        tetSurface());
    checkRow(set.handles[0].targets, 0, {0, 1, 0});
    // Right-hand rule about +x: z goes to -y.
    checkRow(set.handles[1].targets, 0, {0, -1, 0});
  }
  SECTION("planar rotation: axis defaults to z, centre to the handle's centroid") {
    const Mesh mesh = grid();
    const HandleSet set = parse(
        R"({"handles": [{"vertices": [2], "rotate": {"center": [0, 0], "degrees": 90}},
                        {"vertices": [6, 8], "rotate": {"degrees": 180}}]})",
        mesh);
    checkRow(set.handles[0].targets, 0, {0, 2, 0});
    checkRow(set.handles[1].targets, 0, {2, 2, 0});
    checkRow(set.handles[1].targets, 1, {0, 2, 0});
  }
  SECTION("absolute targets, 2 or 3 entries on a planar mesh") {
    const HandleSet set =
        parse(R"({"handles": [{"vertices": [0, 8], "targets": [[-1, -1], [3, 3, 0]]}]})", grid());
    checkRow(set.handles[0].targets, 0, {-1, -1, 0});
    checkRow(set.handles[0].targets, 1, {3, 3, 0});
  }
}

TEST_CASE("handle file errors name the file and the handle", "[handles]") {
  const Mesh mesh = grid();
  CHECK_THAT(error("{\"handles\": [ {\"vertices\": [1,] } ]}", mesh),
             Contains("malformed JSON") && Contains("line 1, column"));
  // Not the last of two (nlohmann's default), nor what comes before a NUL byte.
  CHECK_THAT(error(R"({"handles": [{"vertices": [1]}], "handles": []})", mesh),
             Contains("malformed JSON: key 'handles' twice in one object"));
  CHECK_THAT(error(R"({"handles": [{"vertices": [1], "vertices": [2]}]})", mesh),
             Contains("key 'vertices' twice"));
  CHECK_THAT(error(std::string(R"({"handles": [{"vertices": [1]}]})") + '\0' + "}", mesh),
             Contains("malformed JSON: a NUL byte at offset 32"));
  CHECK_THAT(error("[1, 2]", mesh), Contains("\"handles\""));
  CHECK_THAT(error("{\"handle\": []}", mesh), Contains("\"handles\""));
  CHECK_THAT(error(R"({"handles": [], "extra": 1})", mesh), Contains("unknown key 'extra'"));
  CHECK_THAT(error(R"({"handles": [{"name": "head", "vertex": [1]}]})", mesh),
             Contains("'head'") && Contains("unknown key 'vertex'") &&
                 Contains("valid: name, vertices, nearest, within"));
  CHECK_THAT(error(R"({"handles": [{"name": "head", "vertices": [10]}]})", mesh),
             Contains("'head'") && Contains("vertex id 10 out of range 0..9"));
  CHECK_THAT(error(R"({"handles": [{"vertices": [-1]}]})", mesh),
             Contains("handle0") && Contains("out of range"));
  CHECK_THAT(error(R"({"handles": [{"vertices": [1.5]}]})", mesh), Contains("integers"));
  CHECK_THAT(error(R"({"handles": [{"vertices": ["3"]}]})", mesh), Contains("integers"));
  CHECK_THAT(error(R"({"handles": [{"vertices": [9]}]})", mesh), Contains("not part of any"));
  CHECK_THAT(error(R"({"handles": [{"vertices": []}]})", mesh), Contains("empty handle"));
  CHECK_THAT(error(R"({"handles": [{"nearest": []}]})", mesh), Contains("empty handle"));
  CHECK_THAT(error(R"({"handles": [{"vertices": [1, 1]}]})", mesh), Contains("selected twice"));
  CHECK_THAT(
      error(R"({"handles": [{"name": "a", "vertices": [1, 2]}, {"name": "b", "vertices": [2]}]})",
            mesh),
      Contains("vertex 2 is in handles 'a' and 'b'"));
  CHECK_THAT(
      error(R"({"handles": [{"vertices": [1]}, {"name": "handle0", "vertices": [2]}]})", mesh),
      Contains("two handles are named 'handle0'"));
  CHECK_THAT(error(R"({"handles": [{"name": "r", "vertices": [1], "range": 0}]})", mesh),
             Contains("'r'") && Contains("\"range\" must be in [1e-6, 1e6]"));
  CHECK_THAT(error(R"({"handles": [{"vertices": [1], "range": -2}]})", mesh),
             Contains("\"range\" must be in [1e-6, 1e6]"));
  // A denormal range passed "> 0" and made the weights' system singular later.
  CHECK_THAT(error(R"({"handles": [{"vertices": [1], "range": 5e-324}]})", mesh),
             Contains("\"range\" must be in [1e-6, 1e6]"));
  CHECK_THAT(error(R"({"handles": [{"name": "m", "vertices": [1], "magnitude": -0.1}]})", mesh),
             Contains("'m'") && Contains("\"magnitude\" must be >= 0"));
  CHECK_THAT(error(R"({"handles": [{"vertices": [1], "magnitude": 1e999}]})", mesh),
             Contains("malformed JSON") && Contains("overflow"));
  CHECK_THAT(error(R"({"handles": [{"vertices": [1], "translate": [1e999, 0]}]})", mesh),
             Contains("malformed JSON") && Contains("overflow"));
  CHECK_THAT(error(R"({"handles": [{"vertices": [1], "range": "wide"}]})", mesh),
             Contains("must be a number"));
  CHECK_THAT(error(R"({"handles": [{"vertices": [1], "nearest": [0, 0]}]})", mesh),
             Contains("more than one selection"));
  CHECK_THAT(error(R"({"handles": [{"range": 1}]})", mesh), Contains("no selection"));
  CHECK_THAT(
      error(R"({"handles": [{"vertices": [1], "translate": [1, 0], "targets": [[0, 0]]}]})", mesh),
      Contains("at most one of"));
  CHECK_THAT(error(R"({"handles": [{"vertices": [1, 2], "targets": [[0, 0]]}]})", mesh),
             Contains("1 targets for 2 selected vertices"));
  CHECK_THAT(error(R"({"handles": [{"vertices": [1], "translate": [0, 0, 1]}]})", mesh),
             Contains("leaves the plane"));
  CHECK_THAT(error(R"({"handles": [{"within": {"center": [9, 9], "radius": 0.5}}]})", mesh),
             Contains("no vertex lies within"));
  CHECK_THAT(error(R"({"handles": [{"within": {"center": [0, 0], "radius": 0}}]})", mesh),
             Contains("radius must be > 0"));
  CHECK_THAT(error(R"({"handles": [{"within": {"center": [0, 0], "r": 1}}]})", mesh),
             Contains("unknown key 'r'"));
  CHECK_THAT(
      error(R"({"handles": [{"vertices": [1], "rotate": {"axis": [1, 0, 0], "degrees": 5}}]})",
            mesh),
      Contains("must be the z axis"));
  CHECK_THAT(error(R"({"handles": [{"vertices": [1], "rotate": {"center": [0, 0]}}]})", mesh),
             Contains("needs \"degrees\""));
  CHECK_THAT(error(R"({"handles": [7]})", mesh), Contains("#0") && Contains("must be an object"));

  const Mesh surf = tetSurface();
  CHECK_THAT(error(R"({"handles": [{"vertices": [1], "translate": [1, 0]}]})", surf),
             Contains("needs 3 entries"));
  CHECK_THAT(error(R"({"handles": [{"vertices": [1], "rotate": {"degrees": 5}}]})", surf),
             Contains("needs an \"axis\""));
  CHECK_THAT(
      error(R"({"handles": [{"vertices": [1], "rotate": {"axis": [0, 0, 0], "degrees": 5}}]})",
            surf),
      Contains("axis is zero"));
}

TEST_CASE("readHandles: unreadable files are IoError", "[handles]") {
  const Mesh mesh = grid();
  CHECK_THROWS_AS(readHandles("/nonexistent/dir/h.json", mesh), IoError);
  CHECK_THROWS_AS(readHandles(std::filesystem::temp_directory_path().string(), mesh), IoError);
  std::string tmpl = (std::filesystem::temp_directory_path() / "diffreg-handles-XXXXXX").string();
  REQUIRE(mkdtemp(tmpl.data()) != nullptr);
  const std::string path = tmpl + "/h.json";
  std::ofstream(path) << R"({"handles": [{"name": "x", "vertices": [20]}]})";
  try {
    readHandles(path, mesh);
    FAIL("no error");
  } catch (const InvalidParameter& e) {
    CHECK_THAT(e.what(), Contains(path) && Contains("'x'"));
  }
  std::filesystem::remove_all(tmpl);
}

TEST_CASE("handlesToJson parses back identically", "[handles]") {
  for (const Mesh& mesh : {grid(), tetSurface()}) {
    const bool planar = mesh.kind() == MeshKind::Planar;
    const std::string text =
        planar ? R"({"handles": [{"name": "tip", "vertices": [8, 5], "rotate": {"degrees": 33.3},
                                  "range": 0.3, "magnitude": 0.7},
                                 {"nearest": [0.1, 0.1], "translate": [0.1, 0.2]}]})"
               : R"({"handles": [{"vertices": [3], "rotate": {"axis": [1, 1, 0.3], "degrees": 17},
                                  "range": 1e-3},
                                 {"vertices": [0, 1], "translate": [0.1, 1e-7, 3]}]})";
    const HandleSet a = parse(text, mesh);
    const HandleSet b = parse(handlesToJson(a), mesh);
    REQUIRE(a.handles.size() == b.handles.size());
    for (size_t i = 0; i < a.handles.size(); ++i) {
      CHECK(a.handles[i].name == b.handles[i].name);
      CHECK(a.handles[i].vertices == b.handles[i].vertices);
      CHECK(a.handles[i].targets == b.handles[i].targets);
      CHECK(a.handles[i].range == b.handles[i].range);
      CHECK(a.handles[i].magnitude == b.handles[i].magnitude);
    }
  }
}

TEST_CASE("hostile handle values are refused up front, naming file, handle and field",
          "[handles][hostile]") {
  using Catch::Contains;
  const Mesh mesh = makeRectangle(1.0, 1.0, 3, 3);
  const auto message = [&](const std::string& json) {
    try {
      parseHandles(json, mesh, "h.json");
    } catch (const InvalidParameter& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  SECTION("magnitude above 1, with a short number") {
    const std::string m =
        message(R"({"handles": [{"name": "tip", "vertices": [1], "magnitude": 1e100}]})");
    CHECK_THAT(m, Contains("h.json") && Contains("'tip'") && Contains("\"magnitude\"") &&
                      Contains("<= 1") && Contains("got 1e100"));
    CHECK(m.size() < 160);
  }
  SECTION("a value just outside its range is not rounded onto the bound") {
    CHECK_THAT(message(R"({"handles": [{"vertices": [1], "range": 9.9999999e-7}]})"),
               Contains("got 9.9999999e-7"));
  }
  SECTION("a vertex id of 2^64-1 is reported as written") {
    CHECK_THAT(message(R"({"handles": [{"vertices": [18446744073709551615]}]})"),
               Contains("18446744073709551615") && Contains("out of range"));
  }
  SECTION("a rotate axis of length 1e300 is the x axis, not a collapse to a point") {
    const Mesh solid = makeRectangle(1.0, 1.0, 3, 3);
    Mesh bent = solid;
    Eigen::MatrixXd p = bent.positions();
    p(4, 2) = 0.3;  // not planar any more
    bent.setPositions(p);
    const HandleSet set = parseHandles(
        R"({"handles": [{"vertices": [0, 2, 8], "rotate": {"center": [0, 0, 0],
            "axis": [1e300, 0, 0], "degrees": 90}}]})",
        Mesh(bent.tri()), "h.json");
    const Eigen::MatrixXd t = set.handles[0].targets;
    const Eigen::MatrixXd r = bent.positions();
    for (int i = 0; i < 3; ++i) {
      const int v = set.handles[0].vertices[i];
      CHECK(t(i, 0) == Approx(r(v, 0)));  // x kept
      CHECK(std::hypot(t(i, 1), t(i, 2)) == Approx(std::hypot(r(v, 1), r(v, 2))));
    }
    CHECK((t.row(1) - t.row(2)).norm() == Approx((r.row(2) - r.row(8)).norm()));
  }
  SECTION("the reach is the referenced vertices': a far unreferenced vertex widens nothing") {
    TriMesh t = mesh.tri();  // the unit square, diagonal sqrt(2)
    t.add_vertex({1e6, 1e6, 0.0});
    const Mesh loose(t);
    // A target beside the square is taken (the edit engine, which paired the square's diagonal
    // with the centre of the box that took the stray vertex in, refused it).
    CHECK_NOTHROW(parseHandles(R"({"handles": [{"vertices": [1], "translate": [0.5, 0]}]})", loose,
                               "h.json"));
    // And 2000 units is over 1000 diagonals of the square, however far the stray vertex lies
    // (measured on the box with the stray vertex, the reach was 1.4e9).
    try {
      parseHandles(R"({"handles": [{"vertices": [1], "translate": [2000, 0]}]})", loose, "h.json");
      FAIL("a target 1400 diagonals away was taken");
    } catch (const InvalidParameter& e) {
      CHECK_THAT(e.what(), Contains("1000 mesh diagonals"));
    }
  }
  SECTION("a translate that overflows or goes far away") {
    CHECK_THAT(message(R"({"handles": [{"vertices": [1], "translate": [1e30, 0]}]})"),
               Contains("1000 mesh diagonals"));
    CHECK_THAT(message(R"({"handles": [{"vertices": [1], "translate": [1.7e308, 0]},
                                       {"vertices": [2], "translate": [1.7e308, 0]}]})"),
               Contains("target of vertex 1"));
  }
}
