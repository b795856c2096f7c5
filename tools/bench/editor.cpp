// Editor cases: a drag step in the edit engine as `diffreg serve` runs it (non-uniform ARAP with
// diffused weights, the unregularized reference for Dist, the Table-1 metrics), on a shared
// surface: the update that follows a move of the pulled handle, with the editor's time budget
// (kEditorSeconds) and with the iterations alone (50, no time limit). Each update solves from
// the rest shape ("drags continue from the current shape" off, the editor's default).
#include <diffreg/core/timer.h>
#include <diffreg/engine/edit_engine.h>
#include "bench.h"

#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace diffreg::bench {
namespace {

struct Editor {
  std::unique_ptr<EditEngine> engine;
  EditState state;
  int step = 0;
};

struct EditorPair {
  Editor budget, unlimited;
  Eigen::MatrixXd rest;
  std::vector<int> fixed, moved;
};

// One engine with the two end handles at the first drag position, brought up to date (the
// factorizations and weights of the load are not part of a drag step).
void prepareEditor(Editor& e, const Mesh& mesh, const EditorPair& p, double seconds) {
  e.engine = std::make_unique<EditEngine>(mesh);
  const Eigen::MatrixXd T = moveTargets(p.rest, p.fixed, p.moved, 0.10, 3);
  HandleSet handles;
  handles.handles = {
      Handle{"held", p.fixed, T.topRows(static_cast<Eigen::Index>(p.fixed.size()))},
      Handle{"pulled", p.moved, T.bottomRows(static_cast<Eigen::Index>(p.moved.size()))}};
  EditParams params = e.engine->state().params;
  params.seconds = seconds;
  params.iterations = kEditorIterations;
  e.engine->setEdit(handles, params);
  e.state = e.engine->state();
  e.engine->update();
}

// One drag step: the pulled handle to the next of two positions, one update. Returns its
// seconds and iterations.
std::pair<double, int> dragStep(Editor& e, const EditorPair& p) {
  const double offset = (e.step++ % 2 == 0) ? 0.11 : 0.10;
  const Eigen::MatrixXd T = moveTargets(p.rest, p.fixed, p.moved, offset, 3);
  e.state.handles[1].targets = T.bottomRows(static_cast<Eigen::Index>(p.moved.size()));
  e.engine->setState(e.state);
  Timer timer;
  const UpdateReport u = e.engine->update();
  return {timer.seconds(), u.iterations};
}

void addEditorCase(std::vector<Case>& cases, const std::string& label, const std::string& file) {
  auto pair = std::make_shared<EditorPair>();
  Case c;
  c.group = "editor";
  c.name = "editor/" + label;
  c.prepare = [pair, file] {
    Prepared p;
    Mesh mesh;
    std::string path;
    if (!sharedMesh(file, mesh, path)) {
      p.available = false;
      p.skipReason = path + " absent";
      return p;
    }
    pair->rest = mesh.positions();
    std::tie(pair->fixed, pair->moved) = endHandles(pair->rest, 0.05);
    prepareEditor(pair->budget, mesh, *pair, kEditorSeconds);
    prepareEditor(pair->unlimited, mesh, *pair, 0.0);
    p.source = path;
    p.vertices = mesh.numVertices();
    p.elements = mesh.numElements();
    p.facts["handle_vertices"] = static_cast<double>(pair->fixed.size() + pair->moved.size());
    return p;
  };
  c.release = [pair] { *pair = EditorPair(); };
  c.run = [pair] {
    const auto [budget, budgetIterations] = dragStep(pair->budget, *pair);
    const auto [unlimited, unlimitedIterations] = dragStep(pair->unlimited, *pair);
    return Sample{{"budget", budget},
                  {"budget_iterations", budgetIterations},
                  {"unlimited", unlimited},
                  {"unlimited_iterations", unlimitedIterations}};
  };
  cases.push_back(std::move(c));
}

}  // namespace

void addEditorCases(std::vector<Case>& cases, const Sizes& sizes) {
  if (sizes.quick) return;
  addEditorCase(cases, "rocker-arm", "surface-rocker-arm.obj");
  addEditorCase(cases, "armadillo", "surface-armadillo.obj");
}

}  // namespace diffreg::bench
