// The edit engine behind every front end (filters, the OpenMesh API, `diffreg serve`): each
// edit costs what the paper's Fig. 5 says and no more, invalid states are refused without a
// trace, every mesh kind deforms, and the one-shot uses give what the sessions below it give.
#include "test_support.h"

#include <diffreg/core/error.h>
#include <diffreg/deformation/metrics.h>
#include <diffreg/engine/edit_engine.h>
#include <diffreg/handles/handles.h>
#include <diffreg/mesh/io.h>

#include <catch2/catch.hpp>

#include <string>
#include <tuple>
#include <vector>

using namespace diffreg;

namespace {

Mesh shipped(const std::string& name) {
  return readMesh(std::string(DIFFREG_SOURCE_DIR) + "/meshes/" + name);
}

EditHandle handle(const EditEngine& s, EditState& state, std::vector<int> vertices) {
  EditHandle h;
  h.id = state.nextId++;
  h.vertices = std::move(vertices);
  h.targets.resize(static_cast<Eigen::Index>(h.vertices.size()), 3);
  for (size_t i = 0; i < h.vertices.size(); ++i)
    h.targets.row(static_cast<Eigen::Index>(i)) = s.positions().row(h.vertices[i]);
  return h;
}

}  // namespace

TEST_CASE("edit engine: each edit costs only what it must", "[engine]") {
  EditEngine s(shipped("bar.obj"));
  EditState state = s.state();
  state.handles.push_back(handle(s, state, {0, 33, 66, 99, 132}));
  state.handles.push_back(handle(s, state, {32, 65, 98, 131, 164}));
  s.setState(state);
  UpdateReport u = s.update();
  REQUIRE(u.solved);
  CHECK(u.weightsWork == "analysis");
  CHECK(u.deformationWork == "analysis");
  CHECK(s.computedVersion() == s.version());

  // Nothing changed: nothing to do.
  u = s.update();
  CHECK(u.weights.solves + u.deformation.solves + u.reference.solves == 0);

  // m_j: the weights need no solve (the interactive engine kept every handle's own weights
  // from the first solve); the deformation a new factorization (its regularization weights
  // changed).
  state = s.state();
  state.handles[1].magnitude = 0.5;
  s.setState(state);
  u = s.update();
  CHECK(u.weightsWork == "superpose");
  CHECK(u.weights.solves == 0);
  CHECK(u.deformationWork == "numeric");
  CHECK(s.weights()[98] == Approx(0.5));
  CHECK(u.referenceWork == "none");  // the unregularized edit did not change

  // Targets: solves only, and the handle vertices reach them.
  state = s.state();
  state.handles[1].targets.col(1).array() += 1.0;
  s.setState(state);
  u = s.update();
  CHECK(u.weightsWork == "none");
  CHECK(u.deformationWork == "solve");
  CHECK(u.referenceWork == "solve");
  CHECK(s.positions()(98, 1) == Approx(1.5));
  CHECK(s.metrics().dist.has_value());
  CHECK(*s.metrics().dist > 0.0);

  // The mesh written out carries the three properties.
  const Mesh out = s.resultMesh();
  CHECK(out.hasVertexScalar(prop::weight));
  CHECK(out.hasElementScalar(prop::distortion));
  CHECK(out.hasElementScalar(prop::smoothness));
}

TEST_CASE("edit engine: invalid states are refused and leave the session unchanged", "[engine]") {
  EditEngine s(shipped("bar.obj"));
  EditState state = s.state();
  state.handles.push_back(handle(s, state, {0, 33}));
  s.setState(state);
  s.update();
  const long version = s.version();

  auto refused = [&](EditState bad) {
    CHECK_THROWS_AS(s.setState(std::move(bad)), InvalidParameter);
    CHECK(s.version() == version);
    CHECK(s.state().handles.size() == 1);
  };
  EditState bad = s.state();
  bad.handles[0].vertices.push_back(5000);
  bad.handles[0].targets.conservativeResize(3, 3);
  bad.handles[0].targets.row(2).setZero();
  refused(bad);
  bad = s.state();
  bad.handles[0].targets(0, 0) = std::nan("");
  refused(bad);
  bad = s.state();
  bad.handles[0].range = 0.0;
  refused(bad);
  bad = s.state();
  bad.handles[0].magnitude = 1.5;
  refused(bad);
  bad = s.state();
  bad.params.beta = -0.1;
  refused(bad);
  bad = s.state();
  bad.params.diffusion.t = 0.0;
  refused(bad);
  bad = s.state();
  bad.params.iterations = 0;
  refused(bad);
  bad = s.state();
  bad.handles.push_back(handle(s, bad, {33}));  // already in handle 0
  refused(bad);
  // What the handle file format refuses: the state's handle file must read back.
  bad = s.state();
  bad.handles[0].range = 1e-7;  // below kMinHandleRange
  refused(bad);
  bad = s.state();
  bad.handles.push_back(handle(s, bad, {66}));
  bad.handles[0].name = bad.handles[1].name = "twin";
  refused(bad);
}

TEST_CASE("edit engine: a target's reach ignores unreferenced vertices", "[engine]") {
  // The bar (8 x 1, diagonal about 8.06) with one vertex that no triangle uses, far away.
  TriMesh t = shipped("bar.obj").tri();
  t.add_vertex({1e6, 0.0, 0.0});
  EditEngine s{Mesh(t)};
  EditState state = s.state();
  state.handles.push_back(handle(s, state, {0, 33}));
  state.handles.push_back(handle(s, state, {32, 65}));
  state.handles[1].targets.col(1).array() += 1.0;
  // Measured from the centre of a box that took the stray vertex in, these targets were
  // "more than 1000 mesh diagonals away".
  REQUIRE_NOTHROW(s.setState(state));
  CHECK(s.update().solved);
  // The reach is still 1000 diagonals of the bar itself.
  EditState far = s.state();
  far.handles[1].targets.col(0).array() += 9000.0;
  CHECK_THROWS_WITH(s.setState(far), Catch::Contains("1000 mesh diagonals"));
}

TEST_CASE("edit engine: the handle file of any accepted state reads back", "[engine]") {
  EditEngine s(shipped("bar.obj"));
  EditState state = s.state();
  state.handles.push_back(handle(s, state, {0, 33}));
  state.handles.push_back(handle(s, state, {66}));
  state.handles.push_back(handle(s, state, {98}));
  state.handles[0].name.clear();  // exported as handle-<id>, the name the next one takes
  state.handles[1].name = "handle-" + std::to_string(state.handles[0].id);
  state.handles[2].range = kMinHandleRange;
  s.setState(state);
  const HandleSet set = s.handleSet();
  CHECK(set.handles[0].name != set.handles[1].name);
  const testing::TempDir dir;
  const HandleSet back = readHandles(dir.file("h.json", handlesToJson(set)), s.restMesh());
  REQUIRE(back.handles.size() == 3);
  for (size_t j = 0; j < 3; ++j) {
    CHECK(back.handles[j].name == set.handles[j].name);
    CHECK(back.handles[j].vertices == set.handles[j].vertices);
    CHECK(back.handles[j].range == set.handles[j].range);
  }
}

TEST_CASE("edit engine: surfaces and tet meshes deform with every energy", "[engine]") {
  for (const char* name : {"cylinder.obj", "tetbar.mesh"}) {
    INFO(name);
    EditEngine s(shipped(name));
    const Eigen::MatrixXd rest = s.positions();
    // The vertices at the lowest and the highest end of the longest axis.
    Eigen::Index axis = 0;
    (rest.colwise().maxCoeff() - rest.colwise().minCoeff()).maxCoeff(&axis);
    const double lo = rest.col(axis).minCoeff(), hi = rest.col(axis).maxCoeff();
    std::vector<int> low, high;
    for (int v = 0; v < s.numVertices(); ++v) {
      if (rest(v, axis) < lo + 1e-9) low.push_back(v);
      if (rest(v, axis) > hi - 1e-9) high.push_back(v);
    }
    EditState state = s.state();
    state.handles.push_back(handle(s, state, low));
    state.handles.push_back(handle(s, state, high));
    const Eigen::Index side = (axis + 1) % 3;
    state.handles[1].targets.col(side).array() += 0.25 * (hi - lo);
    for (Energy energy : {Energy::Arap, Energy::Asap, Energy::Larap, Energy::Dirichlet}) {
      state.params.energy = energy;
      s.setState(state);
      const UpdateReport u = s.update();
      INFO(toString(energy) << ": " << u.message);
      CHECK(u.solved);
      CHECK(s.positions().allFinite());
      CHECK(s.positions()(high[0], side) == Approx(rest(high[0], side) + 0.25 * (hi - lo)));
    }
  }
}

TEST_CASE("edit engine: with continue_drags a drag continues from the current shape",
          "[engine]") {
  for (bool continueDrags : {false, true}) {
    INFO("continue_drags " << continueDrags);
    EditEngine s(shipped("bar.obj"));
    EditState state = s.state();
    state.params.iterations = 500;
    // A drag's tolerance: near the previous shape a continued drag gets there in fewer
    // iterations (7 against 12 here). To 1e-7 L-BFGS needs about 20 from either start.
    state.params.tolerance = 1e-4;
    state.params.continueDrags = continueDrags;
    state.handles.push_back(handle(s, state, {0, 33, 66, 99, 132}));
    state.handles.push_back(handle(s, state, {32, 65, 98, 131, 164}));
    state.handles[1].targets.col(1).array() += 1.0;
    s.setState(state);
    const UpdateReport first = s.update();
    REQUIRE(first.solved);
    CHECK(first.initialGuess != "given");  // nothing to continue from yet

    // A small drag step.
    state = s.state();
    state.handles[1].targets.col(1).array() += 0.02;
    s.setState(state);
    const UpdateReport drag = s.update();
    REQUIRE(drag.solved);
    CHECK(s.positions()(98, 1) == Approx(1.52));
    CHECK(drag.deformationWork == "solve");
    if (continueDrags) {
      CHECK(drag.initialGuess == "given");
      CHECK(drag.iterations < first.iterations);
    } else {
      CHECK(drag.initialGuess != "given");
    }

    // Any other change solves from scratch again.
    state = s.state();
    state.params.beta = 0.3;
    state.params.regularization = Regularization::Uniform;
    s.setState(state);
    CHECK(s.update().initialGuess != "given");
  }
}

TEST_CASE("edit engine: refine continues an unconverged deformation until it converges",
          "[engine]") {
  EditEngine s(shipped("bar.obj"));
  EditState state = s.state();
  state.params.iterations = 3;  // a small budget per update
  state.handles.push_back(handle(s, state, {0, 33, 66, 99, 132}));
  state.handles.push_back(handle(s, state, {32, 65, 98, 131, 164}));
  state.handles[1].targets.col(1).array() += 1.0;
  s.setState(state);
  const UpdateReport first = s.update();
  REQUIRE(first.solved);
  CHECK_FALSE(first.converged);
  CHECK(first.criterion > state.params.tolerance);
  const double before = s.metrics().energy;
  int rounds = 0;
  while (s.refine() && rounds < 2000) {
    const UpdateReport u = s.update();
    REQUIRE(u.solved);
    CHECK(u.initialGuess == "continued");
    CHECK(s.metrics().energy <= before * (1 + 1e-12));
    ++rounds;
  }
  CHECK(rounds > 0);
  CHECK(s.lastUpdate().converged);
  CHECK(s.lastUpdate().criterion <= state.params.tolerance);
  CHECK_FALSE(s.refine());  // nothing left to do

  // Batches of a continued run are one run: the same shape as a single converged solve.
  EditEngine once(shipped("bar.obj"));
  EditState all = state;
  all.params.iterations = kDefaultIterations;
  once.setState(all);
  REQUIRE(once.update().converged);
  CHECK(s.metrics().energy == Approx(once.metrics().energy).epsilon(1e-9));
  CHECK((s.positions() - once.positions()).cwiseAbs().maxCoeff() < 1e-9);
}

TEST_CASE("edit engine: an update at the default parameters is converged", "[engine]") {
  // The twisted cylinder takes more iterations than the editor's per-update cap.
  const Mesh mesh = shipped("cylinder.obj");
  EditEngine s(mesh);
  s.setHandles(readHandles(std::string(DIFFREG_SOURCE_DIR) + "/meshes/cylinder-twist.json", mesh));
  const UpdateReport u = s.update();
  REQUIRE(u.solved);
  CHECK(u.converged);
  CHECK(u.criterion <= kDefaultTolerance);
  CHECK(u.iterations > kEditorIterations);
}

TEST_CASE("edit engine: a new iteration cap or tolerance keeps the shape", "[engine]") {
  EditEngine s(shipped("bar.obj"));
  EditState state = s.state();
  state.handles.push_back(handle(s, state, {0, 33, 66, 99, 132}));
  state.handles.push_back(handle(s, state, {32, 65, 98, 131, 164}));
  state.handles[1].targets.col(1).array() += 1.0;
  state.params.iterations = kDefaultIterations;
  s.setState(state);
  REQUIRE(s.update().converged);
  const Eigen::MatrixXd converged = s.positions();
  const double energy = s.metrics().energy;

  // A smaller cap, a looser tolerance: still converged, nothing solved.
  state = s.state();
  state.params.iterations = 7;
  state.params.tolerance = 1e-5;
  s.setState(state);
  UpdateReport u = s.update();
  CHECK(u.converged);
  CHECK(u.deformation.solves + u.reference.solves == 0);
  CHECK(s.positions() == converged);

  // A tighter tolerance continues from the converged shape, within the small cap: lower
  // energy, not a restart from the rest shape (7 iterations from rest end far above).
  state = s.state();
  state.params.tolerance = 1e-12;
  s.setState(state);
  u = s.update();
  CHECK(u.initialGuess == "continued");
  CHECK(s.metrics().energy <= energy);
  CHECK((s.positions() - converged).cwiseAbs().maxCoeff() < 1e-3);

  // A one-shot engine (the filters') solves every edit from the rest shape: a pipeline's second
  // deform with another cap is a run of its own.
  EngineSettings oneShot;
  oneShot.interactive = false;
  EditEngine filters(shipped("bar.obj"), oneShot);
  state.params.tolerance = kDefaultTolerance;
  state.params.iterations = kDefaultIterations;
  filters.setState(state);
  REQUIRE(filters.update().converged);
  state.params.iterations = 3;
  filters.setState(state);
  u = filters.update();
  CHECK(u.deformation.solves > 0);
  CHECK(u.iterations <= 3);
  CHECK_FALSE(u.converged);
  CHECK(u.initialGuess != "continued");
}

TEST_CASE("edit engine: updates within a time budget answer unconverged, refine() reaches the "
          "shape of one run, and metrics say when the energy is not relaxed",
          "[engine]") {
  EditEngine s(shipped("bar.obj"));
  EditState state = s.state();
  CHECK(state.params.seconds == 0.0);  // no limit unless asked (the editor asks)
  state.handles.push_back(handle(s, state, {0, 33, 66, 99, 132}));
  state.handles.push_back(handle(s, state, {32, 65, 98, 131, 164}));
  state.handles[1].targets.col(1).array() += 1.0;
  EditState unlimited = state;
  state.params.seconds = 1e-9;  // spent before the first step: one iteration per run
  s.setState(state);
  const UpdateReport first = s.update();
  REQUIRE(first.solved);
  CHECK_FALSE(first.converged);
  // The run's own energy at its shape, not the relaxed one.
  CHECK_FALSE(s.metrics().relaxed);
  CHECK(s.metrics().energy == s.lastRun().energies.back());
  int rounds = 0;
  while (s.refine() && rounds < 5000) {
    const UpdateReport u = s.update();
    REQUIRE(u.solved);
    CHECK(u.iterations <= 2);  // one step, or the L-BFGS step and its plain check
    ++rounds;
  }
  REQUIRE(s.lastUpdate().converged);
  CHECK(s.metrics().relaxed);

  EditEngine once(shipped("bar.obj"));
  once.setState(unlimited);
  REQUIRE(once.update().converged);
  CHECK(once.metrics().relaxed);
  CHECK(s.metrics().energy == once.metrics().energy);
  REQUIRE(once.metrics().dist.has_value());
  CHECK(s.metrics().dist == once.metrics().dist);
  CHECK((s.positions() - once.positions()).cwiseAbs().maxCoeff() == 0.0);

  EditState bad = state;
  bad.params.seconds = -1.0;
  CHECK_THROWS_AS(s.setState(bad), InvalidParameter);
}

namespace {

/// The bar's two end handles as a HandleSet, the right one pulled up by `lift`.
HandleSet barHandles(const Mesh& bar, double lift) {
  HandleSet set;
  for (const auto& [name, vertices, dy] :
       {std::tuple<const char*, std::vector<int>, double>{"left", {0, 33, 66, 99, 132}, 0.0},
        {"right", {32, 65, 98, 131, 164}, lift}}) {
    Handle h;
    h.name = name;
    h.vertices = vertices;
    h.targets.resize(static_cast<Eigen::Index>(vertices.size()), 3);
    for (size_t i = 0; i < vertices.size(); ++i)
      h.targets.row(static_cast<Eigen::Index>(i)) = bar.positions().row(vertices[i]);
    h.targets.col(1).array() += dy;
    set.handles.push_back(h);
  }
  return set;
}

}  // namespace

TEST_CASE("edit engine: weights alone, then the deformation, then its reference", "[engine]") {
  const Mesh bar = shipped("bar.obj");
  EngineSettings oneShot;
  oneShot.interactive = false;
  EditEngine engine(bar, oneShot);
  EditParams weightsOnly;
  weightsOnly.deform = false;
  weightsOnly.reference = false;
  engine.setEdit(barHandles(bar, 1.0), weightsOnly);
  UpdateReport u = engine.updateOrThrow();
  CHECK(u.weightsWork == "analysis");
  CHECK(u.deformationWork == "none");
  CHECK(u.absoluteTime > 0.0);
  CHECK(engine.positions() == bar.positions());  // no deformation asked for
  CHECK(engine.weights().maxCoeff() == Approx(1.0));

  // The same weights given: the deformation equals a DeformationSession's with them.
  EditParams deformParams;
  deformParams.scheme = WeightScheme::Given;
  deformParams.givenWeights = engine.weights();
  deformParams.reference = false;
  const Eigen::VectorXd weights = engine.weights();
  engine.setEdit(barHandles(bar, 1.0), deformParams);
  u = engine.updateOrThrow();
  CHECK(u.weightsWork == "none");  // the given weights are the diffused ones
  CHECK(u.deformationWork == "analysis");
  DeformationOptions options;
  options.regularization = Regularization::Nonuniform;
  options.weights = weights;
  options.maxIterations = deformParams.iterations;
  options.relTolerance = deformParams.tolerance;
  const Discretization disc(bar);
  DeformationSession session(disc, options);
  const HandleSet handles = barHandles(bar, 1.0);
  session.setHandles(handles.allVertices());
  session.setTargets(handles.allTargets());
  const DeformationResult direct = session.solve();
  CHECK((engine.positions().leftCols(2) - direct.positions).cwiseAbs().maxCoeff() < 1e-12);
  CHECK(engine.lastRun().iterations == direct.iterations);
  CHECK(engine.referencePositions().size() == 0);

  // The reference alone (measure's request): the deformation is not solved again.
  EditParams referenceOnly = deformParams;
  referenceOnly.deform = false;
  referenceOnly.reference = true;
  engine.setEdit(barHandles(bar, 1.0), referenceOnly);
  u = engine.updateOrThrow();
  CHECK(u.deformationWork == "none");
  CHECK(u.referenceWork == "analysis");
  REQUIRE(engine.referencePositions().rows() == bar.numVertices());
  options.regularization = Regularization::None;
  options.weights.resize(0);
  DeformationSession plain(disc, options);
  plain.setHandles(handles.allVertices());
  plain.setTargets(handles.allTargets());
  CHECK((engine.referencePositions() - plain.solve().positions).cwiseAbs().maxCoeff() < 1e-12);

  // Back to the deformation: its shape comes back without a solve.
  engine.setEdit(barHandles(bar, 1.0), deformParams);
  u = engine.updateOrThrow();
  CHECK(u.deformationWork == "none");
  CHECK((engine.positions().leftCols(2) - direct.positions).cwiseAbs().maxCoeff() < 1e-12);
}

TEST_CASE("edit engine: one-shot settings keep an unregularized system small", "[engine]") {
  // Interactive: the facet couplings are reserved, so turning regularization on refactors.
  // One-shot: an unregularized edit analyses the smaller pattern; regularizing it later must
  // analyse again (a new session), and gives the same shape as the interactive engine.
  const Mesh bar = shipped("bar.obj");
  EngineSettings oneShot;
  oneShot.interactive = false;
  EditEngine interactive(bar), once(bar, oneShot);
  EditParams p;
  p.scheme = WeightScheme::Given;
  p.regularization = Regularization::None;
  for (EditEngine* e : {&interactive, &once}) {
    e->setEdit(barHandles(bar, 1.0), p);
    CHECK(e->updateOrThrow().deformationWork == "analysis");
  }
  p.regularization = Regularization::Uniform;
  interactive.setEdit(barHandles(bar, 1.0), p);
  once.setEdit(barHandles(bar, 1.0), p);
  CHECK(interactive.updateOrThrow().deformationWork == "numeric");
  CHECK(once.updateOrThrow().deformationWork == "analysis");
  CHECK((interactive.positions() - once.positions()).cwiseAbs().maxCoeff() < 1e-9);
}

TEST_CASE("edit engine: the maps of a deformation are those of its shape", "[engine]") {
  // Without coupled targets the maps take the run's own fits (DeformationSession::ownResiduals);
  // with them they fit every element at the shape. Either way, the maps of the shape.
  const Mesh bar = shipped("bar.obj");
  for (bool interactive : {true, false})
    for (Regularization mode : {Regularization::None, Regularization::Uniform}) {
      INFO("interactive " << interactive << ", " << toString(mode));
      EngineSettings settings;
      settings.interactive = interactive;
      EditEngine e(bar, settings);
      EditParams p;
      p.scheme = WeightScheme::Given;
      p.regularization = mode;
      p.iterations = 4;
      e.setEdit(barHandles(bar, 1.0), p);
      e.updateOrThrow();
      const ElementMaps expected = elementMaps(e.discretization(), p.energy,
                                               e.positions().leftCols(e.discretization().dim()));
      CHECK(e.distortion() == expected.distortion);
      CHECK(e.smoothness() == expected.smoothness);
      CHECK(e.distortion().maxCoeff() > 0.0);
    }
}

TEST_CASE("edit engine: updateOrThrow rethrows the failure's own exception", "[engine]") {
  const Mesh bar = shipped("bar.obj");
  EditEngine engine(bar);
  EditParams p;
  p.scheme = WeightScheme::Given;
  p.regularization = Regularization::Nonuniform;
  p.givenWeights = Eigen::VectorXd::Constant(bar.numVertices(), 2.0);  // outside [0, 1]
  engine.setEdit(barHandles(bar, 1.0), p);
  CHECK_THROWS_AS(engine.updateOrThrow(), InvalidParameter);
  CHECK_FALSE(engine.lastUpdate().solved);
  CHECK_FALSE(engine.lastUpdate().converged);  // nothing solved, nothing converged
  // Asked again with nothing changed: the same answer.
  const UpdateReport again = engine.update();
  CHECK_FALSE(again.solved);
  CHECK_FALSE(again.converged);
  CHECK(engine.positions() == bar.positions());  // the previous results are kept

  // Given weights of the wrong length are refused by validation, naming them.
  p.givenWeights = Eigen::VectorXd::Zero(3);
  CHECK_THROWS_WITH(engine.setEdit(barHandles(bar, 1.0), p), Catch::Contains("given weights"));
}

TEST_CASE("edit engine: without the deformation the metrics stay empty while the reference "
          "refines", "[engine]") {
  EditEngine s(shipped("bar.obj"));
  EditState state = s.state();
  state.params.deform = false;  // the weights filters' setting: the shape stays at rest
  state.params.seconds = 1e-9;  // the reference then refines for several updates
  state.handles.push_back(handle(s, state, {0, 33, 66, 99, 132}));
  state.handles.push_back(handle(s, state, {32, 65, 98, 131, 164}));
  s.setState(state);
  REQUIRE(s.update().solved);
  state.handles[1].targets.col(1).array() += 1.0;  // a drag
  s.setState(state);
  int rounds = 0;
  do {
    REQUIRE(s.update().solved);
    CHECK(s.metrics().dMax == 0.0);
    CHECK_FALSE(s.metrics().dist.has_value());
  } while (s.refine() && ++rounds < 5000);
}
