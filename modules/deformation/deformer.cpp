#include "deformation/deformer.h"

#include "core/error.h"

#include <cmath>
#include <limits>
#include <string>

namespace diffreg {

DeformationSession::DeformationSession(const Discretization& disc,
                                       const DeformationOptions& options)
    : disc_(disc),
      options_(options),
      model_(disc, options.energy),
      system_(model_, options.backend, options.reserveRegularization) {
  if (options.energy == Energy::Arap && disc.kind() == MeshKind::Planar) {
    initModel_ = std::make_unique<ResidualModel>(disc, Energy::Asap);
    initSystem_ = std::make_unique<RegularizedSystem>(*initModel_, options.backend,
                                                      options.reserveRegularization);
  }
  setRegularization(options.regularization, options.beta, options.weights);
}

DeformationSession::~DeformationSession() = default;

void DeformationSession::setHandles(const std::vector<int>& vertices) {
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
  targets_.resize(static_cast<Eigen::Index>(vertices.size()), disc_.dim());
  for (size_t i = 0; i < vertices.size(); ++i)
    targets_.row(static_cast<Eigen::Index>(i)) = disc_.rest().row(vertices[i]);
  system_.setHandles(vertices);
  if (initSystem_) initSystem_->setHandles(vertices);
}

void DeformationSession::setTargets(const Eigen::MatrixXd& targets) {
  const int d = disc_.dim();
  if (targets.rows() != static_cast<Eigen::Index>(handles_.size()) || targets.cols() < d ||
      targets.cols() > 3)
    throw InvalidParameter("deformation: targets are " + std::to_string(targets.rows()) + " x " +
                           std::to_string(targets.cols()) + " for " +
                           std::to_string(handles_.size()) + " handle vertices in " +
                           std::to_string(d) + "D");
  if (!targets.allFinite()) throw InvalidParameter("deformation: a target is not finite");
  targets_ = targets.leftCols(d);
}

void DeformationSession::setRegularization(Regularization mode, double beta,
                                           const Eigen::VectorXd& weights) {
  const RegularizationWeights w = makeRegularizationWeights(disc_, mode, beta, weights);
  options_.regularization = mode;
  options_.beta = beta;
  options_.weights = weights;
  system_.setWeights(w);
  restRhs_.resize(0, 0);  // C depends on the weights
  initRhs_.resize(0, 0);
  if (initSystem_) initSystem_->setWeights(w);
}

void DeformationSession::setBeta(double beta) { setRegularization(Regularization::Uniform, beta); }

void DeformationSession::setWeights(const Eigen::VectorXd& weights) {
  setRegularization(Regularization::Nonuniform, 0.0, weights);
}

SolverStats DeformationSession::stats() const {
  SolverStats s = system_.stats();
  if (initSystem_) s += initSystem_->stats();
  return s;
}

DeformationResult DeformationSession::solve(int maxIterations, double relTolerance) {
  return run(maxIterations, relTolerance, nullptr);
}

DeformationResult DeformationSession::solveFrom(const Eigen::MatrixXd& initial, int maxIterations,
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

DeformationResult DeformationSession::run(int maxIterations, double relTolerance,
                                          const Eigen::MatrixXd* initial) {
  if (handles_.empty()) throw InvalidParameter("deformation: no handles set");
  if (maxIterations < 1)
    throw InvalidParameter("deformation: iterations = " + std::to_string(maxIterations) +
                           " must be at least 1");
  if (!(relTolerance >= 0.0)) throw InvalidParameter("deformation: tolerance must be non-negative");
  const RegularizationWeights& w = system_.weights();
  // The local step at X: t_ fitted to X, residuals e_ and the energy, in one pass.
  auto energyAt = [&](const Eigen::MatrixXd& X) {
    const double E = model_.fit(X, w, t_, e_);
    if (!std::isfinite(E))
      throw SingularSystem("deformation: the energy is not finite (degenerate solution)");
    return E;
  };
  auto report = [&](int iteration, double E) {
    if (options_.progress) options_.progress(iteration, E);
  };

  // The rest targets and their right-hand side change only with the weights: every handle move
  // starts from them (the first global step of the iterative energies, the only one of the
  // linear energies).
  auto restSolve = [&]() {
    if (restTargets_.size() == 0) model_.targets(disc_.rest(), restTargets_);
    if (restRhs_.size() == 0) system_.rightHandSide(restTargets_, restRhs_);
    return system_.solveRightHandSide(restRhs_, targets_);
  };

  DeformationResult result;
  if (!model_.iterative()) {
    result.positions = restSolve();
    result.energies.push_back(energyAt(result.positions));
    result.iterations = 1;
    report(1, result.energies.back());
    return result;
  }

  // Initial local step: the rotations of the rest shape (identities, fitted once per session),
  // or those of the regularized ASAP solution.
  Eigen::MatrixXd X;
  const Eigen::MatrixXd* t = &t_;
  double E = std::numeric_limits<double>::infinity();
  if (initial) {
    X = *initial;
    result.initialGuess = "given";
    E = energyAt(X);  // also fits t_ to X
    result.energies.push_back(E);
  } else if (initSystem_ && initSystem_->singularity().empty()) {
    if (initRhs_.size() == 0) {
      Eigen::MatrixXd t0;
      initModel_->targets(disc_.rest(), t0);  // constant: ASAP is linear in 2D
      initSystem_->rightHandSide(t0, initRhs_);
    }
    X = initSystem_->solveRightHandSide(initRhs_, targets_);
    result.initialGuess = "asap";
    E = energyAt(X);  // also fits t_ to X
    result.energies.push_back(E);
  } else {
    t = nullptr;  // the first global step is the rest solve
  }
  result.converged = false;
  for (int it = 0; it < maxIterations; ++it) {
    X = t ? system_.solve(*t, targets_) : restSolve();
    t = &t_;
    const double previous = E;
    E = energyAt(X);
    result.energies.push_back(E);
    ++result.iterations;
    report(result.iterations, E);
    if (std::isfinite(previous) && std::abs(previous - E) <= relTolerance * previous) {
      result.converged = true;
      break;
    }
  }
  result.positions = std::move(X);
  return result;
}

DeformationResult deform(const Discretization& disc, const DeformationOptions& options,
                         const std::vector<int>& handles, const Eigen::MatrixXd& targets) {
  DeformationSession session(disc, options);
  session.setHandles(handles);
  session.setTargets(targets);
  return session.solve();
}

}  // namespace diffreg
