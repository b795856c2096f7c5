// The benchmark cases on diffreg itself: diffused weights (eq. 7 / eq. 8), the regularized ARAP
// session, the CGAL peer's problem set-up and the memory probe's session.
#include <diffreg/core/error.h>
#include <diffreg/core/timer.h>
#include <diffreg/deformation/deformer.h>
#include <diffreg/discretization/discretization.h>
#include <diffreg/mesh/io.h>
#include <diffreg/mesh/shapes.h>
#include <diffreg/weights/diffusion.h>
#include "bench.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <tuple>

namespace diffreg::bench {
namespace {

std::string thousands(int n) {
  std::ostringstream s;
  if (n >= 1000)
    s << (n + 500) / 1000 << "k";
  else
    s << n;
  return s.str();
}

}  // namespace

BenchMesh sphereNear(int n) {
  // A UV sphere has slices * (stacks - 1) + 2 vertices; stacks ~ 0.625 slices.
  const int slices = std::max(8, 4 * static_cast<int>(std::lround(std::sqrt(n / 0.625) / 4.0)));
  const int stacks = std::max(3, static_cast<int>(std::lround((n - 2.0) / slices)) + 1);
  std::ostringstream src;
  src << "makeSphere(1, " << slices << ", " << stacks << ")";
  Mesh m = makeSphere(1.0, slices, stacks);
  return {"sphere-" + thousands(m.numVertices()), src.str(), std::move(m)};
}

namespace {

// Generated shapes sized to about n vertices.
BenchMesh rectangleNear(int n) {
  // A 2 x 1 rectangle of 2k x k cells has (2k + 1)(k + 1) corners and 2 k^2 centres.
  const int k = std::max(2, static_cast<int>(std::lround(std::sqrt(n / 4.0))));
  std::ostringstream src;
  src << "makeRectangle(2, 1, " << 2 * k << ", " << k << ")";
  Mesh m = makeRectangle(2.0, 1.0, 2 * k, k);
  return {"rect-" + thousands(m.numVertices()), src.str(), std::move(m)};
}

BenchMesh tetBoxNear(int n) {
  // A 3 x 1 x 1 bar of 3k x k x k cubes has (3k + 1)(k + 1)^2 vertices, 18 k^3 tets.
  int k = 1;
  while ((3.0 * (k + 1) + 1) * (k + 2) * (k + 2) <= n) ++k;
  const double below = (3.0 * k + 1) * (k + 1) * (k + 1);
  const double above = (3.0 * (k + 1) + 1) * (k + 2) * (k + 2);
  if (above - n < n - below) ++k;
  std::ostringstream src;
  src << "makeTetBox(3, 1, 1, " << 3 * k << ", " << k << ", " << k << ")";
  Mesh m = makeTetBox(3.0, 1.0, 1.0, 3 * k, k, k);
  return {"tet-" + thousands(m.numVertices()), src.str(), std::move(m)};
}

// Vertex sets for the weights: three small regions (radius 2% of the diagonal) around the
// extreme vertices along the longest axis (both ends) and the second-longest axis (top).
struct WeightHandles {
  std::vector<std::vector<int>> sets;
  std::vector<double> ranges{1.0, 1.0, 1.5}, magnitudes{1.0, 0.6, 0.8};
};

WeightHandles weightHandles(const Discretization& disc) {
  const Eigen::MatrixXd& X = disc.rest();
  const Eigen::RowVectorXd lo = X.colwise().minCoeff(), hi = X.colwise().maxCoeff();
  std::vector<int> axes(X.cols());
  for (int a = 0; a < X.cols(); ++a) axes[a] = a;
  std::stable_sort(axes.begin(), axes.end(),
                   [&](int a, int b) { return hi(a) - lo(a) > hi(b) - lo(b); });
  Eigen::Index iMin, iMax, iTop;
  X.col(axes[0]).minCoeff(&iMin);
  X.col(axes[0]).maxCoeff(&iMax);
  X.col(axes[1]).maxCoeff(&iTop);
  const double radius = 0.02 * disc.boundingBoxDiagonal();
  WeightHandles h;
  std::vector<bool> taken(X.rows(), false);
  for (Eigen::Index c : {iMin, iMax, iTop}) {
    std::vector<int> set;
    for (int v = 0; v < X.rows(); ++v)
      if (!taken[v] && disc.active()[v] && (X.row(v) - X.row(c)).norm() <= radius) {
        set.push_back(v);
        taken[v] = true;
      }
    if (set.empty()) continue;  // the centre already belongs to an earlier handle
    h.sets.push_back(std::move(set));
  }
  h.ranges.resize(h.sets.size());
  h.magnitudes.resize(h.sets.size());
  return h;
}

// The weight schemes timed: eq. 7, eq. 8 by PCG (the default) and eq. 8 by the direct
// Cholesky of its 2-ring matrix (docs/method.md, "Diffused weights").
struct WeightScheme {
  const char* name;
  DiffusionOrder order;
  DiffusionSolve solve;
};
constexpr WeightScheme kWeightSchemes[] = {
    {"eq7", DiffusionOrder::First, DiffusionSolve::Pcg},
    {"eq8", DiffusionOrder::Second, DiffusionSolve::Pcg},
    {"eq8-direct", DiffusionOrder::Second, DiffusionSolve::Direct},
};

// The paper's §4 timings for its three weight meshes (factor, solve), eq. 7 then eq. 8.
struct PaperWeights {
  double factor7, factor8, solve7, solve8;
};
constexpr PaperWeights kPaper1k{0.008, 0.032, 0.001, 0.002};  // car body, 984 V
constexpr PaperWeights kPaper4k{1.13, 8.5, 0.011, 0.030};     // rocker arm, 3,696 V
constexpr PaperWeights kPaper21k{9.04, 52.8, 0.06, 0.17};     // chair, 21,342 V

// Everything a case builds before its repeats, shared by its prepare/run/release closures.
struct State {
  BenchMesh mesh;
  std::unique_ptr<Discretization> disc;
  WeightHandles weightHandles;
  ToolRun toolRun;  // weights, the default scheme only; empty without the tool
  std::vector<int> fixed, moved, handles;  // deformation: both ends, fixed first
  Eigen::VectorXd weights;                 // deformation: diffused regularization weights
};

Prepared describe(const State& s) {
  Prepared p;
  p.source = s.mesh.source;
  p.vertices = s.mesh.mesh.numVertices();
  p.elements = s.mesh.mesh.numElements();
  return p;
}

// A shared mesh as a case's mesh, or an unavailable case when ../shared/meshes lacks it.
std::function<BenchMesh()> shared(const std::string& label, const std::string& file) {
  return [label, file] {
    BenchMesh b{label, "", {}};
    if (!sharedMesh(file, b.mesh, b.source)) b.source.clear();
    return b;
  };
}

// A weights case's set-up: the mesh, its discretization and the three handle regions.
Prepared prepareWeights(State& state, const std::function<BenchMesh()>& make) {
  state.mesh = make();
  if (state.mesh.source.empty()) {
    Prepared p;
    p.available = false;
    p.skipReason = "mesh not found in " + sharedMeshDirectory();
    return p;
  }
  Timer timer;
  state.disc = std::make_unique<Discretization>(state.mesh.mesh);
  Prepared p = describe(state);
  p.facts["discretization_s"] = timer.seconds();
  state.weightHandles = weightHandles(*state.disc);
  int fixed = 0;
  for (const auto& set : state.weightHandles.sets) fixed += static_cast<int>(set.size());
  p.facts["handles"] = static_cast<double>(state.weightHandles.sets.size());
  p.facts["handle_vertices"] = fixed;
  return p;
}

// Sets up the tool's run of the diffuse_weights filter at its defaults (eq. 8 by PCG) with the
// case's handles, ranges and magnitudes; leaves `run` empty when the tool is not beside this
// benchmark.
void prepareWeightsToolRun(const State& state, ToolRun& run) {
  if (!prepareToolRun(run)) return;
  if (std::filesystem::exists(state.mesh.source)) {
    run.mesh = state.mesh.source;  // a shared mesh, read from its file
  } else {
    run.mesh = (run.dir->path() / (state.mesh.label + (state.mesh.mesh.isTet() ? ".mesh" : ".obj")))
                   .string();
    writeMesh(run.mesh, state.mesh.mesh);
  }
  const WeightHandles& h = state.weightHandles;
  nlohmann::json handles = nlohmann::json::array();
  for (size_t j = 0; j < h.sets.size(); ++j)
    handles.push_back({{"name", "h" + std::to_string(j)},
                       {"vertices", h.sets[j]},
                       {"range", h.ranges[j]},
                       {"magnitude", h.magnitudes[j]}});
  std::ofstream(run.handles) << nlohmann::json{{"handles", handles}}.dump();
}

// The diffuse_weights filter's own seconds from the tool's report: `diffreg -i MESH --handles H
// --filter diffuse_weights -o OUT.ply --report R` in a process of its own.
double toolFilterSeconds(const ToolRun& run) {
  runToolFilter(run, "diffuse_weights", "weights filter on " + run.mesh);
  const nlohmann::json report = toolReport(run);
  const nlohmann::json& filter = report.at("filters").at(0);
  if (filter.at("name") != "diffuse_weights")
    throw Error("weights: the tool's report has no diffuse_weights filter first");
  return filter.at("seconds").get<double>();
}

// The editor's weights session (DiffusionWeights::setHandleBasis): its first solve (one block
// CG for every handle's own weights) and the first change of a magnitude after it.
void addEditorWeights(const Discretization& disc, const WeightHandles& h,
                      const DiffusionParams& p, Sample& sample) {
  DiffusionWeights editor(disc);
  editor.setHandleBasis(true);
  editor.setHandles(h.sets, h.ranges, h.magnitudes);
  editor.setParams(p);
  Timer timer;
  editor.solve();
  sample.emplace_back("editor_whole", timer.seconds());
  const SolverStats before = editor.stats();
  editor.setMagnitude(0, 0.9);
  timer.reset();
  editor.solve();
  sample.emplace_back("editor_resolve", timer.seconds());
  if ((editor.stats() - before).solves != 0)
    throw Error("weights: the editor's session solved for a new magnitude");
}

// One repeat of a weights case: what the diffuse_weights filter does (discretize the rest
// shape, then one session), then a new t and a new magnitude, checking that each reuses as
// much of the factorization as paper Fig. 5 says.
Sample runWeights(const State& state, const WeightScheme& scheme) {
  Timer whole;
  const Discretization disc(state.mesh.mesh);
  const double discretization = whole.seconds();
  DiffusionWeights w(disc);
  const WeightHandles& h = state.weightHandles;
  w.setHandles(h.sets, h.ranges, h.magnitudes);
  DiffusionParams p;
  p.order = scheme.order;
  p.solve = scheme.solve;
  p.t = 0.01;
  w.setParams(p);
  Timer timer;
  w.solve();
  const double firstSolve = timer.seconds();
  const double filter = whole.seconds();
  const SolverStats s1 = w.stats();
  const DiffusionSolveInfo cg = w.lastSolve();
  // The solve phase: the back-substitution, or the whole CG (its products with B too).
  const double solvePhase = cg.cgIterations > 0 ? cg.cgSeconds : s1.solveSeconds;
  // A new t: numeric refactorization only (paper Fig. 5).
  p.t = 0.012;
  w.setParams(p);
  timer.reset();
  w.solve();
  const double refactor = timer.seconds();
  const SolverStats s2 = w.stats() - s1;
  // A new magnitude: right-hand side and solve only.
  w.setMagnitude(0, 0.9);
  timer.reset();
  w.solve();
  const double resolve = timer.seconds();
  const SolverStats s3 = w.stats() - s1 - s2;
  // The same magnitude again, as a slider does: pcg keeps the handle's own weights (no solve).
  w.setMagnitude(0, 0.8);
  timer.reset();
  w.solve();
  const double resolveAgain = timer.seconds();
  if (s1.symbolic != 1 || s2.symbolic != 0 || s2.numeric != 1 || s3.numeric != 0)
    throw Error("weights: the session did not reuse its factorization as Fig. 5 says");
  if (!cg.converged) throw Error("weights: conjugate gradients did not converge");
  Sample sample{{"symbolic", s1.symbolicSeconds},
                {"numeric", s1.numericSeconds},
                {"factor", firstSolve - solvePhase},
                {"solve", solvePhase},
                {"whole", firstSolve},
                {"discretization", discretization},
                {"filter", filter},
                {"cg_iterations_count", static_cast<double>(cg.cgIterations)},
                {"refactor", refactor},
                {"refactor_numeric", s2.numericSeconds},
                {"resolve", resolve},
                {"resolve_solve", s3.solveSeconds},
                {"resolve_again", resolveAgain}};
  if (scheme.solve == DiffusionSolve::Pcg && scheme.order == DiffusionOrder::Second) {
    addEditorWeights(disc, h, p, sample);
    if (!state.toolRun.tool.empty())
      sample.emplace_back("tool_filter", toolFilterSeconds(state.toolRun));
  }
  return sample;
}

// The weights cases of one mesh, one per scheme, with the paper's figures beside them.
void addWeightCase(std::vector<Case>& cases, const std::string& label,
                   const std::function<BenchMesh()>& make, const PaperWeights& paper) {
  for (const WeightScheme& scheme : kWeightSchemes) {
    auto state = std::make_shared<State>();
    const bool first = scheme.order == DiffusionOrder::First;
    Case c;
    c.group = "weights";
    c.name = std::string("weights/") + scheme.name + "/" + label;
    c.paper = {{"factor", first ? paper.factor7 : paper.factor8},
               {"resolve", first ? paper.solve7 : paper.solve8}};
    const bool tool = scheme.order == DiffusionOrder::Second && scheme.solve == DiffusionSolve::Pcg;
    c.prepare = [state, make, tool] {
      Prepared p = prepareWeights(*state, make);
      if (p.available && tool) prepareWeightsToolRun(*state, state->toolRun);
      return p;
    };
    c.release = [state] { *state = State(); };  // removes the tool run's scratch directory
    c.run = [state, scheme] { return runWeights(*state, scheme); };
    cases.push_back(std::move(c));
  }
}

// Builds the mesh, its discretization and the two end handles (5% deep each).
Prepared prepareDeformation(State& s, const std::function<BenchMesh()>& make, bool weights) {
  s.mesh = make();
  if (s.mesh.source.empty()) {
    Prepared p;
    p.available = false;
    p.skipReason = sharedMeshDirectory() + ": " + s.mesh.label + " absent";
    return p;
  }
  s.disc = std::make_unique<Discretization>(s.mesh.mesh);
  std::tie(s.fixed, s.moved) = endHandles(s.disc->rest(), 0.05);
  s.handles = s.fixed;
  s.handles.insert(s.handles.end(), s.moved.begin(), s.moved.end());
  Prepared p = describe(s);
  p.facts["handle_vertices"] = static_cast<double>(s.handles.size());
  if (weights) {
    // Regularization weights diffused from the two handles (eq. 8, default t).
    DiffusionWeights w(*s.disc);
    w.setHandles({s.fixed, s.moved}, {1.0, 1.0}, {0.5, 1.0});
    Timer timer;
    s.weights = w.solve();
    p.facts["weights_s"] = timer.seconds();
  }
  return p;
}

// One handle move on a session: setTargets + solve(iterations) with no early stop.
double handleMove(DeformationSession& session, const State& s, double offset, int iterations) {
  const Eigen::MatrixXd T = moveTargets(s.disc->rest(), s.fixed, s.moved, offset, s.disc->dim());
  Timer timer;
  session.setTargets(T);
  session.solve(iterations, 0.0);
  return timer.seconds();
}

constexpr int kLongMove = 5;  // iterations of the longer handle move

void addDeformationCase(std::vector<Case>& cases, const std::string& series,
                        const std::string& label, const std::function<BenchMesh()>& make,
                        int maxRepeats = 0) {
  auto state = std::make_shared<State>();
  Case c;
  c.group = "deform";
  c.name = "deform/" + series + "/" + label;
  c.series = series;
  c.maxRepeats = maxRepeats;
  c.prepare = [state, make] { return prepareDeformation(*state, make, true); };
  c.release = [state] { *state = State(); };
  c.run = [state] {
    const State& s = *state;
    DeformationOptions o;
    o.energy = Energy::Arap;
    o.regularization = Regularization::Nonuniform;
    o.weights = s.weights;
    Timer timer;
    DeformationSession session(*s.disc, o);
    session.setHandles(s.handles);
    const double setup = timer.seconds();
    handleMove(session, s, 0.05, 1);
    const SolverStats s1 = session.stats();
    const double latency1 = handleMove(session, s, 0.10, 1);
    const SolverStats s2 = session.stats() - s1;
    const double latencyLong = handleMove(session, s, 0.15, kLongMove);
    const SolverStats s3 = session.stats() - s1 - s2;
    // Planar ARAP also owns the factorization of its ASAP initial guess (stats() sums both).
    if (s1.symbolic < 1 || s2.symbolic + s2.numeric + s3.symbolic + s3.numeric != 0)
      throw Error("deformation: the session did not reuse its factorization");
    const double iteration = (latencyLong - latency1) / (kLongMove - 1);
    const double global = s3.solveSeconds / kLongMove;
    // The editor's setting: the handle basis, built by the next solve, then a move whose
    // handle groups move affinely (here: translated) starts without a solve.
    // Planar ARAP starts from its ASAP solution instead: no basis there.
    double basisMove = NAN, latencyBasis = NAN;
    if (s.disc->kind() != MeshKind::Planar) {
      session.setHandleBasis(true);
      basisMove = handleMove(session, s, 0.05, 1);
      const SolverStats s4 = session.stats() - s1 - s2 - s3;
      latencyBasis = handleMove(session, s, 0.10, 1);
      const SolverStats s5 = session.stats() - s1 - s2 - s3 - s4;
      if (s5.solves != 0) throw Error("deformation: the handle basis did not serve the move");
    }
    return Sample{{"setup", setup},
                  {"symbolic", s1.symbolicSeconds},
                  {"factor", s1.numericSeconds},
                  {"iteration", iteration},
                  {"global", global},
                  {"local", iteration - global},
                  {"move1", latency1},
                  {"move5", latencyLong},
                  {"basis_move1", basisMove},
                  {"move1_basis", latencyBasis}};
  };
  cases.push_back(std::move(c));
}

}  // namespace

namespace {
std::string& meshDirectoryOverride() {
  static std::string dir;
  return dir;
}
}  // namespace

void setSharedMeshDirectory(const std::string& dir) { meshDirectoryOverride() = dir; }

std::string sharedMeshDirectory() {
  if (!meshDirectoryOverride().empty()) return meshDirectoryOverride();
  if (const char* env = std::getenv("DIFFREG_SHARED_MESHES")) return env;
  // ../shared/meshes beside the source tree (this file is tools/bench/cases.cpp).
  const std::filesystem::path source(__FILE__);
  if (source.is_absolute())
    return (source.parent_path().parent_path().parent_path().parent_path() / "shared" / "meshes")
        .lexically_normal()
        .string();
  return "../shared/meshes";
}

bool sharedMesh(const std::string& file, Mesh& mesh, std::string& path) {
  path = sharedMeshDirectory() + "/" + file;
  if (!std::filesystem::exists(path)) return false;
  mesh = readMesh(path);
  return true;
}

std::pair<std::vector<int>, std::vector<int>> endHandles(const Eigen::MatrixXd& rest,
                                                         double fraction) {
  const Eigen::RowVectorXd lo = rest.colwise().minCoeff(), hi = rest.colwise().maxCoeff();
  // The longest axis; near-ties go to the later axis (z for a sphere: its poles).
  int axis = 0;
  for (int a = 1; a < rest.cols(); ++a)
    if (hi(a) - lo(a) >= (hi(axis) - lo(axis)) * (1.0 - 1e-9)) axis = a;
  const double depth = fraction * (hi(axis) - lo(axis));
  std::vector<int> fixed, moved;
  for (int v = 0; v < rest.rows(); ++v) {
    if (rest(v, axis) <= lo(axis) + depth) fixed.push_back(v);
    if (rest(v, axis) >= hi(axis) - depth) moved.push_back(v);
  }
  return {fixed, moved};
}

Eigen::MatrixXd moveTargets(const Eigen::MatrixXd& rest, const std::vector<int>& fixed,
                            const std::vector<int>& moved, double offset, int dim) {
  const Eigen::RowVectorXd lo = rest.colwise().minCoeff(), hi = rest.colwise().maxCoeff();
  int axis = 0;
  for (int a = 1; a < rest.cols(); ++a)
    if (hi(a) - lo(a) >= (hi(axis) - lo(axis)) * (1.0 - 1e-9)) axis = a;
  const int side = (axis + 1) % dim;
  const double length = hi(axis) - lo(axis);
  Eigen::MatrixXd T(static_cast<Eigen::Index>(fixed.size() + moved.size()), dim);
  Eigen::Index row = 0;
  for (int v : fixed) T.row(row++) = rest.row(v).leftCols(dim);
  for (int v : moved) {
    T.row(row) = rest.row(v).leftCols(dim);
    T(row, axis) += offset * length;
    T(row, side) += 0.5 * offset * length;
    ++row;
  }
  return T;
}

// The shared meshes every deformation benchmark also runs on: the surfaces (also against CGAL),
// a planar and a tetrahedral one.
const std::vector<std::pair<std::string, std::string>> kRealMeshes = {
    {"rocker-arm", "surface-rocker-arm.obj"}, {"armadillo", "surface-armadillo.obj"},
    {"beetle-20k", "surface-beetle-20k.off"},  {"crocodile", "planar-crocodile.obj"},
    {"tet-monkey", "tet-monkey.mesh"}};
const std::vector<std::pair<std::string, std::string>> kRealSurfaces = {
    kRealMeshes[0], kRealMeshes[1], kRealMeshes[2]};

void addWeightCases(std::vector<Case>& cases, const Sizes& sizes) {
  addWeightCase(
      cases, "sphere-1k", [] { return sphereNear(1000); }, kPaper1k);
  if (sizes.quick) {
    addWeightCase(
        cases, "tet-1k", [] { return tetBoxNear(1000); }, kPaper1k);
    return;
  }
  addWeightCase(
      cases, "tet-3.7k", [] { return tetBoxNear(3700); }, kPaper4k);
  addWeightCase(cases, "tet-bar", shared("tet-bar", "tet-bar.mesh"), kPaper4k);
  addWeightCase(cases, "rocker-arm", shared("rocker-arm", "surface-rocker-arm.obj"), kPaper4k);
  addWeightCase(
      cases, "tet-21k", [] { return tetBoxNear(21000); }, kPaper21k);
  addWeightCase(cases, "tet-monkey", shared("tet-monkey", "tet-monkey.mesh"), kPaper21k);
}

void addDeformationCases(std::vector<Case>& cases, const Sizes& sizes) {
  struct Size {
    const char* label;
    int n;
    int maxRepeats;
  };
  const std::vector<Size> triSizes =
      sizes.quick ? std::vector<Size>{{"1k", 1000, 0}, {"4k", 4000, 0}}
                  : std::vector<Size>{{"1k", 1000, 0}, {"10k", 10000, 0}, {"100k", 100000, 3}};
  const std::vector<Size> tetSizes =
      sizes.quick ? std::vector<Size>{{"1k", 1000, 0}, {"4k", 4000, 0}}
                  : std::vector<Size>{
                        {"1k", 1000, 0}, {"10k", 10000, 0}, {"30k", 30000, 3}, {"100k", 100000, 3}};
  for (const Size& z : triSizes)
    addDeformationCase(
        cases, "planar", z.label, [n = z.n] { return rectangleNear(n); }, z.maxRepeats);
  for (const Size& z : triSizes)
    addDeformationCase(
        cases, "surface", z.label, [n = z.n] { return sphereNear(n); }, z.maxRepeats);
  for (const Size& z : tetSizes)
    addDeformationCase(
        cases, "tet", z.label, [n = z.n] { return tetBoxNear(n); }, z.maxRepeats);
  if (sizes.quick) return;
  // The growth series to a million vertices (a handle move on the largest takes seconds).
  addDeformationCase(
      cases, "surface", "1m", [] { return sphereNear(1000000); }, 1);
  // The shared real meshes (series "real": not part of the growth fits).
  for (const auto& [label, file] : kRealMeshes)
    addDeformationCase(cases, "real", label, shared(label, file), 3);
}

namespace {

void addPeerCase(std::vector<Case>& cases, const std::string& label,
                 const std::function<BenchMesh()>& make, int maxRepeats) {
  auto state = std::make_shared<State>();
  Case c;
  c.group = "peer";
  c.name = "peer/" + label;
  c.maxRepeats = maxRepeats;
  c.prepare = [state, make] { return prepareDeformation(*state, make, false); };
  c.release = [state] { *state = State(); };
  c.run = [state] {
    const State& s = *state;
    // Ours: plain ARAP (no regularization); the preprocessing includes the discretization,
    // since CGAL computes its cotangent weights in its own set-up.
    Timer timer;
    Discretization disc(s.mesh.mesh);
    const double discretization = timer.seconds();
    DeformationOptions o;
    o.energy = Energy::Arap;
    o.regularization = Regularization::None;
    // A plain ARAP session, as a user without regularization makes it: the regularizer's
    // couplings are not reserved in the factor, so the problem is the one CGAL solves.
    o.reserveRegularization = false;
    DeformationSession session(disc, o);
    session.setHandles(s.handles);
    const double setup = timer.seconds();
    const double first = handleMove(session, s, 0.05, 1);
    const SolverStats factorization = session.stats();
    const double latency1 = handleMove(session, s, 0.10, 1);
    const double latencyLong = handleMove(session, s, 0.15, 1 + kLongMove);
    const double oursPre = setup + first - latency1;
    const double oursIter = (latencyLong - latency1) / kLongMove;

    const Eigen::MatrixXd T = moveTargets(s.disc->rest(), s.fixed, s.moved, 0.10, s.disc->dim());
    const PeerTimes cgal =
        runCgalArap(s.mesh.mesh.positions(), s.mesh.mesh.elements(), s.handles, T, kLongMove);
    const double cgalIter = (cgal.latencyMore - cgal.latency1) / kLongMove;
    return Sample{{"ours_preprocess", oursPre},
                  {"cgal_preprocess", cgal.preprocess},
                  {"ours_iteration", oursIter},
                  {"cgal_iteration", cgalIter},
                  {"ours_move1", latency1},
                  {"cgal_move1", cgal.latency1},
                  {"ours_discretization", discretization},
                  {"ours_session", setup - discretization},
                  {"ours_symbolic", factorization.symbolicSeconds},
                  {"ours_numeric", factorization.numericSeconds}};
  };
  cases.push_back(std::move(c));
}

}  // namespace

void addPeerCases(std::vector<Case>& cases, const Sizes& sizes) {
  struct Size {
    const char* label;
    int n;
    int maxRepeats;
  };
  const std::vector<Size> peerSizes =
      sizes.quick ? std::vector<Size>{{"2k", 2000, 0}}
                  : std::vector<Size>{{"10k", 10000, 0}, {"100k", 100000, 3}};
  for (const Size& z : peerSizes)
    addPeerCase(
        cases, std::string("sphere-") + z.label, [n = z.n] { return sphereNear(n); },
        z.maxRepeats);
  if (sizes.quick) return;
  for (const auto& [label, file] : kRealSurfaces) addPeerCase(cases, label, shared(label, file), 0);
}

void runMemorySession(int vertices) {
  // Peak resident memory so far after each stage, for the parent to report. VmHWM belongs to
  // this process image only; ru_maxrss would also count the parent's pages shared at fork.
  auto stage = [](const char* name) {
    std::ifstream status("/proc/self/status");
    std::string line;
    long kib = -1;
    while (std::getline(status, line))
      if (line.rfind("VmHWM:", 0) == 0) kib = std::strtol(line.c_str() + 6, nullptr, 10);
    std::printf("stage %s %ld\n", name, kib);
    std::fflush(stdout);
  };
  stage("start");
  State s;
  s.mesh = sphereNear(vertices);
  stage("mesh");
  s.disc = std::make_unique<Discretization>(s.mesh.mesh);
  std::tie(s.fixed, s.moved) = endHandles(s.disc->rest(), 0.05);
  s.handles = s.fixed;
  s.handles.insert(s.handles.end(), s.moved.begin(), s.moved.end());
  stage("discretization");
  {
    DiffusionWeights w(*s.disc);
    w.setHandles({s.fixed, s.moved}, {1.0, 1.0}, {0.5, 1.0});
    s.weights = w.solve();
  }
  stage("weights");
  DeformationOptions o;
  o.energy = Energy::Arap;
  o.regularization = Regularization::Nonuniform;
  o.weights = s.weights;
  DeformationSession session(*s.disc, o);
  session.setHandles(s.handles);
  stage("session");
  handleMove(session, s, 0.1, kLongMove);
  stage("solve");
  session.setHandleBasis(true);  // the editor's setting: built by the next solve
  handleMove(session, s, 0.15, 1);
  stage("basis");
  handleMove(session, s, 0.2, kLongMove);
  stage("edit");
  std::printf("vertices %d\n", s.mesh.mesh.numVertices());
}

}  // namespace diffreg::bench
