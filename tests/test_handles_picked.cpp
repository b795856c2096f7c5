// Handles from MeshLab PickedPoints (.pp) files: the nearest vertex of each active point, named
// points, one handle per point, paths relative to the handle file, and one-line errors.
#include <diffreg/core/error.h>
#include <diffreg/handles/handles.h>

#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>

#include <unistd.h>

using namespace diffreg;
using Catch::Contains;
namespace fs = std::filesystem;

namespace {

/// Planar 4 x 4 grid of unit cells' corners at z = 0: vertex 4 j + i at (i, j).
Mesh grid() {
  TriMesh m;
  std::vector<TriMesh::VertexHandle> v;
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 4; ++i) v.push_back(m.add_vertex({double(i), double(j), 0.0}));
  for (int j = 0; j < 3; ++j) {
    for (int i = 0; i < 3; ++i) {
      const int a = 4 * j + i;
      m.add_face(v[a], v[a + 1], v[a + 5]);
      m.add_face(v[a], v[a + 5], v[a + 4]);
    }
  }
  return Mesh(m);
}

// As MeshLab's PickPoints editor saves them: a DocumentData block, then the points.
const char* kPicked = R"(<!DOCTYPE PickedPoints>
<PickedPoints>
 <DocumentData>
  <DateTime time="10:00:00" date="2024-01-01"/>
  <User name="someone"/>
  <DataFileName name="grid.ply"/>
  <templateName name=""/>
 </DocumentData>
 <point x="0.1" y="0.2" z="0" active="1" name="a"/>
 <point x="2.9" y="0.1" z="0" active="1" name="b"/>
 <point x="1.1" y="2.2" z="0.3" active="0" name="c"/>
 <point x="2.8" y="2.9" z="0" active="1" name="d"/>
</PickedPoints>
)";

/// A scratch directory with the handle files in `sub/` and .pp files beside them.
struct Scratch {
  fs::path dir = fs::temp_directory_path() / ("diffreg-picked-" + std::to_string(::getpid()));
  Scratch() {
    fs::remove_all(dir);
    fs::create_directories(dir / "sub");
    write("sub/points.pp", kPicked);
  }
  ~Scratch() { fs::remove_all(dir); }
  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(dir / name) << text;
    return (dir / name).string();
  }
  /// Writes `json` as sub/h.json and reads it (relative .pp paths resolve against sub/).
  HandleSet read(const std::string& json) const {
    return readHandles(write("sub/h.json", json), grid());
  }
  /// The message of the error `json` raises; fails when it reads.
  template <class E = InvalidParameter>
  std::string error(const std::string& json) const {
    try {
      read(json);
    } catch (const E& e) {
      const std::string what = e.what();
      CHECK(what.find('\n') == std::string::npos);
      CHECK_THAT(what, Contains("h.json"));
      return what;
    }
    FAIL("no error for " << json);
    return "";
  }
};

}  // namespace

TEST_CASE("readPickedPoints reads MeshLab's PickedPoints format", "[handles][picked]") {
  Scratch s;
  const auto points = readPickedPoints((s.dir / "sub/points.pp").string());
  REQUIRE(points.size() == 4);
  CHECK(points[0].name == "a");
  CHECK(points[0].position == Eigen::Vector3d(0.1, 0.2, 0.0));
  CHECK(points[0].line == 9);
  CHECK(points[2].name == "c");
  CHECK_FALSE(points[2].active);
  CHECK(points[3].active);
  // Without active and name attributes: active, unnamed.
  const auto bare = parsePickedPoints("<PickedPoints><point x='1' y='2' z='3'/></PickedPoints>", "m");
  REQUIRE(bare.size() == 1);
  CHECK(bare[0].active);
  CHECK(bare[0].name.empty());
}

TEST_CASE("a handle selects the nearest vertex of every active picked point", "[handles][picked]") {
  Scratch s;
  const HandleSet set = s.read(R"({"handles": [
      {"name": "p", "picked": "points.pp", "translate": [0, 1]}]})");
  REQUIRE(set.handles.size() == 1);
  const Handle& h = set.handles[0];
  CHECK(h.vertices == std::vector<int>{0, 3, 15});  // c is inactive
  REQUIRE(h.targets.rows() == 3);
  CHECK(h.targets.row(0) == Eigen::RowVector3d(0, 1, 0));
  CHECK(h.targets.row(2) == Eigen::RowVector3d(3, 4, 0));

  // The same as "nearest" with the active points' coordinates.
  const HandleSet same = s.read(R"({"handles": [
      {"name": "p", "nearest": [[0.1, 0.2, 0], [2.9, 0.1, 0], [2.8, 2.9, 0]], "translate": [0, 1]}]})");
  CHECK(same.handles[0].vertices == h.vertices);
  CHECK(same.handles[0].targets == h.targets);
}

TEST_CASE("named picked points group into handles", "[handles][picked]") {
  Scratch s;
  const HandleSet set = s.read(R"({"handles": [
      {"name": "fixed", "picked": {"file": "points.pp", "names": ["d", "a"]}, "translate": [0, 0]},
      {"name": "moved", "picked": {"file": "points.pp", "names": ["b"]}, "translate": [1, 0],
       "range": 2, "magnitude": 0.5}]})");
  REQUIRE(set.handles.size() == 2);
  CHECK(set.handles[0].vertices == std::vector<int>{15, 0});  // in the order named
  CHECK(set.handles[1].vertices == std::vector<int>{3});
  CHECK(set.handles[1].targets.row(0) == Eigen::RowVector3d(4, 0, 0));
  CHECK(set.handles[1].range == 2.0);
  CHECK(set.handles[1].magnitude == 0.5);
}

TEST_CASE("handles_from_picked makes one handle per active point", "[handles][picked]") {
  Scratch s;
  SECTION("alone, with a shared motion, range and magnitude") {
    const HandleSet set = s.read(R"({"handles_from_picked":
        {"file": "points.pp", "translate": [0.5, 0], "range": 3, "magnitude": 0.25}})");
    REQUIRE(set.handles.size() == 3);
    const std::vector<std::string> names = {"a", "b", "d"};
    const std::vector<int> vertices = {0, 3, 15};
    for (size_t i = 0; i < 3; ++i) {
      CHECK(set.handles[i].name == names[i]);
      CHECK(set.handles[i].vertices == std::vector<int>{vertices[i]});
      CHECK(set.handles[i].range == 3.0);
      CHECK(set.handles[i].magnitude == 0.25);
    }
    CHECK(set.handles[2].targets.row(0) == Eigen::RowVector3d(3.5, 3, 0));
  }
  SECTION("after the listed handles, several entries, only named points") {
    const HandleSet set = s.read(R"({"handles": [{"name": "mid", "vertices": [5]}],
        "handles_from_picked": [{"file": "points.pp", "names": ["b"]},
                                {"file": "points.pp", "names": ["d"], "rotate":
                                 {"center": [3, 2], "degrees": 90}}]})");
    REQUIRE(set.handles.size() == 3);
    CHECK(set.handles[0].name == "mid");
    CHECK(set.handles[1].name == "b");
    CHECK(set.handles[2].name == "d");
    CHECK(set.handles[2].targets.row(0).isApprox(Eigen::RowVector3d(2, 2, 0), 1e-12));
  }
  SECTION("unnamed points are named after their position in the file") {
    s.write("sub/bare.pp", "<PickedPoints><point x='3' y='3' z='0'/></PickedPoints>");
    const HandleSet set = s.read(R"({"handles_from_picked": {"file": "bare.pp"}})");
    REQUIRE(set.handles.size() == 1);
    CHECK(set.handles[0].name == "picked0");
    CHECK(set.handles[0].vertices == std::vector<int>{15});
  }
}

TEST_CASE("picked paths resolve against the handle file's directory", "[handles][picked]") {
  Scratch s;
  // sub/h.json names "points.pp": found in sub/, whatever the working directory.
  CHECK(s.read(R"({"handles": [{"picked": "points.pp"}]})").handles.size() == 1);
  // An absolute path is taken as it is; "../" climbs from sub/.
  s.write("top.pp", "<PickedPoints><point x='1' y='1' z='0'/></PickedPoints>");
  const std::string absolute = (s.dir / "top.pp").string();
  CHECK(s.read(R"({"handles": [{"picked": ")" + absolute + R"("}]})").handles[0].vertices ==
        std::vector<int>{5});
  CHECK(s.read(R"({"handles": [{"picked": "../top.pp"}]})").handles[0].vertices ==
        std::vector<int>{5});
  // From text, relative to the base directory given (or the working directory).
  const HandleSet set = parseHandles(R"({"handles": [{"picked": "top.pp"}]})", grid(), "text",
                                     s.dir.string());
  CHECK(set.handles[0].vertices == std::vector<int>{5});
}

TEST_CASE("picked point errors name the handle file, the handle and the .pp file",
          "[handles][picked]") {
  Scratch s;
  s.write("sub/off.pp",
          "<PickedPoints>\n <point x='1' y='1' z='0' active='0' name='a'/>\n</PickedPoints>\n");
  s.write("sub/empty.pp", "<!DOCTYPE PickedPoints>\n<PickedPoints>\n</PickedPoints>\n");
  s.write("sub/broken.pp", "<PickedPoints>\n <point x='1' y='1' z='0'\n</PickedPoints>\n");
  s.write("sub/nan.pp", "<PickedPoints>\n\n <point x='1' y='one' z='0' name='q'/>\n</PickedPoints>");
  s.write("sub/flag.pp", "<PickedPoints>\n <point x='1' y='1' z='0' active='yes'/>\n</PickedPoints>");
  s.write("sub/noz.pp", "<PickedPoints>\n <point x='1' y='1'/>\n</PickedPoints>");
  s.write("sub/mlx.pp", "<!DOCTYPE FilterScript>\n<FilterScript/>\n");
  s.write("sub/close.pp",
          "<PickedPoints>\n <point x='1' y='1' z='0' name='u'/>\n"
          " <point x='1.1' y='0.9' z='0' name='v'/>\n</PickedPoints>\n");
  const std::string pp = (s.dir / "sub").string() + "/";

  SECTION("missing file") {
    const std::string what = s.error<IoError>(R"({"handles": [{"name": "h", "picked": "nope.pp"}]})");
    CHECK_THAT(what, Contains("handle 'h' (#0)"));
    CHECK_THAT(what, Contains("cannot open picked points file '" + pp + "nope.pp': no such file"));
  }
  SECTION("malformed files, with their line") {
    CHECK_THAT(s.error(R"({"handles": [{"picked": "broken.pp"}]})"),
               Contains(pp + "broken.pp:2: malformed XML: unterminated start tag <point>"));
    CHECK_THAT(s.error(R"({"handles": [{"picked": "nan.pp"}]})"),
               Contains(pp + "nan.pp:3: point 'q': y=\"one\" is not a finite number"));
    CHECK_THAT(s.error(R"({"handles": [{"picked": "flag.pp"}]})"),
               Contains("flag.pp:2: point: active=\"yes\" is not one of 1, 0, true, false"));
    CHECK_THAT(s.error(R"({"handles": [{"picked": "noz.pp"}]})"),
               Contains("noz.pp:2: point has no z attribute"));
    CHECK_THAT(s.error(R"({"handles": [{"picked": "mlx.pp"}]})"),
               Contains("mlx.pp:2: the root element is <FilterScript>"));
  }
  SECTION("no active points, no points") {
    CHECK_THAT(s.error(R"({"handles": [{"name": "h", "picked": "off.pp"}]})"),
               Contains("handle 'h' (#0): " + pp + "off.pp has no active points (all 1 are inactive)"));
    CHECK_THAT(s.error(R"({"handles_from_picked": {"file": "empty.pp"}})"),
               Contains("handles_from_picked #0: " + pp + "empty.pp has no points"));
  }
  SECTION("names not found or inactive") {
    CHECK_THAT(s.error(R"({"handles": [{"picked": {"file": "points.pp", "names": ["a", "z"]}}]})"),
               Contains("no point named 'z' in " + pp + "points.pp (names: 'a', 'b', 'c', 'd')"));
    CHECK_THAT(s.error(R"({"handles": [{"picked": {"file": "points.pp", "names": ["c"]}}]})"),
               Contains("point 'c' in " + pp + "points.pp is not active"));
    CHECK_THAT(s.error(R"({"handles_from_picked": {"file": "points.pp", "names": ["x"]}})"),
               Contains("handles_from_picked #0: no point named 'x'"));
    CHECK_THAT(s.error(R"({"handles": [{"picked": {"file": "points.pp", "names": []}}]})"),
               Contains("\"names\" must be a non-empty list"));
  }
  SECTION("two points on one vertex, a vertex in two handles") {
    CHECK_THAT(s.error(R"({"handles": [{"picked": "close.pp"}]})"),
               Contains("picked points 'u' (line 2) and 'v' (line 3) of " + pp +
                        "close.pp are both nearest to vertex 5"));
    CHECK_THAT(s.error(R"({"handles": [{"name": "x", "vertices": [0]}],
                           "handles_from_picked": {"file": "points.pp"}})"),
               Contains("vertex 0 is in handles 'x' and 'a'"));
    CHECK_THAT(s.error(R"({"handles": [{"name": "a", "vertices": [1]}],
                           "handles_from_picked": {"file": "points.pp"}})"),
               Contains("two handles are named 'a'"));
  }
  SECTION("bad keys and shapes") {
    CHECK_THAT(s.error(R"({"handles": [{"picked": "points.pp", "vertices": [1]}]})"),
               Contains("give exactly one of \"vertices\", \"nearest\", \"within\", \"picked\""));
    CHECK_THAT(s.error(R"({"handles": [{"picked": {"file": "points.pp", "name": ["a"]}}]})"),
               Contains("unknown key 'name' in \"picked\" (valid: file, names)"));
    CHECK_THAT(s.error(R"({"handles": [{"picked": 3}]})"),
               Contains("\"picked\" must be a .pp file name or"));
    CHECK_THAT(s.error(R"({"handles": [{"picked": {"names": ["a"]}}]})"),
               Contains("\"picked\" needs \"file\""));
    CHECK_THAT(s.error(R"({"handles_from_picked": {"file": "points.pp", "targets": [[0, 0]]}})"),
               Contains("handles_from_picked #0: unknown key 'targets' (valid: file, names, "
                        "translate, rotate, range, magnitude)"));
    CHECK_THAT(s.error(R"({"handles_from_picked": [{"file": "points.pp"}, {}]})"),
               Contains("handles_from_picked #1: needs \"file\""));
    CHECK_THAT(s.error(R"({"handles_from_picked": "points.pp"})"),
               Contains("\"handles_from_picked\" must be an object"));
    CHECK_THAT(s.error(R"({"handles_from_picked": {"file": "points.pp", "magnitude": -1}})"),
               Contains("handle 'a' (#0, from " + pp + "points.pp): \"magnitude\" must be >= 0"));
    CHECK_THAT(s.error(R"({"picked": "points.pp"})"),
               Contains("expected an object {\"handles\": [...]}"));
  }
}
