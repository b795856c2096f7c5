#include <diffreg/engine/edit_engine.h>

#include <diffreg/core/error.h>
#include <diffreg/core/timer.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

namespace diffreg {

namespace {

std::string num(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

void checkRange(const std::string& what, double value, double lo, double hi, bool openLow) {
  const bool low = openLow ? value > lo : value >= lo;
  if (!std::isfinite(value) || !low || value > hi)
    throw InvalidParameter(what + " = " + num(value) + " is outside " + (openLow ? "(" : "[") +
                           num(lo) + ", " + num(hi) + "]");
}

std::vector<std::vector<int>> vertexSets(const EditState& s) {
  std::vector<std::vector<int>> sets;
  for (const EditHandle& h : s.handles) sets.push_back(h.vertices);
  return sets;
}

bool sameTargets(const EditState& a, const EditState& b) {
  if (vertexSets(a) != vertexSets(b)) return false;
  for (size_t j = 0; j < a.handles.size(); ++j)
    if (a.handles[j].targets != b.handles[j].targets) return false;
  return true;
}

bool sameDiffusion(const DiffusionParams& a, const DiffusionParams& b) {
  return a.t == b.t && a.unit == b.unit && a.order == b.order && a.steps == b.steps &&
         a.solve == b.solve && a.clip == b.clip;
}

bool sameRbf(const RbfSettings& a, const RbfSettings& b) {
  return a.distance == b.distance && a.sigma == b.sigma && a.sigmaAbsolute == b.sigmaAbsolute &&
         a.clamp == b.clamp;
}

bool sameRangesAndMagnitudes(const EditState& a, const EditState& b) {
  if (a.handles.size() != b.handles.size()) return false;
  for (size_t j = 0; j < a.handles.size(); ++j)
    if (a.handles[j].range != b.handles[j].range ||
        a.handles[j].magnitude != b.handles[j].magnitude)
      return false;
  return true;
}

/// The costliest phase a counter difference shows.
std::string workOf(const SolverStats& s) {
  if (s.symbolic > 0) return "analysis";
  if (s.numeric > 0) return "numeric";
  if (s.solves > 0) return "solve";
  return "none";
}

/// A deformation kept in line with the wanted state: the edit itself, or the same edit without
/// regularization for Dist.
struct TrackedDeformation {
  std::unique_ptr<DeformationSession> session;
  std::optional<EditState> synced;  // the state it was last brought in line with
  Eigen::MatrixXd positions;        // n x d, its last result
  bool converged = true;
  double criterion = 0.0;   // its last run's stopping criterion
  long weightsSerial = -1;  // the weights its regularization was set from
  void reset() {
    session.reset();
    synced.reset();
    converged = true;
    criterion = 0.0;
  }
};

/// How a tracked deformation's sessions are made.
struct SessionSetup {
  const Discretization& disc;
  const EngineSettings& settings;
  const std::function<void(int, double, double)>* progress;  // null: none (the reference)
};

/// A deformation session for `p` with regularization `mode` (`regularized`: the edit's own,
/// else the reference, never regularized).
std::unique_ptr<DeformationSession> newSession(const SessionSetup& setup, const EditParams& p,
                                               Regularization mode, bool regularized,
                                               const Eigen::VectorXd& weights) {
  DeformationOptions options;
  options.energy = p.energy;
  options.regularization = mode;
  options.beta = p.beta;
  options.localStep = p.localStep;
  options.acceleration = p.acceleration;
  options.history = p.history;
  if (options.regularization == Regularization::Nonuniform) options.weights = weights;
  // The reference is never regularized: the smaller pattern. So is a one-shot unregularized
  // edit; the editor's may become regularized later.
  options.reserveRegularization =
      regularized && (setup.settings.interactive || mode != Regularization::None);
  options.backend = setup.settings.backend;
  options.handleBasis = setup.settings.interactive;  // drags start without a solve
  if (setup.progress != nullptr) {
    const std::function<void(int, double, double)>* progress = setup.progress;
    options.progress = [progress](int iteration, double energy, double criterion) {
      if (*progress) (*progress)(iteration, energy, criterion);
    };
  }
  return std::make_unique<DeformationSession>(setup.disc, options);
}

/// Brings `tracked` in line with `want` at the least cost: a new session for a new energy, local
/// step, acceleration or history, or when the regularization needs the facet couplings the
/// session did not reserve; new handles, targets or regularization (`regularized`: the edit's own,
/// from `weights`; otherwise none); then a solve, a continued drag (only targets moved, with
/// continueDrags) or, when `refine` or (interactive engines) a new iteration cap or tolerance
/// alone and the run is short of the tolerance, a resumed run, each within
/// `seconds` (0: no limit). Returns whether it solved (then `result` holds the run) and the
/// solver work in `work`.
bool syncDeformation(const SessionSetup& setup, TrackedDeformation& tracked, const EditState& want,
                     bool regularized, const Eigen::VectorXd& weights, long weightsSerial,
                     bool refine, double seconds, DeformationResult& result, SolverStats& work) {
  const EditParams& p = want.params;
  const std::optional<EditState>& had = tracked.synced;
  const Regularization mode = regularized ? p.regularization : Regularization::None;
  const bool fresh =
      !tracked.session || !had || had->params.energy != p.energy ||
      had->params.localStep != p.localStep || had->params.acceleration != p.acceleration ||
      had->params.history != p.history ||
      (mode != Regularization::None && !tracked.session->options().reserveRegularization);
  if (fresh) {
    tracked.session = newSession(setup, p, mode, regularized, weights);
    tracked.weightsSerial = weightsSerial;
  }
  DeformationSession& session = *tracked.session;
  const SolverStats before = fresh ? SolverStats{} : session.stats();
  const HandleSet wanted = toHandleSet(want);
  const std::vector<int> vertices = wanted.allVertices();
  bool dirty = fresh;
  if (fresh || toHandleSet(*had).allVertices() != vertices) {
    session.setHandles(vertices);
    dirty = true;
  }
  // A drag: only targets moved since the last solve, which continues from its result.
  bool drag = !dirty && p.continueDrags;
  if (dirty || !sameTargets(*had, want)) {
    session.setTargets(wanted.allTargets());
    dirty = true;
  }
  bool budget = false;
  if (!fresh) {
    const EditParams& q = had->params;
    budget = q.iterations != p.iterations || q.tolerance != p.tolerance;
    const bool regChanged =
        regularized && (q.regularization != p.regularization ||
                        (p.regularization == Regularization::Uniform && q.beta != p.beta) ||
                        (p.regularization == Regularization::Nonuniform &&
                         tracked.weightsSerial != weightsSerial));
    if (regChanged) {
      session.setRegularization(
          p.regularization, p.beta,
          p.regularization == Regularization::Nonuniform ? weights : Eigen::VectorXd());
      tracked.weightsSerial = weightsSerial;
    }
    // One-shot engines (the filters) solve every edit from the rest shape, whatever changed.
    if (regChanged || (budget && !setup.settings.interactive)) {
      drag = false;
      dirty = true;
    }
  }
  // Refining: the last run stopped at its iteration budget, or a new cap or tolerance finds it
  // short of converged; continue from its shape. A new budget alone keeps the shape.
  const bool converged = tracked.converged && tracked.criterion <= p.tolerance;
  const bool refining = (refine || budget) && !dirty && !converged;
  const bool solve = dirty || refining;
  if (solve) {
    session.setTimeBudget(seconds);
    result = refining ? session.resume(p.iterations, p.tolerance)
             : drag   ? session.solveFrom(tracked.positions, p.iterations, p.tolerance)
                      : session.solve(p.iterations, p.tolerance);
    tracked.positions = result.positions;
    tracked.converged = result.converged;
    tracked.criterion = result.criterion;
  }
  tracked.synced = want;
  work = session.stats() - before;
  return solve;
}

}  // namespace

/// The systems and the state each was last brought in line with.
struct EditEngine::Systems {
  std::unique_ptr<DiffusionWeights> diffusion;
  std::optional<EditState> diffusionSynced;
  Eigen::VectorXd diffused;  // the diffusion's last weights
  std::optional<EditState> rbfSynced;
  long weightsSerial = 0;  // incremented whenever the weights change
  TrackedDeformation deform, reference;
};

// The discretization of the mesh taken over (mesh_ is initialized first): no copy of the mesh.
EditEngine::EditEngine(Mesh mesh, EngineSettings settings)
    : mesh_(std::move(mesh)),
      disc_(std::make_shared<const Discretization>(mesh_)),
      settings_(settings),
      systems_(std::make_unique<Systems>()) {
  initialize();
}

EditEngine::EditEngine(Mesh mesh, std::shared_ptr<const Discretization> disc,
                       EngineSettings settings)
    : mesh_(std::move(mesh)),
      disc_(std::move(disc)),
      settings_(settings),
      systems_(std::make_unique<Systems>()) {
  if (!disc_ || disc_->numVertices() != mesh_.numVertices())
    throw InvalidParameter("edit engine: the discretization is not of this mesh");
  initialize();
}

void EditEngine::initialize() {
  positions_ = mesh_.positions();
  // The centre of the referenced vertices, as the diagonal that validate() pairs it with.
  const Eigen::AlignedBox3d box = meshBounds(positions_, disc_->active());
  restCenter_.setZero();
  if (!box.isEmpty()) restCenter_ = box.center();
  weights_ = Eigen::VectorXd::Zero(disc_->numVertices());
  distortion_ = Eigen::VectorXd::Zero(disc_->numElements());
  smoothness_ = Eigen::VectorXd::Zero(disc_->numElements());
}

EditEngine::~EditEngine() = default;

void EditEngine::validate(const EditState& s) const {
  const int n = disc_->numVertices();
  const std::vector<bool>& active = disc_->active();
  const Eigen::Vector3d& center = restCenter_;
  const double reach = 1000.0 * std::max(disc_->boundingBoxDiagonal(), 1e-300);
  std::vector<int> owner(static_cast<size_t>(n), -1);
  std::set<int> ids;
  std::set<std::string> names;
  for (const EditHandle& h : s.handles) {
    const std::string name =
        "handle " + std::to_string(h.id) + (h.name.empty() ? std::string() : " ('" + h.name + "')");
    if (h.id < 0 || h.id >= s.nextId)
      throw InvalidParameter(name + ": id must be in [0, " + std::to_string(s.nextId) + ")");
    if (!ids.insert(h.id).second) throw InvalidParameter(name + ": id used twice");
    if (!h.name.empty() && !names.insert(h.name).second)
      throw InvalidParameter(name + ": another handle is named '" + h.name +
                             "' (a handle file needs names of its own)");
    if (h.vertices.empty()) throw InvalidParameter(name + " selects no vertex");
    for (int v : h.vertices) {
      if (v < 0 || v >= n)
        throw InvalidParameter(name + ": vertex " + std::to_string(v) +
                               " does not exist (the mesh has " + std::to_string(n) + " vertices)");
      if (!active[static_cast<size_t>(v)])
        throw InvalidParameter(name + ": vertex " + std::to_string(v) + " belongs to no element");
      int& o = owner[static_cast<size_t>(v)];
      if (o == h.id)
        throw InvalidParameter(name + ": vertex " + std::to_string(v) + " is listed twice");
      if (o >= 0)
        throw InvalidParameter(name + ": vertex " + std::to_string(v) + " is already in handle " +
                               std::to_string(o));
      o = h.id;
    }
    checkRange(name + ": range", h.range, kMinHandleRange, kMaxHandleRange, false);
    checkRange(name + ": magnitude", h.magnitude, 0.0, 1.0, false);
    // Weights alone need no targets.
    if (h.targets.size() == 0 && !s.params.deform && !s.params.reference) continue;
    if (h.targets.rows() != static_cast<Eigen::Index>(h.vertices.size()) || h.targets.cols() != 3)
      throw InvalidParameter(name + ": " + std::to_string(h.vertices.size()) +
                             " vertices need as many targets of 3 coordinates");
    for (Eigen::Index i = 0; i < h.targets.rows(); ++i) {
      const Eigen::Vector3d p = h.targets.row(i).transpose();
      if (!p.allFinite())
        throw InvalidParameter(name + ": the target of vertex " + std::to_string(h.vertices[i]) +
                               " is not a finite position");
      if ((p - center).norm() > reach)
        throw InvalidParameter(name + ": the target of vertex " + std::to_string(h.vertices[i]) +
                               " is more than 1000 mesh diagonals away");
    }
  }
  const EditParams& p = s.params;
  checkRange("beta", p.beta, 0.0, 1.0, false);
  checkRange("t", p.diffusion.t, kMinDiffusionTime, kMaxDiffusionTime, false);
  checkRange("steps", p.diffusion.steps, 1, kMaxDiffusionSteps, false);
  checkRange("sigma", p.rbf.sigma, kMinRbfSigma, kMaxRbfSigma, false);
  checkRange("iterations", p.iterations, 1, kMaxIterations, false);
  checkRange("tolerance", p.tolerance, 0.0, 1.0, false);
  checkRange("seconds", p.seconds, 0.0, 3600.0, false);
  checkRange("history", p.history, 1, 100, false);
  if (p.givenWeights.size() != 0 && p.givenWeights.size() != n)
    throw InvalidParameter("given weights: " + std::to_string(p.givenWeights.size()) +
                           " values for " + std::to_string(n) + " vertices");
}

void EditEngine::setState(EditState state) {
  // Planar meshes: targets live in the mesh's plane.
  if (mesh_.kind() == MeshKind::Planar) {
    const Mesh::PointRows rest = mesh_.points();
    for (EditHandle& h : state.handles)
      for (Eigen::Index i = 0; i < h.targets.rows() && h.targets.cols() == 3; ++i)
        if (h.vertices[static_cast<size_t>(i)] >= 0 &&
            h.vertices[static_cast<size_t>(i)] < rest.rows())
          h.targets(i, 2) = rest(h.vertices[static_cast<size_t>(i)], 2);
  }
  validate(state);
  state_ = std::move(state);
  ++version_;
}

void EditEngine::setHandles(const HandleSet& handles) { setEdit(handles, state_.params); }

void EditEngine::setEdit(const HandleSet& handles, EditParams params) {
  EditState s = state_;
  s.params = std::move(params);
  s.handles.clear();
  for (const Handle& h : handles.handles) {
    EditHandle e;
    e.id = s.nextId++;
    e.name = h.name;
    e.vertices = h.vertices;
    e.targets = h.targets;
    e.range = h.range;
    e.magnitude = h.magnitude;
    s.handles.push_back(std::move(e));
  }
  setState(std::move(s));
}

bool EditEngine::refine() {
  if (computedVersion_ != version_) return true;  // the pending update solves anyway
  if (!last_.solved || last_.converged) return false;
  refine_ = true;
  return true;
}

UpdateReport EditEngine::update() {
  UpdateReport report;
  if (computedVersion_ == version_ && !refine_) {
    report.solved = last_.solved;
    report.converged = last_.converged;
    report.message = last_.message;
    report.failure = last_.failure;
    return report;
  }
  const Timer total;
  try {
    compute(state_, report);
    computed_ = state_;
  } catch (const std::exception& e) {
    // Rebuild every system at the next update; keep the previous results.
    systems_ = std::make_unique<Systems>();
    computed_.reset();
    report = UpdateReport{};
    report.solved = false;
    report.converged = false;  // nothing solved, nothing converged (refine() skips it too)
    report.message = e.what();
    report.failure = std::current_exception();
  }
  computedVersion_ = version_;
  refine_ = false;
  report.seconds = total.seconds();
  weightTotals_ += report.weights;
  deformTotals_ += report.deformation;
  referenceTotals_ += report.reference;
  last_ = report;
  return report;
}

void EditEngine::compute(const EditState& want, UpdateReport& report) {
  Systems& S = *systems_;
  const EditParams& p = want.params;
  const bool hasHandles = !want.handles.empty();
  Timer timer;
  Eigen::VectorXd weights = weights_;
  const bool weightsChanged = computeWeights(want, weights, report);
  report.weightsSeconds = timer.seconds();

  timer.reset();
  Eigen::MatrixXd positions;  // the new shape when it changed (`deformed`)
  bool deformed = false;
  if (!hasHandles || !p.deform) {
    deformed = !computed_ || positions_ != mesh_.points();
    if (deformed) positions = mesh_.points();
    if (!hasHandles) {
      S.deform.reset();
      S.reference.reset();
    }
    report.converged = true;
  } else {
    const SessionSetup setup{*disc_, settings_, &progress_};
    DeformationResult result;
    if (syncDeformation(setup, S.deform, want, true, weights, S.weightsSerial, refine_, p.seconds,
                        result, report.deformation)) {
      result.positions.resize(0, 0);  // kept in S.deform.positions
      lastRun_ = std::move(result);
      deformed = true;
    }
    // The shape of the deformation, also when it did not solve again (the shape may have
    // been at rest for a state without deformation).
    deformed = deformed || !computed_ || !computed_->params.deform;
    if (deformed && S.deform.positions.cols() == 3) {
      positions = S.deform.positions;
    } else if (deformed) {  // planar: the rest z
      positions = mesh_.points();
      positions.leftCols(disc_->dim()) = S.deform.positions;
    }
    report.iterations = lastRun_.iterations;
    report.criterion = lastRun_.criterion;
    report.initialGuess = lastRun_.initialGuess;
    report.converged = S.deform.converged;
    report.deformationWork = workOf(report.deformation);
  }
  report.deformationSeconds = timer.seconds();

  // The same edit without regularization, for Dist.
  timer.reset();
  bool referenceChanged = false;
  if (wantsReference(want)) {
    const SessionSetup setup{*disc_, settings_, nullptr};
    DeformationResult result;
    // What the update's time budget has left (one iteration at least): the shape comes first,
    // the reference catches up while the editor refines.
    const double left =
        p.seconds > 0.0 ? std::max(1e-9, p.seconds - report.deformationSeconds) : 0.0;
    referenceChanged = syncDeformation(setup, S.reference, want, false, weights, S.weightsSerial,
                                       refine_, left, result, report.reference);
    report.converged = report.converged && S.reference.converged;
    report.referenceWork = workOf(report.reference);
  } else {
    S.reference.synced.reset();  // targets may move meanwhile: resynchronize when needed again
    S.reference.converged = true;
  }
  report.referenceSeconds = timer.seconds();

  // Per-element maps and the Table-1 metrics of a deformation.
  timer.reset();
  const Eigen::MatrixXd& shape = deformed ? positions : positions_;
  if (deformed || weightsChanged || mapsParamsChanged(want))
    refreshMaps(want, shape);
  else if (referenceChanged)  // only the reference moved (it refines after the shape): Dist
    refreshDist(want, shape);
  report.metricsSeconds = timer.seconds();
  if (deformed) positions_.swap(positions);
  weights_ = weights;
}

void EditEngine::refreshDist(const EditState& want, const Eigen::MatrixXd& positions) {
  // As refreshMaps: without the deformation (deform off) the metrics stay zero, Dist unset.
  if (want.params.deform && want.params.metrics && want.params.reference && wantsReference(want))
    metrics_.dist = rmsDistance(positions.leftCols(disc_->dim()), systems_->reference.positions,
                                disc_->active());
}

bool EditEngine::mapsParamsChanged(const EditState& want) const {
  if (!computed_) return true;
  const EditParams &p = want.params, &q = computed_->params;
  return q.energy != p.energy || q.regularization != p.regularization || q.beta != p.beta ||
         q.reference != p.reference || q.metrics != p.metrics || q.deform != p.deform;
}

void EditEngine::refreshMaps(const EditState& want, const Eigen::MatrixXd& positions) {
  if (want.handles.empty() || want.params.deform) {
    computeMaps(want, positions);
  } else {
    distortion_.setZero(disc_->numElements());
    smoothness_.setZero(disc_->numElements());
    metrics_ = DeformationMetrics{};
  }
}

bool EditEngine::wantsReference(const EditState& want) {
  return !want.handles.empty() && want.params.reference &&
         want.params.regularization != Regularization::None;
}

const Eigen::MatrixXd& EditEngine::referencePositions() const {
  static const Eigen::MatrixXd none;
  return computed_ && wantsReference(*computed_) ? systems_->reference.positions : none;
}

bool EditEngine::computeWeights(const EditState& want, Eigen::VectorXd& weights,
                                UpdateReport& report) {
  Systems& S = *systems_;
  const EditParams& p = want.params;
  bool changed = false;
  if (want.handles.empty()) {
    const int n = disc_->numVertices();
    changed = weights.size() != n || weights.cwiseAbs().maxCoeff() != 0.0;
    weights = Eigen::VectorXd::Zero(n);
    S.diffusionSynced.reset();
    S.rbfSynced.reset();
  } else if (p.scheme == WeightScheme::Diffusion) {
    S.rbfSynced.reset();
    if (!S.diffusion) {
      S.diffusion = std::make_unique<DiffusionWeights>(*disc_, settings_.backend);
      // The editor's magnitude sliders: every m_j change a superposition from the start.
      S.diffusion->setHandleBasis(settings_.interactive);
    }
    const SolverStats before = S.diffusion->stats();
    const bool solved = syncDiffusion(want);
    if (solved) {
      S.diffused = S.diffusion->solve();
      report.diffusionSolve = S.diffusion->lastSolve();
    }
    // The diffusion keeps its state while other schemes are used; its weights come back.
    if (weights.size() != S.diffused.size() || weights != S.diffused) {
      weights = S.diffused;
      changed = true;
    }
    report.absoluteTime = S.diffusion->absoluteTime();
    S.diffusionSynced = want;
    report.weights = S.diffusion->stats() - before;
    report.weightsWork = workOf(report.weights);
    // New weights without a solve: a magnitude applied by superposition (DiffusionWeights).
    if (solved && report.weightsWork == "none") report.weightsWork = "superpose";
  } else if (p.scheme == WeightScheme::Rbf) {
    const std::optional<EditState>& had = S.rbfSynced;
    report.absoluteSigma =
        p.rbf.sigmaAbsolute ? p.rbf.sigma : rbfSigmaFromDiagonal(*disc_, p.rbf.sigma);
    if (!had || vertexSets(*had) != vertexSets(want) || !sameRangesAndMagnitudes(*had, want) ||
        !sameRbf(had->params.rbf, p.rbf)) {
      weights =
          rbfWeights(mesh_, toHandleSet(want), report.absoluteSigma, p.rbf.distance, p.rbf.clamp);
      changed = true;
      report.weightsWork = "evaluate";
    }
    S.rbfSynced = want;
  } else {  // given
    S.rbfSynced.reset();
    const Eigen::VectorXd given =
        p.givenWeights.size() == 0 ? Eigen::VectorXd::Zero(disc_->numVertices()) : p.givenWeights;
    changed = weights.size() != given.size() || weights != given;
    if (changed) weights = given;
  }
  if (changed) ++S.weightsSerial;
  return changed;
}

bool EditEngine::syncDiffusion(const EditState& want) {
  Systems& S = *systems_;
  DiffusionWeights& diffusion = *S.diffusion;
  const std::optional<EditState>& had = S.diffusionSynced;
  if (!had || vertexSets(*had) != vertexSets(want)) {
    std::vector<double> r, m;
    for (const EditHandle& h : want.handles) {
      r.push_back(h.range);
      m.push_back(h.magnitude);
    }
    diffusion.setParams(want.params.diffusion);
    diffusion.setHandles(vertexSets(want), r, m);
    return true;
  }
  bool dirty = false;
  for (size_t j = 0; j < want.handles.size(); ++j) {
    const int jj = static_cast<int>(j);
    if (want.handles[j].range != had->handles[j].range) {
      diffusion.setRange(jj, want.handles[j].range);
      dirty = true;
    }
    if (want.handles[j].magnitude != had->handles[j].magnitude) {
      diffusion.setMagnitude(jj, want.handles[j].magnitude);
      dirty = true;
    }
  }
  if (!sameDiffusion(had->params.diffusion, want.params.diffusion)) {
    diffusion.setParams(want.params.diffusion);
    dirty = true;
  }
  return dirty;
}

void EditEngine::computeMaps(const EditState& want, const Eigen::MatrixXd& positions) {
  const Systems& S = *systems_;
  const EditParams& p = want.params;
  Eigen::MatrixXd planar;  // a planar mesh's x and y
  if (positions.cols() != disc_->dim()) planar = positions.leftCols(disc_->dim());
  const Eigen::MatrixXd& X = positions.cols() != disc_->dim() ? planar : positions;
  std::optional<RegularizationWeights> restWeights;  // without handles: no session
  if (!S.deform.session)
    restWeights = makeRegularizationWeights(*disc_, p.regularization, p.beta,
                                            Eigen::VectorXd::Zero(disc_->numVertices()));
  const RegularizationWeights& regWeights =
      restWeights ? *restWeights : S.deform.session->regularizationWeights();
  const Eigen::MatrixXd* reference = nullptr;
  if (p.reference) reference = wantsReference(want) ? &S.reference.positions : &X;
  DeformationMetrics metrics;
  // An unconverged deformation reports its own energy: relaxing its targets would take longer
  // than the update's iterations (EditParams::seconds).
  const bool unconverged = S.deform.session && !S.deform.converged && !lastRun_.energies.empty();
  const double* runEnergy = unconverged ? &lastRun_.energies.back() : nullptr;
  // A converged deformation's targets at X are settled already: the relaxation starts there.
  ElementTargets runTargets;
  if (p.metrics && !runEnergy && S.deform.session) runTargets = S.deform.session->lastTargets();
  // The run's own per-element fits at X serve the maps, when it has them (no coupled targets);
  // the maps' distortion serves the metrics.
  const ElementTargets residuals =
      S.deform.session && S.deform.session->options().energy == p.energy
          ? S.deform.session->ownResiduals(X)
          : ElementTargets();
  ElementMaps maps = residuals.size() > 0 ? elementMapsFromResiduals(*disc_, p.energy, residuals)
                                          : elementMaps(*disc_, p.energy, X);
  if (p.metrics)
    metrics = measureDeformation(*disc_, p.energy, X, regWeights, reference, runEnergy,
                                 runTargets.size() > 0 ? &runTargets : nullptr, &maps.distortion);
  metrics_ = metrics;
  distortion_ = std::move(maps.distortion);
  smoothness_ = std::move(maps.smoothness);
}

UpdateReport EditEngine::updateOrThrow() {
  UpdateReport report = update();
  if (!report.solved) {
    if (report.failure) std::rethrow_exception(report.failure);
    throw InvalidParameter(report.message);
  }
  return report;
}

EditParams editParamsOf(const DeformationOptions& options) {
  EditParams p;
  p.energy = options.energy;
  p.regularization = options.regularization;
  p.beta = options.beta;
  p.scheme = WeightScheme::Given;
  p.givenWeights = options.weights;
  p.iterations = options.maxIterations;
  p.tolerance = options.relTolerance;
  p.localStep = options.localStep;
  p.acceleration = options.acceleration;
  p.history = options.history;
  p.reference = false;
  p.metrics = false;
  return p;
}

HandleSet EditEngine::handleSet() const { return toHandleSet(state_); }

std::vector<std::string> handleNames(const EditState& state) {
  std::set<std::string> taken;
  for (const EditHandle& h : state.handles)
    if (!h.name.empty()) taken.insert(h.name);
  std::vector<std::string> names;
  for (const EditHandle& h : state.handles) {
    if (!h.name.empty()) {
      names.push_back(h.name);
      continue;
    }
    const std::string base = "handle-" + std::to_string(h.id);
    std::string name = base;
    for (int k = 2; !taken.insert(name).second; ++k) name = base + "-" + std::to_string(k);
    names.push_back(name);
  }
  return names;
}

HandleSet toHandleSet(const EditState& state) {
  HandleSet set;
  const std::vector<std::string> names = handleNames(state);
  for (size_t j = 0; j < state.handles.size(); ++j) {
    const EditHandle& e = state.handles[j];
    Handle h;
    h.name = names[j];
    h.vertices = e.vertices;
    h.targets = e.targets;
    h.range = e.range;
    h.magnitude = e.magnitude;
    set.handles.push_back(std::move(h));
  }
  return set;
}

Mesh EditEngine::resultMesh() const {
  Mesh out = mesh_;
  out.setPositions(positions_);
  out.setVertexScalar(prop::weight, weights_);
  out.setElementScalar(prop::distortion, distortion_);
  out.setElementScalar(prop::smoothness, smoothness_);
  return out;
}

}  // namespace diffreg
