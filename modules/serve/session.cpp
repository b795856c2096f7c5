#include <diffreg/serve/session.h>

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
  return a.distance == b.distance && a.sigma == b.sigma && a.clamp == b.clamp;
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
  long weightsSerial = -1;  // the weights its regularization was set from
  void reset() {
    session.reset();
    synced.reset();
    converged = true;
  }
};

/// Brings `tracked` in line with `want` at the least cost: a new session for a new energy, local
/// step or acceleration; new handles, targets or regularization (`regularized`: the edit's own,
/// from `weights`; otherwise none); then a solve, a continued drag (only targets moved, with
/// continueDrags) or, when `refine` and nothing changed, a resumed unconverged run. Returns
/// whether it solved (then `result` holds the run) and the solver work in `work`.
bool syncDeformation(const Discretization& disc, SolverBackend backend, TrackedDeformation& tracked,
                     const EditState& want, bool regularized, const Eigen::VectorXd& weights,
                     long weightsSerial, bool refine, DeformationResult& result,
                     SolverStats& work) {
  const EditParams& p = want.params;
  const std::optional<EditState>& had = tracked.synced;
  const bool fresh = !tracked.session || !had || had->params.energy != p.energy ||
                     had->params.localStep != p.localStep ||
                     had->params.acceleration != p.acceleration;
  if (fresh) {
    DeformationOptions options;
    options.energy = p.energy;
    options.regularization = regularized ? p.regularization : Regularization::None;
    options.beta = p.beta;
    options.localStep = p.localStep;
    options.acceleration = p.acceleration;
    if (options.regularization == Regularization::Nonuniform) options.weights = weights;
    // The reference is never regularized: the smaller pattern.
    options.reserveRegularization = regularized;
    options.backend = backend;
    tracked.session = std::make_unique<DeformationSession>(disc, options);
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
  if (!fresh) {
    const EditParams& q = had->params;
    const bool budget = q.iterations != p.iterations || q.tolerance != p.tolerance;
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
    if (regChanged || budget) {
      drag = false;
      dirty = true;
    }
  }
  // Refining: the last run stopped at its iteration budget; continue from its shape.
  const bool refining = refine && !dirty && !tracked.converged;
  const bool solve = dirty || refining;
  if (solve) {
    result = refining ? session.resume(p.iterations, p.tolerance)
             : drag   ? session.solveFrom(tracked.positions, p.iterations, p.tolerance)
                      : session.solve(p.iterations, p.tolerance);
    tracked.positions = result.positions;
    tracked.converged = result.converged;
  }
  tracked.synced = want;
  work = session.stats() - before;
  return solve;
}

}  // namespace

/// The systems and the state each was last brought in line with.
struct EditSession::Systems {
  std::unique_ptr<DiffusionWeights> diffusion;
  std::optional<EditState> diffusionSynced;
  std::optional<EditState> rbfSynced;
  long weightsSerial = 0;  // incremented whenever the weights change
  TrackedDeformation deform, reference;
};

EditSession::EditSession(Mesh mesh, SolverBackend backend)
    : mesh_(std::move(mesh)),
      disc_(std::make_unique<Discretization>(mesh_)),
      backend_(backend),
      systems_(std::make_unique<Systems>()) {
  positions_ = mesh_.positions();
  weights_ = Eigen::VectorXd::Zero(disc_->numVertices());
  distortion_ = Eigen::VectorXd::Zero(disc_->numElements());
  smoothness_ = Eigen::VectorXd::Zero(disc_->numElements());
}

EditSession::~EditSession() = default;

void EditSession::validate(const EditState& s) const {
  const int n = disc_->numVertices();
  const std::vector<bool>& active = disc_->active();
  const Eigen::MatrixXd rest = mesh_.positions();
  const Eigen::Vector3d center = 0.5 * (rest.colwise().minCoeff() + rest.colwise().maxCoeff());
  const double reach = 1000.0 * std::max(disc_->boundingBoxDiagonal(), 1e-300);
  std::vector<int> owner(static_cast<size_t>(n), -1);
  std::set<int> ids;
  for (const EditHandle& h : s.handles) {
    const std::string name =
        "handle " + std::to_string(h.id) + (h.name.empty() ? std::string() : " ('" + h.name + "')");
    if (h.id < 0 || h.id >= s.nextId)
      throw InvalidParameter(name + ": id must be in [0, " + std::to_string(s.nextId) + ")");
    if (!ids.insert(h.id).second) throw InvalidParameter(name + ": id used twice");
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
    checkRange(name + ": range", h.range, 0.0, 1e6, true);
    checkRange(name + ": magnitude", h.magnitude, 0.0, 1.0, false);
  }
  const EditParams& p = s.params;
  checkRange("beta", p.beta, 0.0, 1.0, false);
  checkRange("t", p.diffusion.t, kMinDiffusionTime, kMaxDiffusionTime, false);
  checkRange("steps", p.diffusion.steps, 1, kMaxDiffusionSteps, false);
  checkRange("sigma", p.rbf.sigma, kMinRbfSigma, kMaxRbfSigma, false);
  checkRange("iterations", p.iterations, 1, kMaxIterations, false);
  checkRange("tolerance", p.tolerance, 0.0, 1.0, false);
}

void EditSession::setState(EditState state) {
  // Planar meshes: targets live in the mesh's plane.
  if (mesh_.kind() == MeshKind::Planar) {
    const Eigen::MatrixXd rest = mesh_.positions();
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

void EditSession::setHandles(const HandleSet& handles) {
  EditState s = state_;
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

bool EditSession::refine() {
  if (computedVersion_ != version_) return true;  // the pending update solves anyway
  if (!last_.solved || last_.converged) return false;
  refine_ = true;
  return true;
}

UpdateReport EditSession::update() {
  UpdateReport report;
  if (computedVersion_ == version_ && !refine_) {
    report.solved = last_.solved;
    report.message = last_.message;
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
    report.message = e.what();
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

void EditSession::compute(const EditState& want, UpdateReport& report) {
  Systems& S = *systems_;
  const EditParams& p = want.params;
  const bool hasHandles = !want.handles.empty();
  Timer timer;
  Eigen::VectorXd weights = weights_;
  const bool weightsChanged = computeWeights(want, weights, report);
  report.weightsSeconds = timer.seconds();

  timer.reset();
  Eigen::MatrixXd positions = positions_;
  bool deformed = false;
  if (!hasHandles) {
    positions = mesh_.positions();
    deformed = true;
    S.deform.reset();
    S.reference.reset();
    report.converged = true;
  } else {
    DeformationResult result;
    if (syncDeformation(*disc_, backend_, S.deform, want, true, weights, S.weightsSerial, refine_,
                        result, report.deformation)) {
      positions = mesh_.positions();
      positions.leftCols(disc_->dim()) = result.positions;
      report.iterations = result.iterations;
      report.criterion = result.criterion;
      report.initialGuess = result.initialGuess;
      deformed = true;
    } else {
      report.iterations = last_.iterations;
      report.criterion = last_.criterion;
      report.initialGuess = last_.initialGuess;
    }
    report.converged = S.deform.converged;
    report.deformationWork = workOf(report.deformation);
  }
  report.deformationSeconds = timer.seconds();

  // The same edit without regularization, for Dist.
  timer.reset();
  const bool wantReference = hasHandles && p.reference && p.regularization != Regularization::None;
  bool referenceChanged = false;
  if (wantReference) {
    DeformationResult result;
    referenceChanged = syncDeformation(*disc_, backend_, S.reference, want, false, weights,
                                       S.weightsSerial, refine_, result, report.reference);
    report.converged = report.converged && S.reference.converged;
    report.referenceWork = workOf(report.reference);
  } else {
    S.reference.synced.reset();  // targets may move meanwhile: resynchronize when needed again
    S.reference.converged = true;
  }
  report.referenceSeconds = timer.seconds();

  // Per-element maps and the Table-1 metrics.
  timer.reset();
  const bool paramsChanged = !computed_ || computed_->params.energy != p.energy ||
                             computed_->params.regularization != p.regularization ||
                             computed_->params.beta != p.beta ||
                             computed_->params.reference != p.reference;
  if (deformed || weightsChanged || referenceChanged || paramsChanged) computeMaps(want, positions);
  report.metricsSeconds = timer.seconds();
  positions_ = positions;
  weights_ = weights;
}

bool EditSession::computeWeights(const EditState& want, Eigen::VectorXd& weights,
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
    if (!S.diffusion) S.diffusion = std::make_unique<DiffusionWeights>(*disc_, backend_);
    const SolverStats before = S.diffusion->stats();
    if (syncDiffusion(want)) {
      weights = S.diffusion->solve();
      changed = true;
    }
    S.diffusionSynced = want;
    report.weights = S.diffusion->stats() - before;
    report.weightsWork = workOf(report.weights);
    // New weights without a solve: a magnitude applied by superposition (DiffusionWeights).
    if (changed && report.weightsWork == "none") report.weightsWork = "superpose";
  } else {
    S.diffusionSynced.reset();
    const std::optional<EditState>& had = S.rbfSynced;
    if (!had || vertexSets(*had) != vertexSets(want) || !sameRangesAndMagnitudes(*had, want) ||
        !sameRbf(had->params.rbf, p.rbf)) {
      const double sigma = rbfSigmaFromDiagonal(mesh_, p.rbf.sigma);
      weights = rbfWeights(mesh_, toHandleSet(want), sigma, p.rbf.distance, p.rbf.clamp);
      changed = true;
      report.weightsWork = "evaluate";
    }
    S.rbfSynced = want;
  }
  if (changed) ++S.weightsSerial;
  return changed;
}

bool EditSession::syncDiffusion(const EditState& want) {
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

void EditSession::computeMaps(const EditState& want, const Eigen::MatrixXd& positions) {
  const Systems& S = *systems_;
  const EditParams& p = want.params;
  const Eigen::MatrixXd X = positions.leftCols(disc_->dim());
  const bool hasHandles = !want.handles.empty();
  const RegularizationWeights regWeights =
      hasHandles ? S.deform.session->regularizationWeights()
                 : makeRegularizationWeights(*disc_, p.regularization, p.beta,
                                             Eigen::VectorXd::Zero(disc_->numVertices()));
  const bool wantReference = hasHandles && p.reference && p.regularization != Regularization::None;
  const Eigen::MatrixXd* reference = nullptr;
  if (p.reference) reference = wantReference ? &S.reference.positions : &X;
  DeformationMetrics metrics = measureDeformation(*disc_, p.energy, X, regWeights, reference);
  Eigen::VectorXd distortion = elementDistortion(*disc_, p.energy, X);
  Eigen::VectorXd smoothness = elementSmoothness(*disc_, facetSmoothness(*disc_, p.energy, X));
  metrics_ = metrics;
  distortion_ = std::move(distortion);
  smoothness_ = std::move(smoothness);
}

HandleSet EditSession::handleSet() const { return toHandleSet(state_); }

HandleSet toHandleSet(const EditState& state) {
  HandleSet set;
  for (const EditHandle& e : state.handles) {
    Handle h;
    h.name = e.name.empty() ? "handle-" + std::to_string(e.id) : e.name;
    h.vertices = e.vertices;
    h.targets = e.targets;
    h.range = e.range;
    h.magnitude = e.magnitude;
    set.handles.push_back(std::move(h));
  }
  return set;
}

Mesh EditSession::resultMesh() const {
  Mesh out = mesh_;
  out.setPositions(positions_);
  out.setVertexScalar(prop::weight, weights_);
  out.setElementScalar(prop::distortion, distortion_);
  out.setElementScalar(prop::smoothness, smoothness_);
  return out;
}

}  // namespace diffreg
