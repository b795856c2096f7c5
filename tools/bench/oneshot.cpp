// One-shot cases: a whole `diffreg` run on a shared surface or a generated sphere written as
// OBJ, from reading the file to writing the result (the tool itself, started as a process: `-i MESH
// --handles H --filter 'deform iterations=1' -o OUT.ply`), against CGAL's Surface_mesh_deformation
// reading the same file, preprocessing and deforming once, in the same run. Handles: the 5% at both
// ends of the longest axis, one end pulled by 10% of the length (as the peer cases).
#include <diffreg/core/error.h>
#include <diffreg/core/file.h>
#include <diffreg/core/timer.h>
#include <diffreg/mesh/io.h>
#include "bench.h"

#include <nlohmann/json.hpp>

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

extern char** environ;

namespace diffreg::bench {
namespace {

namespace fs = std::filesystem;

struct OneShot {
  std::string path, tool, handleFile, output;
  std::vector<int> handles;
  Eigen::MatrixXd targets;
  fs::path dir;
};

// Writes the handles as a diffreg handle file: the held end, and the pulled end with the
// (common) translation of its vertices.
void writeHandleFile(const OneShot& s, size_t held, const Eigen::MatrixXd& rest) {
  nlohmann::json fixed = nlohmann::json::array(), moved = nlohmann::json::array();
  for (size_t i = 0; i < s.handles.size(); ++i) (i < held ? fixed : moved).push_back(s.handles[i]);
  const Eigen::Index first = static_cast<Eigen::Index>(held);
  const Eigen::RowVector3d shift = s.targets.row(first) - rest.row(s.handles[held]);
  nlohmann::json file = {
      {"handles",
       {{{"name", "held"}, {"vertices", fixed}, {"translate", {0.0, 0.0, 0.0}}},
        {{"name", "pulled"}, {"vertices", moved}, {"translate", {shift(0), shift(1), shift(2)}}}}}};
  std::ofstream(s.handleFile) << file.dump();
}

double runTool(const OneShot& s) {
  std::vector<std::string> args = {
      s.tool, "-i",     s.path,   "--handles", s.handleFile, "--filter", "deform iterations=1",
      "-o",   s.output, "--quiet"};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  Timer timer;
  pid_t pid = 0;
  if (posix_spawn(&pid, s.tool.c_str(), nullptr, nullptr, argv.data(), environ) != 0)
    throw Error("one-shot: cannot start " + s.tool);
  int status = 0;
  waitpid(pid, &status, 0);
  const double seconds = timer.seconds();
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw Error("one-shot: " + s.tool + " failed on " + s.path);
  return seconds;
}

// A shared mesh (`file`), or with `generated` > 0 a UV sphere of about that many vertices,
// written as OBJ beside the handle file.
void addOneShotCase(std::vector<Case>& cases, const std::string& label, const std::string& file,
                    int generated = 0) {
  auto state = std::make_shared<OneShot>();
  Case c;
  c.group = "oneshot";
  c.name = "oneshot/" + label;
  c.prepare = [state, file, generated] {
    OneShot& s = *state;
    Prepared p;
    s.tool = besideThisExecutable("diffreg");  // the tool beside this benchmark
    if (s.tool.empty() || !fs::exists(s.tool)) {
      p.available = false;
      p.skipReason = "the diffreg tool is not beside diffreg-bench";
      return p;
    }
    s.dir = fs::temp_directory_path() / ("diffreg-bench-" + std::to_string(::getpid()));
    Mesh mesh;
    std::string source;
    if (generated > 0) {
      BenchMesh made = sphereNear(generated);
      mesh = std::move(made.mesh);
      fs::create_directories(s.dir);
      s.path = (s.dir / (made.label + ".obj")).string();
      writeMesh(s.path, mesh);
      source = made.source + ", written as " + s.path;
    } else if (!sharedMesh(file, mesh, s.path)) {
      p.available = false;
      p.skipReason = s.path + " absent";
      return p;
    } else {
      source = s.path;
    }
    const Eigen::MatrixXd rest = mesh.positions();
    const auto [fixed, moved] = endHandles(rest, 0.05);
    s.handles = fixed;
    s.handles.insert(s.handles.end(), moved.begin(), moved.end());
    s.targets = moveTargets(rest, fixed, moved, 0.10, 3);
    fs::create_directories(s.dir);
    s.handleFile = (s.dir / "handles.json").string();
    s.output = (s.dir / "out.ply").string();
    writeHandleFile(s, fixed.size(), rest);
    p.source = source;
    p.vertices = mesh.numVertices();
    p.elements = mesh.numElements();
    p.facts["handle_vertices"] = static_cast<double>(s.handles.size());
    return p;
  };
  c.release = [state] {
    std::error_code ec;
    if (!state->dir.empty()) fs::remove_all(state->dir, ec);
    *state = OneShot();
  };
  c.run = [state] {
    const OneShot& s = *state;
    const double ours = runTool(s);
    const double cgal = cgalOneShot(s.path, s.handles, s.targets, 1);
    return Sample{{"ours", ours}, {"cgal", cgal}};
  };
  cases.push_back(std::move(c));
}

}  // namespace

void addOneShotCases(std::vector<Case>& cases, const Sizes& sizes) {
  if (sizes.quick) return;
  addOneShotCase(cases, "rocker-arm", "surface-rocker-arm.obj");
  addOneShotCase(cases, "armadillo", "surface-armadillo.obj");
  addOneShotCase(cases, "beetle-20k", "surface-beetle-20k.off");
  addOneShotCase(cases, "sphere-10k", "", 10000);
}

}  // namespace diffreg::bench
