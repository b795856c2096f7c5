// The diffreg tool end to end: outputs on success, and on every bad input a non-zero exit,
// exactly one stderr line naming the culprit, and no output file.
#include <diffreg/mesh/io.h>
#include <diffreg/mesh/shapes.h>

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <sys/wait.h>
#include <unistd.h>

using namespace diffreg;
namespace fs = std::filesystem;

namespace {

struct Result {
  int code = -1;
  std::string out;
  std::vector<std::string> errLines;
};

std::string slurp(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// A scratch directory with a planar rectangle mesh (in.off) and a handle file (h.json).
class Workspace {
 public:
  Workspace() {
    dir_ = fs::temp_directory_path() / ("diffreg-cli-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    const Mesh mesh = makeRectangle(2.0, 1.0, 8, 4);
    vertices_ = mesh.numVertices();
    writeMesh((dir_ / "in.off").string(), mesh);
    std::ofstream(dir_ / "h.json") << R"({"handles": [
      {"name": "left", "nearest": [0, 0.5, 0], "translate": [0, 0, 0]},
      {"name": "right", "nearest": [2, 0.5, 0], "translate": [0, 0.5, 0], "magnitude": 0.5}]})";
    std::ofstream(dir_ / "bad.json") << R"({"handles": [ {"name": "a", )";
  }
  ~Workspace() { fs::remove_all(dir_); }
  const fs::path& dir() const { return dir_; }
  int vertices() const { return vertices_; }

  /// Runs the tool in the workspace with `args` (shell words).
  Result run(const std::string& args) const {
    const std::string command = "cd '" + dir_.string() + "' && '" + DIFFREG_TOOL + "' " + args +
                                " > stdout.txt 2> stderr.txt";
    const int status = std::system(command.c_str());
    Result r;
    r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.out = slurp(dir_ / "stdout.txt");
    std::istringstream err(slurp(dir_ / "stderr.txt"));
    for (std::string line; std::getline(err, line);) r.errLines.push_back(line);
    fs::remove(dir_ / "stdout.txt");
    fs::remove(dir_ / "stderr.txt");
    return r;
  }

  /// Files in the workspace other than the inputs.
  std::vector<std::string> outputs() const {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(dir_)) {
      const std::string name = entry.path().filename().string();
      if (name != "in.off" && name != "h.json" && name != "bad.json") names.push_back(name);
    }
    return names;
  }

 private:
  fs::path dir_;
  int vertices_ = 0;
};

bool haveTool() {
  if (fs::exists(DIFFREG_TOOL)) return true;
  WARN("skipping: the diffreg tool was not built at " << DIFFREG_TOOL);
  return false;
}

}  // namespace

TEST_CASE("diffreg writes a PLY with quality and colours, and a report") {
  if (!haveTool()) return;
  Workspace ws;
  const Result r = ws.run(
      "-i in.off --handles h.json --filter 'diffuse_weights t=0.02 order=second' -o out.ply "
      "--report report.json");
  INFO(r.errLines.size() << " stderr lines, first: " << (r.errLines.empty() ? "" : r.errLines[0]));
  REQUIRE(r.code == 0);

  const std::string ply = slurp(ws.dir() / "out.ply");
  const std::string header = ply.substr(0, ply.find("end_header"));
  CHECK(header.find("element vertex " + std::to_string(ws.vertices()) + "\n") != std::string::npos);
  CHECK(header.find("property double quality") != std::string::npos);
  CHECK(header.find("property uchar red") != std::string::npos);
  CHECK(header.find("property uchar green") != std::string::npos);
  CHECK(header.find("property uchar blue") != std::string::npos);

  const auto report = nlohmann::json::parse(slurp(ws.dir() / "report.json"));
  CHECK(report["mesh"]["kind"] == "planar");
  CHECK(report["mesh"]["vertices"] == ws.vertices());
  REQUIRE(report["filters"].size() == 1);
  const auto& entry = report["filters"][0];
  CHECK(entry["name"] == "diffuse_weights");
  CHECK(entry["params"]["t"] == "0.02");
  CHECK(entry["params"]["steps"] == "100");
  CHECK(entry["symbolic"] == 1);
  CHECK(entry["numeric"] == 1);
  CHECK(entry["solves"].get<int>() >= 1);
  CHECK(entry["max"].get<double>() == Approx(1.0).margin(1e-3));
  CHECK(entry["min"].get<double>() >= -1e-3);
  // Nothing but the two outputs is left behind (no temporary files).
  auto outputs = ws.outputs();
  std::sort(outputs.begin(), outputs.end());
  CHECK(outputs == std::vector<std::string>{"out.ply", "report.json"});

  // The PLY gives its weights back: a later run draws them without diffusing again, and writes
  // the same values.
  const Result again = ws.run("-i out.ply --filter 'render file=w.png' -o again.ply");
  INFO((again.errLines.empty() ? "" : again.errLines[0]));
  REQUIRE(again.code == 0);
  CHECK(fs::exists(ws.dir() / "w.png"));
  // The closing line names every file written, the filters' too.
  CHECK(again.errLines.back() == "diffreg: wrote w.png, again.ply");
  const std::string back = slurp(ws.dir() / "again.ply");
  CHECK(back.substr(back.find("end_header")) == ply.substr(ply.find("end_header")));
}

TEST_CASE("diffreg without filters converts formats; --quiet silences stderr") {
  if (!haveTool()) return;
  Workspace ws;
  const Result r = ws.run("-i in.off -o out.obj --quiet");
  CHECK(r.code == 0);
  CHECK(r.errLines.empty());
  CHECK(readMesh((ws.dir() / "out.obj").string()).numVertices() == ws.vertices());
}

TEST_CASE("diffreg: every bad input fails with one line and no output") {
  if (!haveTool()) return;
  Workspace ws;
  struct Case {
    const char* args;
    const char* culprit;
  };
  const Case cases[] = {
      {"-i missing.off -o out.ply", "missing.off"},
      {"-i in.off -o out.xyz", "out.xyz"},
      {"-i in.off --handles bad.json -f diffuse_weights -o out.ply", "bad.json"},
      {"-i in.off --handles nothere.json -f diffuse_weights -o out.ply", "nothere.json"},
      {"-i in.off --handles h.json -f 'smooth_all' -o out.ply", "smooth_all"},
      {"-i in.off --handles h.json -f 'diffuse_weights t=abc' -o out.ply", "'t' = 'abc'"},
      {"-i in.off --handles h.json -f 'diffuse_weights t=-1' -o out.ply", "out of range"},
      {"-i in.off --handles h.json -f 'diffuse_weights order=third' -o out.ply", "third"},
      {"-i in.off --handles h.json -f 'diffuse_weights tt=1' -o out.ply", "'tt'"},
      {"-i in.off --handles h.json -f 'diffuse_weights t' -o out.ply", "'t'"},
      {"-i in.off -f diffuse_weights -o out.ply --report r.json", "--handles"},
      {"-i in.off --handles h.json -f diffuse_weights -o out.ply --report no/r.json", "no/r.json"},
      {"-i in.off --handles h.json -o out.ply --bogus", "--bogus"},
      {"-i in.off", "-o"},
      {"-o out.ply", "-i"},
  };
  for (const auto& c : cases) {
    INFO("diffreg " << c.args);
    const Result r = ws.run(c.args);
    CHECK(r.code != 0);
    REQUIRE(r.errLines.size() == 1);
    CHECK(r.errLines[0].rfind("diffreg: error: ", 0) == 0);
    CHECK(r.errLines[0].find(c.culprit) != std::string::npos);
    CHECK(ws.outputs().empty());
  }
}

TEST_CASE("diffreg: usage errors exit with 2, other errors with 1") {
  if (!haveTool()) return;
  Workspace ws;
  CHECK(ws.run("-i in.off --nonsense -o out.ply").code == 2);
  CHECK(ws.run("-i in.off").code == 2);
  CHECK(ws.run("frobnicate").code == 2);
  // A mistyped command is told every command; the filters command takes no name.
  const auto typo = ws.run("compar -i in.off");
  CHECK(typo.code == 2);
  REQUIRE(typo.errLines.size() == 1);
  CHECK(typo.errLines[0] ==
        "diffreg: error: unexpected argument 'compar' (commands: filters, compare, serve, "
        "resolution; see diffreg --help)");
  const auto late = ws.run("-q compare -i in.off");
  CHECK(late.code == 2);
  CHECK(late.errLines ==
        std::vector<std::string>{"diffreg: error: 'compare' must come first: diffreg compare ... "
                                 "(see diffreg compare --help)"});
  const auto named = ws.run("filters deform");
  CHECK(named.code == 2);
  REQUIRE(named.errLines.size() == 1);
  CHECK(named.errLines[0].find("'deform': the filters command") != std::string::npos);
  CHECK(ws.run("-i missing.off -o out.ply").code == 1);
  CHECK(ws.run("-i in.off -f 'diffuse_weights t=abc' -o out.ply").code == 1);
  // Found before the mesh is read: a missing input is not what is reported.
  for (const char* after : {"nan", "-1", "inf"}) {
    const auto r = ws.run(std::string("-i missing.off -o out.ply --progress-after ") + after);
    CHECK(r.code == 2);
    REQUIRE(r.errLines.size() == 1);
    CHECK(r.errLines[0].find("--progress-after") != std::string::npos);
  }
}

TEST_CASE("diffreg: a failing run leaves an existing output untouched") {
  if (!haveTool()) return;
  Workspace ws;
  std::ofstream(ws.dir() / "out.ply") << "previous result";
  std::ofstream(ws.dir() / "report.json") << "previous report";
  const Result r =
      ws.run("-i in.off --handles h.json -f 'diffuse_weights steps=0' -o out.ply -r report.json");
  CHECK(r.code == 1);
  CHECK(slurp(ws.dir() / "out.ply") == "previous result");
  CHECK(slurp(ws.dir() / "report.json") == "previous report");
  CHECK(ws.outputs().size() == 2);
}

TEST_CASE("diffreg filters lists diffuse_weights with its parameters") {
  if (!haveTool()) return;
  Workspace ws;
  const Result r = ws.run("filters");
  REQUIRE(r.code == 0);
  CHECK(r.out.find("diffuse_weights") != std::string::npos);
  CHECK(r.out.find("Computer-Aided Design") != std::string::npos);
  for (const char* line : {"t = 0.01  (float in [1e-12, 1e6])",
                           "t_unit = diagonal  (enum: absolute | diagonal | mean_edge2)",
                           "order = second  (enum: first | second | implicit_euler)",
                           "steps = 100  (int in [1, 100000])"}) {
    CHECK(r.out.find(line) != std::string::npos);
  }

  const Result help = ws.run("--help");
  CHECK(help.code == 0);
  CHECK(help.out.find("--filter") != std::string::npos);
  CHECK(help.out.find("diffuse_weights") != std::string::npos);
  const Result version = ws.run("--version");
  CHECK(version.code == 0);
  CHECK(version.out.rfind("diffreg ", 0) == 0);
}
