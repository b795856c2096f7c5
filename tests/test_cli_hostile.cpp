// The tool on hostile inputs and outputs: endless and special files, one output spelled two
// ways, targets that cannot be written, wrong picture extensions. Every failing run ends in
// one "diffreg: error:" line and leaves every output as it was.
#include "cli_fixture.h"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>

#include <filesystem>
#include <fstream>
#include <string>

using namespace diffreg::testing;

namespace {

/// True when `r` failed with exactly one error line that contains every one of `parts`.
bool oneErrorLine(const ToolRun& r, std::initializer_list<std::string> parts) {
  if (r.code == 0 || lineCount(r.err) != 1 || r.err.rfind("diffreg: error: ", 0) != 0) return false;
  for (const auto& p : parts)
    if (r.err.find(p) == std::string::npos) return false;
  return true;
}

/// A scratch directory with the shipped bar, its handles and an existing "old" output.
struct Bar : Scratch {
  explicit Bar(const std::string& tag) : Scratch(tag) {
    fs::copy_file(shipped("bar.obj"), dir / "bar.obj");
    fs::copy_file(shipped("bar-bend.json"), dir / "bend.json");
    std::ofstream(dir / "a.ply") << "old a";
    std::ofstream(dir / "b.ply") << "old b";
  }
  bool untouched() const {
    return slurp(dir / "a.ply") == "old a" && slurp(dir / "b.ply") == "old b";
  }
};

}  // namespace

TEST_CASE("endless and special input files are refused at once", "[cli][hostile]") {
  Bar w("hostile-in");
  SECTION("--handles /dev/zero") {
    const ToolRun r = w.run("-i bar.obj --handles /dev/zero -o a.ply");
    CHECK(oneErrorLine(r, {"/dev/zero", "not a regular file"}));
    CHECK(w.untouched());
  }
  SECTION("a FIFO as the mesh (no writer: reading it would wait forever)") {
    REQUIRE(::mkfifo((w.dir / "pipe.obj").c_str(), 0600) == 0);
    const ToolRun r = w.run("-i pipe.obj -o a.ply");
    CHECK(oneErrorLine(r, {"pipe.obj", "not a regular file"}));
    CHECK(w.untouched());
  }
  SECTION("picked points and scripts from /dev/zero") {
    std::ofstream(w.dir / "pp.json") << R"({"handles": [{"picked": "/dev/zero"}]})";
    CHECK(oneErrorLine(w.run("-i bar.obj --handles pp.json -o a.ply"), {"/dev/zero", "pp.json"}));
    CHECK(oneErrorLine(w.run("-i bar.obj -s /dev/zero -o a.ply"), {"/dev/zero"}));
    CHECK(w.untouched());
  }
}

TEST_CASE("outputs: one file under two spellings, bad targets, nothing changed", "[cli][hostile]") {
  Bar w("hostile-out");
  SECTION("-o a.ply -o ./a.ply") {
    CHECK(oneErrorLine(w.run("-i bar.obj -o a.ply -o ./a.ply"), {"a.ply", "twice"}));
  }
  SECTION("-o b.ply --report ./b.ply, and through a symbolic link") {
    CHECK(oneErrorLine(w.run("-i bar.obj -o b.ply --report ./b.ply"),
                       {"b.ply", "twice", "--report"}));
    fs::create_directory_symlink(w.dir, w.dir / "here");
    CHECK(oneErrorLine(w.run("-i bar.obj -o b.ply -o here/b.ply"), {"b.ply", "twice"}));
  }
  SECTION("a later output that is a directory") {
    fs::create_directory(w.dir / "d.ply");
    CHECK(oneErrorLine(w.run("-i bar.obj -o a.ply -o d.ply"), {"d.ply", "directory"}));
  }
  SECTION("compare -o with a mesh extension writes no PNG into it") {
    const ToolRun r = w.run("compare -i bar.obj --handles bend.json -o m.ply");
    CHECK(oneErrorLine(r, {"m.ply", "png"}));
    CHECK_FALSE(w.has("m.ply"));
  }
  CHECK(w.untouched());
  CHECK(w.files() == 4 + (w.has("d.ply") ? 1 : 0) + (w.has("here") ? 1 : 0));
}

TEST_CASE("a mesh that reads as a different one is refused, nothing written", "[cli][hostile]") {
  Bar w("hostile-mesh");
  SECTION("a tet listed twice (its boundary surface would be wrong)") {
    std::ofstream(w.dir / "twice.mesh")
        << "MeshVersionFormatted 2\nDimension 3\nVertices\n5\n0 0 0 0\n1 0 0 0\n0 1 0 0\n"
           "0 0 1 0\n1 1 1 0\nTetrahedra\n3\n1 2 3 4 0\n1 2 3 4 0\n2 5 3 4 0\nEnd\n";
    const ToolRun r = w.run("-i twice.mesh -o a.ply -o t.mesh");
    CHECK(oneErrorLine(r, {"twice.mesh", "tets 0 and 1"}));
    CHECK_FALSE(w.has("t.mesh"));
  }
  SECTION("an ASCII PLY uchar of 300, a PLY format 2.0") {
    const std::string header =
        "element vertex 3\nproperty uchar x\nproperty float y\nproperty float z\n"
        "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
    std::ofstream(w.dir / "big.ply")
        << "ply\nformat ascii 1.0\n" + header + "300 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    std::ofstream(w.dir / "two.ply")
        << "ply\nformat ascii 2.0\n" + header + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    CHECK(oneErrorLine(w.run("-i big.ply -o a.ply -o t.obj"), {"big.ply:10", "vertex 0", "300"}));
    CHECK(oneErrorLine(w.run("-i two.ply -o a.ply -o t.obj"), {"two.ply:2", "format ascii 2.0"}));
    CHECK_FALSE(w.has("t.obj"));
  }
  CHECK(w.untouched());
}

TEST_CASE("diffreg serve stops on SIGTERM", "[cli][hostile][serve]") {
  Bar w("hostile-serve");
  int out[2];
  REQUIRE(::pipe(out) == 0);
  const pid_t pid = ::fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    ::dup2(out[1], 1);
    ::close(out[0]);
    const std::string mesh = (w.dir / "bar.obj").string();
    ::execl(DIFFREG_TOOL, DIFFREG_TOOL, "serve", "-i", mesh.c_str(), "--port", "0", "--quiet",
            static_cast<char*>(nullptr));
    std::_Exit(127);
  }
  ::close(out[1]);
  std::string line;
  char c = 0;
  while (::read(out[0], &c, 1) == 1 && c != '\n') line += c;  // the URL: it is serving
  CHECK(line.find("http://127.0.0.1:") != std::string::npos);
  ::kill(pid, SIGTERM);
  int status = 0;
  REQUIRE(::waitpid(pid, &status, 0) == pid);
  ::close(out[0]);
  CHECK(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 0);
}

TEST_CASE("an input file name that is not UTF-8 reaches the report escaped", "[cli][hostile]") {
  Bar w("hostile-name");
  const std::string name = "b\xff\xfe.obj";
  fs::copy_file(w.dir / "bar.obj", w.dir / name);
  const ToolRun r = w.run("-i '" + name + "' -o out.ply --report r.json --quiet");
  INFO(r.err);
  REQUIRE(r.code == 0);
  const nlohmann::json report = nlohmann::json::parse(slurp(w.dir / "r.json"));
  CHECK(report.at("mesh").at("path") == "b\\xff\\xfe.obj");
}
