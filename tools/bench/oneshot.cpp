// One-shot cases: a whole `diffreg` run on a shared surface or a generated sphere written as
// OBJ, from the start of its process to its exit (the tool itself: `-i MESH --handles H --filter
// 'deform iterations=1' -o OUT.ply`), against CGAL's Surface_mesh_deformation reading the same
// file, preprocessing and deforming once, in the same run: timed in a process of its own with
// the tool's heap settings (the target's figure), and in this process. Handles: the 5% at both
// ends of the longest axis, one end pulled by 10% of the length (as the peer cases).
#include <diffreg/core/error.h>
#include <diffreg/core/file.h>
#include <diffreg/core/heap.h>
#include <diffreg/core/timer.h>
#include <diffreg/mesh/io.h>
#include "bench.h"

#include <nlohmann/json.hpp>

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
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
  std::string path, tool, handleFile, targetFile, output, reportFile;
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

// The handles and their targets for the CGAL child: "count", then "vertex x y z" per handle.
void writeTargetFile(const OneShot& s) {
  std::ofstream file(s.targetFile);
  file.precision(17);
  file << s.handles.size() << "\n";
  for (size_t i = 0; i < s.handles.size(); ++i) {
    const Eigen::Index r = static_cast<Eigen::Index>(i);
    file << s.handles[i] << " " << s.targets(r, 0) << " " << s.targets(r, 1) << " "
         << s.targets(r, 2) << "\n";
  }
  if (!file) throw IoError("one-shot: cannot write " + s.targetFile);
}

// CGAL's read + preprocess + 1 iteration in a process of its own (this benchmark started with
// kCgalOneShotFlag, its heap set up as the tool's), timed inside it, without its start and
// exit: memory as fresh as the tool's, and the same allocator settings. Inside this
// benchmark's process (kept beside it) the time depends on what ran before (the 10K sphere:
// 55 ms after the other one-shot cases, 96 ms alone) and on glibc's default heap, which maps
// and clears CGAL's large blocks afresh.
double runCgalChild(const OneShot& s) {
  int fds[2];
  if (pipe(fds) != 0) throw Error("one-shot: pipe() failed");
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, fds[1], STDOUT_FILENO);
  posix_spawn_file_actions_addclose(&actions, fds[0]);
  posix_spawn_file_actions_addclose(&actions, fds[1]);
  std::vector<std::string> args = {"diffreg-bench", kCgalOneShotFlag, s.path, s.targetFile};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, "/proc/self/exe", &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  close(fds[1]);
  std::string output;
  char buffer[256];
  ssize_t got = 0;
  while (spawned == 0 && (got = read(fds[0], buffer, sizeof buffer)) > 0)
    output.append(buffer, static_cast<size_t>(got));
  close(fds[0]);
  if (spawned != 0) throw Error("one-shot: cannot start the CGAL child");
  int status = 0;
  waitpid(pid, &status, 0);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || output.empty())
    throw Error("one-shot: the CGAL child failed on " + s.path);
  return std::stod(output);
}

// The tool's whole run (from its start to its exit) and, from its report, the part from reading
// the input to writing the output.
std::pair<double, double> runTool(const OneShot& s) {
  std::vector<std::string> args = {
      s.tool, "-i",     s.path,    "--handles", s.handleFile, "--filter", "deform iterations=1",
      "-o",   s.output, "--quiet", "--report",  s.reportFile};
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
  const nlohmann::json report =
      nlohmann::json::parse(readFileLimited(s.reportFile, "report", 1 << 20));
  return {seconds, report.at("seconds").at("total").get<double>()};
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
    s.targetFile = (s.dir / "targets.txt").string();
    s.output = (s.dir / "out.ply").string();
    s.reportFile = (s.dir / "report.json").string();
    writeHandleFile(s, fixed.size(), rest);
    writeTargetFile(s);
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
    const auto [ours, readToWrite] = runTool(s);
    const double cgal = runCgalChild(s);
    const double warm = cgalOneShot(s.path, s.handles, s.targets, 1);
    return Sample{{"ours", ours},
                  {"ours_read_to_write", readToWrite},
                  {"cgal", cgal},
                  {"cgal_in_process", warm}};
  };
  cases.push_back(std::move(c));
}

}  // namespace

int runCgalOneShotChild(const std::string& path, const std::string& targetFile) {
  // The heap set up as the diffreg tool's (huge pages, large blocks kept), which CGAL gains from
  // as well; plain C reading, so that the heap is as fresh as the tool's when CGAL starts.
  tuneHeapForBatchRun();
  std::FILE* file = std::fopen(targetFile.c_str(), "r");
  if (!file) throw IoError("cannot open " + targetFile);
  long count = 0;
  if (std::fscanf(file, "%ld", &count) != 1 || count <= 0 || count > 100000000) {
    std::fclose(file);
    throw IoError("bad target file " + targetFile);
  }
  std::vector<int> handles(static_cast<size_t>(count));
  Eigen::MatrixXd targets(count, 3);
  for (long i = 0; i < count; ++i) {
    if (std::fscanf(file, "%d %lf %lf %lf", &handles[static_cast<size_t>(i)], &targets(i, 0),
                    &targets(i, 1), &targets(i, 2)) != 4) {
      std::fclose(file);
      throw IoError("bad target file " + targetFile);
    }
  }
  std::fclose(file);
  std::printf("%.9f\n", cgalOneShot(path, handles, targets, 1));
  return 0;
}

void addOneShotCases(std::vector<Case>& cases, const Sizes& sizes) {
  if (sizes.quick) return;
  addOneShotCase(cases, "rocker-arm", "surface-rocker-arm.obj");
  addOneShotCase(cases, "armadillo", "surface-armadillo.obj");
  addOneShotCase(cases, "beetle-20k", "surface-beetle-20k.off");
  addOneShotCase(cases, "sphere-10k", "", 10000);
}

}  // namespace diffreg::bench
