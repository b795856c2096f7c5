// One-shot cases: a whole `diffreg` run on a shared surface or a generated sphere written as
// OBJ, from the start of its process to its exit (the tool itself: `-i MESH --handles H --filter
// 'deform iterations=1' -o OUT.ply`), against CGAL's Surface_mesh_deformation reading the same
// file, preprocessing and deforming once, in the same run: timed in a process of its own with
// the tool's heap settings (the target's figure), and in this process. Handles: the 5% at both
// ends of the longest axis, one end pulled by 10% of the length (as the peer cases).
#include <diffreg/core/error.h>
#include <diffreg/core/timer.h>
#include <diffreg/mesh/io.h>
#include "bench.h"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

namespace diffreg::bench {
namespace {

namespace fs = std::filesystem;

struct OneShot {
  ToolRun run;  // the tool's files: a generated mesh in its directory
  std::vector<int> handles;
  Eigen::MatrixXd targets;
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
  std::ofstream(s.run.handles) << file.dump();
}

// The tool's whole run (from its start to its exit) and, from its report, the part from reading
// the input to writing the output.
std::pair<double, double> runTool(const OneShot& s) {
  Timer timer;
  runToolFilter(s.run, "deform iterations=1", "one-shot on " + s.run.mesh);
  const double seconds = timer.seconds();
  return {seconds, toolReport(s.run).at("seconds").at("total").get<double>()};
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
    if (!prepareToolRun(s.run)) {
      p.available = false;
      p.skipReason = "the diffreg tool is not beside diffreg-bench";
      return p;
    }
    const fs::path& dir = s.run.dir->path();
    Mesh mesh;
    std::string source;
    if (generated > 0) {
      BenchMesh made = sphereNear(generated);
      mesh = std::move(made.mesh);
      s.run.mesh = (dir / (made.label + ".obj")).string();
      writeMesh(s.run.mesh, mesh);
      source = made.source + ", written as " + s.run.mesh;
    } else if (!sharedMesh(file, mesh, s.run.mesh)) {
      p.available = false;
      p.skipReason = s.run.mesh + " absent";
      return p;
    } else {
      source = s.run.mesh;
    }
    const Eigen::MatrixXd rest = mesh.positions();
    const auto [fixed, moved] = endHandles(rest, 0.05);
    s.handles = fixed;
    s.handles.insert(s.handles.end(), moved.begin(), moved.end());
    s.targets = moveTargets(rest, fixed, moved, 0.10, 3);
    writeHandleFile(s, fixed.size(), rest);
    p.source = source;
    p.vertices = mesh.numVertices();
    p.elements = mesh.numElements();
    p.facts["handle_vertices"] = static_cast<double>(s.handles.size());
    return p;
  };
  c.release = [state] { *state = OneShot(); };  // removes the scratch directory
  c.run = [state] {
    const OneShot& s = *state;
    const auto [ours, readToWrite] = runTool(s);
    const double cgal = cgalOneShotInChild(s.run.mesh, s.handles, s.targets, 1, s.run.dir->path());
    const double warm = cgalOneShot(s.run.mesh, s.handles, s.targets, 1);
    return Sample{{"ours", ours},
                  {"ours_read_to_write", readToWrite},
                  {"cgal", cgal},
                  {"cgal_in_process", warm}};
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
