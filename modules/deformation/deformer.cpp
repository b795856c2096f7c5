#include <diffreg/deformation/deformer.h>
#include <diffreg/deformation/session_core.h>

#include <diffreg/core/error.h>
#include <diffreg/core/text.h>
#include <diffreg/discretization/element_order.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

namespace diffreg {

DeformationCore::DeformationCore(const Discretization& disc, const DeformationOptions& options)
    : elementOrder_(options.reserveRegularization || options.regularization != Regularization::None
                        ? localityElementOrder(disc)
                        : std::vector<int>()),
      ordered_(elementOrder_.empty()
                   ? nullptr
                   : std::make_unique<Discretization>(disc.withElementOrder(elementOrder_))),
      disc_(ordered_ ? *ordered_ : disc),
      options_(options),
      model_(disc_, options.energy),
      system_(model_, options.backend, options.reserveRegularization) {
  if (options.energy == Energy::Arap && disc_.kind() == MeshKind::Planar) {
    initModel_ = std::make_unique<ResidualModel>(disc_, Energy::Asap);
    initSystem_ = std::make_unique<RegularizedSystem>(*initModel_, options.backend,
                                                      options.reserveRegularization);
  }
  setRegularization(options.regularization, options.beta, options.weights);
}

DeformationCore::~DeformationCore() = default;

const RegularizationWeights& DeformationCore::regularizationWeights() const {
  return ordered_ ? meshOrderWeights_ : system_.weights();
}

ElementTargets DeformationCore::toCallerOrder(const Stacked& blocks) const {
  const Eigen::Index rows = model_.rows();  // per element
  ElementTargets out(blocks.rows(), blocks.cols());
  for (size_t k = 0; k < elementOrder_.size(); ++k)
    out.middleRows(static_cast<Eigen::Index>(elementOrder_[k]) * rows, rows) =
        blocks.middleRows(static_cast<Eigen::Index>(k) * rows, rows);
  return out;
}

ElementTargets DeformationCore::lastTargets() const {
  if (!resumable_) return {};
  if (!ordered_) return t_;
  return toCallerOrder(t_);
}

ElementTargets DeformationCore::ownResiduals(const Eigen::MatrixXd& positions) const {
  if (!resumable_ || !ownFits_ || positions.rows() != lastX_.rows() ||
      positions.cols() != lastX_.cols() || positions != lastX_)
    return {};
  Stacked e;
  model_.gradients(positions, e);
  e -= t_;
  if (!ordered_) return e;
  return toCallerOrder(e);
}

void DeformationCore::setHandles(const std::vector<int>& vertices) {
  if (vertices.empty()) throw InvalidParameter("deformation: the handle set is empty");
  std::vector<bool> seen(static_cast<size_t>(disc_.numVertices()), false);
  for (int v : vertices) {
    if (v < 0 || v >= disc_.numVertices())
      throw InvalidParameter("deformation: handle vertex " + std::to_string(v) +
                             " is out of range [0, " + std::to_string(disc_.numVertices()) + ")");
    if (seen[static_cast<size_t>(v)])
      throw InvalidParameter("deformation: handle vertex " + std::to_string(v) +
                             " is listed twice");
    seen[static_cast<size_t>(v)] = true;
  }
  handles_ = vertices;
  resumable_ = false;
  basis_.reset();
  targets_.resize(static_cast<Eigen::Index>(vertices.size()), disc_.dim());
  for (size_t i = 0; i < vertices.size(); ++i)
    targets_.row(static_cast<Eigen::Index>(i)) = disc_.rest().row(vertices[i]);
  system_.setHandles(vertices);
  if (initSystem_) initSystem_->setHandles(vertices);
}

void DeformationCore::setTargets(const Eigen::MatrixXd& targets) {
  const int d = disc_.dim();
  if (targets.rows() != static_cast<Eigen::Index>(handles_.size()) || targets.cols() < d ||
      targets.cols() > 3)
    throw InvalidParameter("deformation: targets are " + std::to_string(targets.rows()) + " x " +
                           std::to_string(targets.cols()) + " for " +
                           std::to_string(handles_.size()) + " handle vertices in " +
                           std::to_string(d) + "D");
  if (!targets.allFinite()) throw InvalidParameter("deformation: a target is not finite");
  targets_ = targets.leftCols(d);
  resumable_ = false;
}

void DeformationCore::setRegularization(Regularization mode, double beta,
                                        const Eigen::VectorXd& weights) {
  // Vertex weights with another mode would be ignored in silence: a caller who set them meant
  // them to act.
  if (mode != Regularization::Nonuniform && weights.size() > 0)
    throw InvalidParameter(std::string("regularization: vertex weights are given, but "
                                       "regularization is ") +
                           toString(mode) + "; they apply only with nonuniform");
  const RegularizationWeights w = makeRegularizationWeights(disc_, mode, beta, weights);
  options_.regularization = mode;
  options_.beta = beta;
  options_.weights = weights;
  system_.setWeights(w);
  if (ordered_) {  // the caller's element order; the facets keep theirs
    meshOrderWeights_.element.resize(w.element.size());
    for (Eigen::Index i = 0; i < w.element.size(); ++i)
      meshOrderWeights_.element(elementOrder_[static_cast<size_t>(i)]) = w.element(i);
    meshOrderWeights_.facet = w.facet;
  }
  resumable_ = false;
  restRhs_.resize(0, 0);  // C depends on the weights
  basis_.reset();
  initRhs_.resize(0, 0);
  if (initSystem_) initSystem_->setWeights(w);
}

void DeformationCore::setBeta(double beta) { setRegularization(Regularization::Uniform, beta); }

void DeformationCore::setWeights(const Eigen::VectorXd& weights) {
  setRegularization(Regularization::Nonuniform, 0.0, weights);
}

void DeformationCore::setHandleBasis(bool on) {
  options_.handleBasis = on;
  if (!on) basis_.reset();
}

void DeformationCore::setTimeBudget(double seconds) {
  if (!(seconds >= 0.0) || !std::isfinite(seconds))
    throw InvalidParameter(
        "deformation: the time budget must be a non-negative number of "
        "seconds, not " +
        formatNumber(seconds));
  budget_ = seconds;
}

bool DeformationCore::outOfTime(std::chrono::steady_clock::time_point iterationBegan) const {
  if (budget_ <= 0.0) return false;
  const auto now = std::chrono::steady_clock::now();
  return now + (now - iterationBegan) > deadline_;
}

SolverStats DeformationCore::stats() const {
  SolverStats s = system_.stats();
  if (initSystem_) s += initSystem_->stats();
  return s;
}

DeformationResult DeformationCore::solve(int maxIterations, double relTolerance) {
  return run(maxIterations, relTolerance, nullptr);
}

DeformationResult DeformationCore::solveFrom(const Eigen::MatrixXd& initial, int maxIterations,
                                             double relTolerance) {
  const int d = disc_.dim();
  if (initial.rows() != disc_.numVertices() || initial.cols() != d)
    throw InvalidParameter("deformation: the initial positions must be " +
                           std::to_string(disc_.numVertices()) + " x " + std::to_string(d) +
                           ", not " + std::to_string(initial.rows()) + " x " +
                           std::to_string(initial.cols()));
  if (!initial.allFinite())
    throw InvalidParameter("deformation: the initial positions are not all finite");
  return run(maxIterations, relTolerance, &initial);
}

Eigen::MatrixXd DeformationCore::restSolve() {
  // The rest targets' right-hand side changes only with the weights: every handle move starts
  // from it (the first global step of the iterative energies, the only one of the linear
  // energies). It is A x_rest (RegularizedSystem::restRightHandSide), after the factorization.
  system_.factorize();
  if (restRhs_.size() == 0) system_.restRightHandSide(restRhs_);
  if (options_.handleBasis && !model_.coupled()) {
    if (!basis_) basis_ = std::make_unique<HandleBasis>(disc_, handles_);
    if (basis_->usable()) {
      if (!basis_->built()) basis_->build(system_, restRhs_);
      Eigen::MatrixXd X;
      if (basis_->solve(targets_, X)) return X;
    }
  }
  return system_.solveRightHandSide(restRhs_, targets_);
}

double DeformationCore::local(const Eigen::MatrixXd& X, const Stacked* previous, Stacked& t,
                              double reference) {
  const double E = localStep(model_, system_.regularizer(), options_.localStep, X, previous, t,
                             scratch_, reference);
  if (!std::isfinite(E))
    throw NonFiniteSolution("deformation: the energy is not finite (degenerate solution)");
  return E;
}

void DeformationCore::report(const DeformationResult& result) const {
  if (options_.progress)
    options_.progress(result.iterations, result.energies.back(), result.criterion);
}

double DeformationCore::start(const Eigen::MatrixXd* initial, Eigen::MatrixXd& X,
                              DeformationResult& result) {
  // A first global step from the rest shape's or a given shape's targets has no iteration
  // before it to compare with: its criterion is not measured (NaN), not zero.
  result.criterion = std::numeric_limits<double>::quiet_NaN();
  // The first local step fits every target to its own element first (no previous targets).
  if (initial) {
    // The given shape's targets, then one global step: it puts the handles at their targets,
    // so that every later iterate has the fixed values the descent keeps.
    result.initialGuess = "given";
    result.energies.push_back(local(*initial, nullptr, t_));
    X = system_.solve(t_, targets_);
    result.iterations = 1;
  } else if (initSystem_ && initSystem_->singularity().empty()) {
    if (initRhs_.size() == 0) initSystem_->restRightHandSide(initRhs_);  // ASAP is linear in 2D
    X = initSystem_->solveRightHandSide(initRhs_, targets_);
    result.initialGuess = "asap";
  } else {
    // The rest shape's targets (identities): the first global step is the rest solve.
    X = restSolve();
    result.iterations = 1;
  }
  const double E = local(X, initial ? &t_ : nullptr, t_);
  result.energies.push_back(E);
  if (result.iterations > 0) report(result);
  return E;
}

namespace {

// A plain step (global, then local) is a descent in exact arithmetic: one that ends above the
// current energy gains less than rounding. The run then ends at the current iterate, converged,
// and reports no new iteration. So does a run whose energy is rounding alone (roundingLevel).
void settleAtRounding(DeformationResult& result) {
  result.criterion = 0.0;
  result.converged = true;
}

// How far above rounding an energy may be and still count as rounding alone (roundingLevel).
constexpr double kRoundingMargin = 100.0;

}  // namespace

// Coordinates hold about eps times the mesh's diagonal, so in the units of
// ResidualModel::energyScale (unit mean edge length) a gradient F_k of an exact shape is off by
// about eps diagonal / ell and its element's energy by the square of that: a rest shape under
// resting handles lands there (1e-30 to 1e-29 per element on the shipped bar, where the bound
// below is about 4e-25). An energy within kRoundingMargin^2 of it is rounding alone: a relative
// criterion would compare rounding with rounding and run to the cap. The bound sums over the
// elements, so an edit that moves a few elements by less than about sqrt(m) kRoundingMargin eps
// diagonal (2e-11 of the diagonal at a million elements) also ends at its first global step.
bool DeformationCore::roundingLevel(double E) const {
  const double ratio = disc_.boundingBoxDiagonal() / std::max(disc_.meanEdgeLength(), 1e-300);
  const double perElement = kRoundingMargin * std::numeric_limits<double>::epsilon() * ratio;
  return E <= perElement * perElement * disc_.numElements();
}

void DeformationCore::iterateReference(int maxIterations, double tolerance, Eigen::MatrixXd& X,
                                       double E, DeformationResult& result) {
  while (result.iterations < maxIterations) {
    if (roundingLevel(E)) return settleAtRounding(result);
    const auto began = std::chrono::steady_clock::now();
    X = system_.solve(t_, targets_);
    const double previous = E;
    E = local(X, nullptr, t_);  // the reference step reads no previous targets
    result.energies.push_back(E);
    ++result.iterations;
    result.criterion = std::abs(previous - E) / previous;
    report(result);
    if (std::abs(previous - E) <= tolerance * previous) {
      result.converged = true;
      return;
    }
    if (outOfTime(began)) return;
  }
}

void DeformationCore::descend(int maxIterations, double tolerance, Eigen::MatrixXd& X, double E,
                              DeformationResult& result) {
  AndersonMixer& mixer = anderson_;
  const bool accelerate = options_.acceleration == Acceleration::Anderson;
  Stacked& plainT = trialT_;
  Stacked mixedT;
  Eigen::MatrixXd mixed;
  while (result.iterations < maxIterations) {
    if (roundingLevel(E)) return settleAtRounding(result);
    const auto began = std::chrono::steady_clock::now();
    // The plain step: the global step for the current targets, then the local step. Both are
    // exact minimizers, so its energy is at most E; how much lower is the criterion.
    Eigen::MatrixXd plain;
    const double plainEnergy = plainStep(plain, plainT, E);
    result.criterion = E > 0.0 ? std::max(0.0, (E - plainEnergy) / E) : 0.0;
    // The Anderson step, taken only when it ends lower than E (the safeguard).
    bool takeMixed = false;
    double mixedEnergy = plainEnergy;
    if (accelerate && mixer.mix(X, plain, mixed)) {
      mixedEnergy = local(mixed, &t_, mixedT, E);
      takeMixed = mixedEnergy < E;
    }
    if (takeMixed) {
      advance(X, mixed, mixedT, mixedEnergy, E, result);
      ++result.accelerated;
    } else if (plainEnergy > E) {
      settleAtRounding(result);
      return;
    } else {
      advance(X, plain, plainT, plainEnergy, E, result);
    }
    report(result);
    if (result.criterion <= tolerance) {
      result.converged = true;
      return;
    }
    if (outOfTime(began)) return;
  }
}

void DeformationCore::advance(Eigen::MatrixXd& X, Eigen::MatrixXd& next, Stacked& nextT,
                              double energy, double& E, DeformationResult& result) {
  X.swap(next);
  t_.swap(nextT);
  E = energy;
  result.energies.push_back(E);
  ++result.iterations;
}

double DeformationCore::plainStep(Eigen::MatrixXd& X, Stacked& t, double E) {
  X = system_.solve(t_, targets_);
  return local(X, &t_, t, E);
}

Eigen::MatrixXd DeformationCore::gradient(const Eigen::MatrixXd& X, const Stacked& t,
                                          bool afterLocal) {
  // Right after the local step at X its F is at hand.
  if (!afterLocal) model_.gradients(X, scratch_.F);
  Eigen::MatrixXd g;
  system_.residualGradient(scratch_.F, t, g);
  return g;
}

void DeformationCore::descendLbfgs(int maxIterations, double tolerance, Eigen::MatrixXd& X,
                                   double E, DeformationResult& result) {
  constexpr double kArmijo = 1e-4;
  constexpr int kBacktracks = 6;
  if (result.iterations >= maxIterations) return;  // e.g. one iteration: the first global step
  LbfgsHistory& history = lbfgs_;
  const double scale = 2.0 * model_.energyScale();  // grad E = scale (A X - C t)
  const auto initial = [this](const Eigen::MatrixXd& q) { return system_.applyInverse(q); };
  Eigen::MatrixXd g = gradient(X, t_), trial;
  Stacked& trialT = trialT_;
  auto accept = [&](double energy) {
    const double decrease = E > 0.0 ? std::max(0.0, (E - energy) / E) : 0.0;
    Eigen::MatrixXd gNew = gradient(trial, trialT, true);  // accept() follows a local step
    // The pair takes the buffers of the point and the gradient it replaces: two n x d arrays
    // fewer at the million-vertex session's peak.
    X = trial - X;
    g = gNew - g;
    history.add(std::move(X), std::move(g));
    g.swap(gNew);
    advance(X, trial, trialT, energy, E, result);
    return decrease;
  };
  // Stationarity is decided by a plain step: what one more local/global iteration gains.
  // Returns whether it was taken (not when it rose: settleAtRounding).
  auto stationary = [&] {
    const double energy = plainStep(trial, trialT, E);
    if (energy > E) {
      settleAtRounding(result);
      return false;
    }
    result.criterion = accept(energy);
    if (result.criterion <= tolerance) result.converged = true;
    return true;
  };
  if (stationarityDue_) {  // resumed where the last run's cap came before that step
    stationarityDue_ = false;
    if (stationary()) report(result);
    if (result.converged) return;
  }
  while (result.iterations < maxIterations) {
    if (roundingLevel(E)) return settleAtRounding(result);
    const auto began = std::chrono::steady_clock::now();
    Eigen::MatrixXd d = history.direction(g, initial);
    double slope = scale * d.cwiseProduct(g).sum();
    if (!(slope < 0.0)) {  // not a descent direction: start the history again
      history.reset();
      d = -initial(g);
      slope = scale * d.cwiseProduct(g).sum();
    }
    // Backtracking line search on the energy after the local step (Armijo); without history
    // the full step is the plain global step.
    double alpha = 1.0, energy = E;
    bool found = false;
    for (int i = 0; i < kBacktracks && !found; ++i, alpha *= 0.5) {
      trial = X + alpha * d;
      energy = local(trial, &t_, trialT, E);
      found = energy <= E + kArmijo * alpha * slope;
    }
    if (found && history.size() > 0) ++result.accelerated;
    if (!found) {  // the plain step, a descent by construction
      history.reset();
      energy = plainStep(trial, trialT, E);
      if (energy > E) {
        settleAtRounding(result);
        return;
      }
    }
    result.criterion = accept(energy);
    report(result);
    if (result.criterion <= tolerance) {
      if (result.iterations >= maxIterations)
        stationarityDue_ = true;
      else if (stationary())
        report(result);
    }
    if (result.converged || outOfTime(began)) return;
  }
}

DeformationResult DeformationCore::resume(int maxIterations, double relTolerance) {
  return run(maxIterations, relTolerance, nullptr, true);
}

void DeformationCore::throwWithThinnest(const NonFiniteSolution& e) const {
  // A matrix of sliver elements (cotangents of 1e13) factors but does not solve: name the
  // thinnest element, in the caller's numbering.
  const Discretization::Thinnest thin = disc_.thinnestElement();
  const int element = elementOrder_.empty() ? thin.element : elementOrder_[thin.element];
  const bool tet = disc_.kind() == MeshKind::Tet;
  char ratio[32];
  std::snprintf(ratio, sizeof ratio, "%.2g", thin.ratio);
  throw NonFiniteSolution(std::string(e.what()) + "; the thinnest " + (tet ? "tet" : "triangle") +
                          " is " + std::to_string(element) + " (0-based; " +
                          (tet ? "volume / longest edge^3 " : "area / longest edge^2 ") + ratio +
                          ", where a regular one has " + (tet ? "0.118" : "0.433") + ")");
}

void DeformationCore::runSteps(int maxIterations, double relTolerance,
                               const Eigen::MatrixXd* initial, bool resume, Eigen::MatrixXd& X,
                               DeformationResult& result) {
  if (!model_.iterative()) {
    X = restSolve();
    result.energies.push_back(local(X, nullptr, t_));
    result.iterations = 1;
    report(result);
  } else {
    result.converged = false;
    double E = 0.0;
    const bool continuing = resume && resumable_;
    // t_ leaves lastX_ from here until the run ends: a run that throws (a non-finite energy, a
    // solver error, the progress callback) leaves nothing to continue and no last targets.
    resumable_ = false;
    if (continuing) {
      X = lastX_;
      E = lastE_;
      result.initialGuess = "continued";
      result.energies.push_back(E);
    } else {
      stationarityDue_ = false;
      lbfgs_ = LbfgsHistory(std::max(1, options_.history));
      anderson_ = AndersonMixer(std::max(1, options_.history));
      E = start(initial, X, result);
    }
    if (roundingLevel(E)) {  // e.g. every handle at rest: the first global step is exact
      system_.factorize();   // as for any run after new handles (Fig. 5's counts hold)
      stationarityDue_ = false;
      settleAtRounding(result);
    } else if (options_.localStep == LocalStep::Reference) {
      iterateReference(maxIterations, relTolerance, X, E, result);
    } else if (options_.acceleration == Acceleration::Lbfgs) {
      descendLbfgs(maxIterations, relTolerance, X, E, result);
    } else {
      descend(maxIterations, relTolerance, X, E, result);
    }
    // A run capped right after it reached rounding level is converged too.
    if (!result.converged && roundingLevel(result.energies.back())) {
      stationarityDue_ = false;
      settleAtRounding(result);
    }
    lastX_ = X;
    lastE_ = result.energies.back();
    resumable_ = true;
    // As localStep decides: the exact step sweeps coupled targets, every other fits each alone.
    ownFits_ = options_.localStep != LocalStep::Exact || !system_.regularizer().coupling();
  }
}

DeformationResult DeformationCore::run(int maxIterations, double relTolerance,
                                       const Eigen::MatrixXd* initial, bool resume) {
  if (handles_.empty()) throw InvalidParameter("deformation: no handles set");
  if (maxIterations < 1)
    throw InvalidParameter("deformation: iterations = " + std::to_string(maxIterations) +
                           " must be at least 1");
  if (!(relTolerance >= 0.0)) throw InvalidParameter("deformation: tolerance must be non-negative");
  const auto begin = std::chrono::steady_clock::now();
  deadline_ = begin + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                          std::chrono::duration<double>(std::min(budget_, 1e9)));
  DeformationResult result;
  Eigen::MatrixXd X;
  try {
    runSteps(maxIterations, relTolerance, initial, resume, X, result);
  } catch (const NonFiniteSolution& e) {
    throwWithThinnest(e);
  }
  result.positions = std::move(X);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
  return result;
}

DeformationResult deform(const Discretization& disc, const DeformationOptions& options,
                         const std::vector<int>& handles, const Eigen::MatrixXd& targets) {
  DeformationOptions once = options;
  // One solve: no later regularization to reserve the system's couplings for.
  once.reserveRegularization = options.regularization != Regularization::None;
  DeformationSession session(disc, once);
  session.setHandles(handles);
  session.setTargets(targets);
  return session.solve();
}

// DeformationSession: the public face of DeformationCore.
DeformationSession::DeformationSession(const Discretization& disc,
                                       const DeformationOptions& options)
    : core_(std::make_unique<DeformationCore>(disc, options)) {}
DeformationSession::~DeformationSession() = default;
DeformationSession::DeformationSession(DeformationSession&&) noexcept = default;
DeformationSession& DeformationSession::operator=(DeformationSession&&) noexcept = default;
void DeformationSession::setHandles(const std::vector<int>& vertices) {
  core_->setHandles(vertices);
}
void DeformationSession::setTargets(const Eigen::MatrixXd& targets) { core_->setTargets(targets); }
void DeformationSession::setRegularization(Regularization mode, double beta,
                                           const Eigen::VectorXd& weights) {
  core_->setRegularization(mode, beta, weights);
}
void DeformationSession::setBeta(double beta) { core_->setBeta(beta); }
void DeformationSession::setHandleBasis(bool on) { core_->setHandleBasis(on); }
void DeformationSession::setTimeBudget(double seconds) { core_->setTimeBudget(seconds); }
void DeformationSession::setProgress(std::function<void(int, double, double)> progress) {
  core_->setProgress(std::move(progress));
}
void DeformationSession::setWeights(const Eigen::VectorXd& weights) { core_->setWeights(weights); }
DeformationResult DeformationSession::solve(int maxIterations, double relTolerance) {
  return core_->solve(maxIterations, relTolerance);
}
DeformationResult DeformationSession::solveFrom(const Eigen::MatrixXd& initial, int maxIterations,
                                                double relTolerance) {
  return core_->solveFrom(initial, maxIterations, relTolerance);
}
DeformationResult DeformationSession::resume(int maxIterations, double relTolerance) {
  return core_->resume(maxIterations, relTolerance);
}
const DeformationOptions& DeformationSession::options() const { return core_->options(); }
const RegularizationWeights& DeformationSession::regularizationWeights() const {
  return core_->regularizationWeights();
}
ElementTargets DeformationSession::lastTargets() const { return core_->lastTargets(); }
ElementTargets DeformationSession::ownResiduals(const Eigen::MatrixXd& positions) const {
  return core_->ownResiduals(positions);
}
const SparseMatrix& DeformationSession::systemMatrix() const { return core_->systemMatrix(); }
SolverStats DeformationSession::stats() const { return core_->stats(); }

}  // namespace diffreg
