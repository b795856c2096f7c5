#include <diffreg/weights/diffusion.h>
#include <diffreg/weights/diffusion_core.h>

#include <diffreg/core/error.h>
#include <diffreg/core/log.h>
#include <diffreg/core/text.h>
#include <diffreg/core/timer.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <sstream>

namespace diffreg {

DiffusionCore::DiffusionCore(const Discretization& disc, SolverBackend backend)
    : disc_(disc), solver_(backend) {}

void DiffusionCore::setHandles(const std::vector<std::vector<int>>& vertexSets,
                                  const std::vector<double>& ranges,
                                  const std::vector<double>& magnitudes) {
  const int n = disc_.numVertices();
  if (ranges.size() != vertexSets.size() || magnitudes.size() != vertexSets.size())
    throw InvalidParameter("weights: one range and one magnitude per handle are needed");
  std::vector<int> seen(n, -1);
  for (size_t j = 0; j < vertexSets.size(); ++j) {
    const std::string h = "weights: handle " + std::to_string(j);
    if (vertexSets[j].empty()) throw InvalidParameter(h + " selects no vertex");
    if (!(ranges[j] >= kMinHandleRange && ranges[j] <= kMaxHandleRange))
      throw InvalidParameter(h + ": range must be in [1e-6, 1e6] (got " + formatNumber(ranges[j]) +
                             ")");
    if (!(magnitudes[j] >= 0.0 && magnitudes[j] <= 1.0))
      throw InvalidParameter(h + ": magnitude must be in [0, 1] (got " +
                             formatNumber(magnitudes[j]) + ")");
    for (int v : vertexSets[j]) {
      if (v < 0 || v >= n)
        throw InvalidParameter(h + ": vertex " + std::to_string(v) + " out of range [0, " +
                               std::to_string(n) + ")");
      if (seen[v] == static_cast<int>(j))
        throw InvalidParameter(h + ": vertex " + std::to_string(v) + " is listed twice");
      if (seen[v] >= 0)
        throw InvalidParameter(h + ": vertex " + std::to_string(v) + " is also in handle " +
                               std::to_string(seen[v]));
      seen[v] = static_cast<int>(j);
    }
  }
  sets_ = vertexSets;
  ranges_ = ranges;
  magnitudes_ = magnitudes;
  owner_.reset();
  partitionDirty_ = matrixDirty_ = productDirty_ = true;
}

void DiffusionCore::setHandles(const HandleSet& handles) {
  std::vector<std::vector<int>> sets;
  std::vector<double> r, m;
  for (const Handle& h : handles.handles) {
    sets.push_back(h.vertices);
    r.push_back(h.range);
    m.push_back(h.magnitude);
  }
  setHandles(sets, r, m);
}

void DiffusionCore::setMagnitude(int handle, double m) {
  if (handle < 0 || handle >= static_cast<int>(sets_.size()))
    throw InvalidParameter("weights: no handle " + std::to_string(handle));
  if (!(m >= 0.0 && m <= 1.0))
    throw InvalidParameter("weights: handle " + std::to_string(handle) +
                           ": magnitude must be in [0, 1] (got " + formatNumber(m) + ")");
  magnitudes_[handle] = m;  // right-hand side only (pcg: superposition, see solve())
}

void DiffusionCore::setRange(int handle, double r) {
  if (handle < 0 || handle >= static_cast<int>(sets_.size()))
    throw InvalidParameter("weights: no handle " + std::to_string(handle));
  if (!(r >= kMinHandleRange && r <= kMaxHandleRange))
    throw InvalidParameter("weights: handle " + std::to_string(handle) +
                           ": range must be in [1e-6, 1e6] (got " + formatNumber(r) + ")");
  if (r == ranges_[handle]) return;
  ranges_[handle] = r;
  matrixDirty_ = productDirty_ = true;  // N changes: numeric refactorization only
}

void DiffusionCore::setParams(const DiffusionParams& params) {
  if (!(params.t > 0.0) || !std::isfinite(params.t))
    throw InvalidParameter("weights: t must be > 0 (got " + std::to_string(params.t) + ")");
  if (params.order == DiffusionOrder::ImplicitEuler && params.steps < 1)
    throw InvalidParameter("weights: steps must be >= 1 (got " + std::to_string(params.steps) +
                           ")");
  if (params.t != params_.t || params.unit != params_.unit || params.order != params_.order ||
      params.steps != params_.steps || params.solve != params_.solve)
    matrixDirty_ = true;
  params_ = params;
}

double DiffusionCore::absoluteTime() const {
  switch (params_.unit) {
    case TimeUnit::Absolute: return params_.t;
    case TimeUnit::Diagonal:
      return params_.t * disc_.boundingBoxDiagonal() * disc_.boundingBoxDiagonal();
    case TimeUnit::MeanEdge2: return params_.t * disc_.meanEdgeLength() * disc_.meanEdgeLength();
  }
  return params_.t;
}

namespace {

// The nearest handle of every vertex (-1 when none is reachable) by a multi-source Dijkstra
// along the edges of the pattern of K, edge lengths from the rest positions X. The vertices are
// settled in the order of (distance, index), and a vertex takes the handle of the first settled
// neighbour that gives it its distance. The queue holds each vertex at most once, at its current
// distance (a binary heap with positions, lowered in place), where a queue of (distance, vertex)
// pairs pushed on every improvement would hold stale entries: about half the heap operations on
// a mesh, and a heap operation's branches are what the search waits on.
std::vector<int> nearestHandles(const SparseMatrix& K, const Eigen::MatrixXd& X,
                                const std::vector<std::vector<int>>& sets) {
  const int n = static_cast<int>(K.cols());
  std::vector<int> owner(static_cast<size_t>(n), -1), heap, at(static_cast<size_t>(n), -1);
  std::vector<double> dist(static_cast<size_t>(n), INFINITY);
  std::vector<unsigned char> settled(static_cast<size_t>(n), 0);
  heap.reserve(static_cast<size_t>(n));
  const auto before = [&dist](int a, int b) {
    return dist[a] < dist[b] || (dist[a] == dist[b] && a < b);
  };
  const auto place = [&](int v, int i) {
    heap[static_cast<size_t>(i)] = v;
    at[static_cast<size_t>(v)] = i;
  };
  const auto up = [&](int i) {
    const int v = heap[static_cast<size_t>(i)];
    for (int parent; i > 0 && before(v, heap[static_cast<size_t>(parent = (i - 1) / 2)]);
         i = parent)
      place(heap[static_cast<size_t>(parent)], i);
    place(v, i);
  };
  const auto down = [&](int i) {
    const int v = heap[static_cast<size_t>(i)], size = static_cast<int>(heap.size());
    for (int child; (child = 2 * i + 1) < size; i = child) {
      if (child + 1 < size &&
          before(heap[static_cast<size_t>(child + 1)], heap[static_cast<size_t>(child)]))
        ++child;
      if (!before(heap[static_cast<size_t>(child)], v)) break;
      place(heap[static_cast<size_t>(child)], i);
    }
    place(v, i);
  };
  for (size_t j = 0; j < sets.size(); ++j)
    for (int v : sets[j]) {
      owner[static_cast<size_t>(v)] = static_cast<int>(j);
      dist[static_cast<size_t>(v)] = 0.0;
      heap.push_back(v);
      up(static_cast<int>(heap.size()) - 1);
    }
  const int* outer = K.outerIndexPtr();
  const int* inner = K.innerIndexPtr();
  while (!heap.empty()) {
    const int v = heap.front();
    settled[static_cast<size_t>(v)] = true;
    heap.front() = heap.back();
    heap.pop_back();
    if (!heap.empty()) down(0);
    const double d = dist[static_cast<size_t>(v)];
    for (int e = outer[v]; e < outer[v + 1]; ++e) {
      const int w = inner[e];
      if (settled[static_cast<size_t>(w)]) continue;
      const double dw = d + (X.row(v) - X.row(w)).norm();
      if (!(dw < dist[static_cast<size_t>(w)])) continue;
      dist[static_cast<size_t>(w)] = dw;
      owner[static_cast<size_t>(w)] = owner[static_cast<size_t>(v)];
      if (at[static_cast<size_t>(w)] < 0) heap.push_back(w);
      up(at[static_cast<size_t>(w)] < 0 ? static_cast<int>(heap.size()) - 1
                                        : at[static_cast<size_t>(w)]);
    }
  }
  return owner;
}

}  // namespace

// A vertex no handle reaches keeps r = 1, so where every r_j is 1 (the default) the field is 1
// everywhere and the nearest-handle search is not needed; it runs on the first other r_j.
Eigen::VectorXd DiffusionCore::rangeField() const {
  Eigen::VectorXd r = Eigen::VectorXd::Ones(disc_.numVertices());
  if (std::all_of(ranges_.begin(), ranges_.end(), [](double rj) { return rj == 1.0; })) return r;
  if (!owner_) owner_ = nearestHandles(disc_.stiffness(), disc_.rest(), sets_);
  for (size_t v = 0; v < owner_->size(); ++v)
    if ((*owner_)[v] >= 0) r(static_cast<Eigen::Index>(v)) = ranges_[(*owner_)[v]];
  return r;
}

// Fixed unknowns (handles, unreferenced vertices) and K's blocks.
void DiffusionCore::preparePartition() {
  const int n = disc_.numVertices();
  std::vector<bool> fixed(n, false);
  for (int v = 0; v < n; ++v) fixed[v] = !disc_.active()[v];
  for (const std::vector<int>& set : sets_)
    for (int v : set) fixed[v] = true;
  const SparseMatrix& K = disc_.stiffness();
  partition_ = Partition(fixed);
  partition_.freeFree(K).swap(KFF_);  // swapped in: assigning would copy
  partition_.freeFixed(K).swap(KFJ_);
  partitionDirty_ = false;
}

namespace {

// The lower triangle of diag(N) + c K (K symmetric, compressed, its rows sorted), which is all
// the solver reads of a symmetric matrix: the values of the full sum's lower triangle, bit for
// bit (an entry of K alone is 0 + c K_ij, as a sparse sum has it), at half the entries.
SparseMatrix lowerShifted(const Eigen::VectorXd& N, double c, const SparseMatrix& K) {
  const int n = static_cast<int>(K.cols());
  const int* outer = K.outerIndexPtr();
  const int* inner = K.innerIndexPtr();
  const double* values = K.valuePtr();
  SparseMatrix A(n, n);
  std::vector<int> first(static_cast<size_t>(n));  // each column's first entry on or below j
  Eigen::Index count = 0;
  for (int j = 0; j < n; ++j) {
    first[static_cast<size_t>(j)] =
        static_cast<int>(std::lower_bound(inner + outer[j], inner + outer[j + 1], j) - inner);
    const bool diagonal =
        first[static_cast<size_t>(j)] < outer[j + 1] && inner[first[static_cast<size_t>(j)]] == j;
    count += outer[j + 1] - first[static_cast<size_t>(j)] + (diagonal ? 0 : 1);
  }
  A.resizeNonZeros(count);
  int* Aouter = A.outerIndexPtr();
  int* Ainner = A.innerIndexPtr();
  double* Avalues = A.valuePtr();
  int at = 0;
  Aouter[0] = 0;
  for (int j = 0; j < n; ++j) {
    int e = first[static_cast<size_t>(j)];
    Ainner[at] = j;  // the diagonal: N_j + c K_jj, or N_j + 0 where K has none
    Avalues[at++] = e < outer[j + 1] && inner[e] == j ? N(j) + c * values[e++] : N(j) + 0.0;
    for (; e < outer[j + 1]; ++e) {
      Ainner[at] = inner[e];
      Avalues[at++] = 0.0 + c * values[e];
    }
    Aouter[j + 1] = at;
  }
  return A;
}

}  // namespace

// The matrix factored for the current order, t and r (docs/method.md, "Diffused weights"): the
// system itself, or for the second order by `pcg` its preconditioner's factor N + t/sqrt(2) K_FF;
// the lower triangle only, which is what the solver reads.
void DiffusionCore::prepareMatrix(bool analyzeAgain) {
  const Eigen::VectorXd& M = disc_.lumpedMass();
  const Eigen::VectorXd r = rangeField();
  const int nf = partition_.numFree();
  N_.resize(nf);
  for (int i = 0; i < nf; ++i) {
    const int v = partition_.freeIds()[i];
    N_(i) = M(v) / r(v);
  }
  const double t = absoluteTime();
  // Returned, not assigned: Eigen's SparseMatrix copies on assignment from a returned matrix.
  const SparseMatrix A = [&]() -> SparseMatrix {
    switch (params_.order) {
      case DiffusionOrder::First:
        return lowerShifted(N_, t, KFF_);
      case DiffusionOrder::ImplicitEuler:
        return lowerShifted(N_, t / params_.steps, KFF_);
      case DiffusionOrder::Second:
        break;
    }
    if (params_.solve == DiffusionSolve::Pcg) return lowerShifted(N_, t / std::sqrt(2.0), KFF_);
    if (productDirty_) {
      KNK_ = SparseMatrix(KFF_ * N_.cwiseInverse().asDiagonal()) * KFF_;
      productDirty_ = false;
    }
    SparseMatrix Nmat(nf, nf);
    Nmat.reserve(Eigen::VectorXi::Constant(nf, 1));
    for (int i = 0; i < nf; ++i) Nmat.insert(i, i) = N_(i);
    return SparseMatrix(
        SparseMatrix(Nmat + t * KFF_ + (0.5 * t * t) * KNK_).triangularView<Eigen::Lower>());
  }();
  solver_.compute(A, analyzeAgain);
  matrixDirty_ = false;
}

Eigen::VectorXd DiffusionCore::solve() {
  if (sets_.empty()) throw InvalidParameter("weights: no handles (the weights need at least one)");
  bool newPattern = false;
  if (partitionDirty_) {
    preparePartition();
    newPattern = true;
  }
  const bool newMatrix = matrixDirty_ || newPattern;
  if (newMatrix) {
    prepareMatrix(newPattern);
    basis_.assign(sets_.size(), HandleSolution());
    previous_.resize(0);
  }
  lastSolve_ = DiffusionSolveInfo();

  const Eigen::VectorXd g = dirichlet(magnitudes_);
  Eigen::VectorXd x;
  if (usesPcg() && previous_.size() > 0)
    x = superposed();
  else if (usesPcg() && handleBasis_)
    x = solveBasis();
  else
    x = solveFor(g);
  if (usesPcg()) {
    previous_ = x;
    previousMagnitudes_ = magnitudes_;
    previousInfo_ = lastSolve_;
  }
  if (params_.clip && x.size() > 0) {
    const double top = *std::max_element(magnitudes_.begin(), magnitudes_.end());
    x = x.cwiseMax(0.0).cwiseMin(top);
  }
  return partition_.scatter(x, g);
}

Eigen::VectorXd DiffusionCore::superposed() {
  Eigen::VectorXd x = previous_;
  // The CG runs of this call, and the accuracy of everything combined.
  DiffusionSolveInfo total;
  total.cgResidual = previousInfo_.cgResidual;
  total.converged = previousInfo_.converged;
  for (size_t j = 0; j < sets_.size(); ++j) {
    const double change = magnitudes_[j] - previousMagnitudes_[j];
    if (change == 0.0) continue;
    HandleSolution& own = basis_[j];
    if (own.x.size() == 0) {  // handle j's own weights (m_j = 1, the others 0), once
      std::vector<double> unit(sets_.size(), 0.0);
      unit[j] = 1.0;
      lastSolve_ = DiffusionSolveInfo();
      own.x = solveFor(dirichlet(unit));
      own.info = lastSolve_;
      total.cgIterations += own.info.cgIterations;
      total.cgSeconds += own.info.cgSeconds;
    }
    total.cgResidual = std::max(total.cgResidual, own.info.cgResidual);
    total.converged = total.converged && own.info.converged;
    x += change * own.x;
  }
  lastSolve_ = total;
  return x;
}

Eigen::VectorXd DiffusionCore::solveBasis() {
  const size_t handles = sets_.size();
  Eigen::MatrixXd G(partition_.numFixed(), static_cast<Eigen::Index>(handles));
  for (size_t j = 0; j < handles; ++j) {
    std::vector<double> unit(handles, 0.0);
    unit[j] = 1.0;
    G.col(static_cast<Eigen::Index>(j)) = dirichlet(unit);
  }
  const Eigen::MatrixXd X = solveForColumns(G);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(X.rows());
  for (size_t j = 0; j < handles; ++j) {
    basis_[j].x = X.col(static_cast<Eigen::Index>(j));
    basis_[j].info = lastSolve_;
    x += magnitudes_[j] * basis_[j].x;
  }
  return x;
}

void DiffusionCore::setHandleBasis(bool on) { handleBasis_ = on; }

Eigen::VectorXd DiffusionCore::dirichlet(const std::vector<double>& values) const {
  Eigen::VectorXd g = Eigen::VectorXd::Zero(partition_.numFixed());
  for (size_t j = 0; j < sets_.size(); ++j)
    for (int v : sets_[j]) g(partition_.local(v)) = values[j];
  return g;
}

Eigen::VectorXd DiffusionCore::solveFor(const Eigen::VectorXd& g) {
  return solveForColumns(g).col(0);
}

Eigen::MatrixXd DiffusionCore::solveForColumns(const Eigen::MatrixXd& G) {
  const Eigen::MatrixXd b = -(KFJ_ * G);
  const double t = absoluteTime();
  Eigen::MatrixXd x;
  switch (params_.order) {
    case DiffusionOrder::First: x = solver_.solve(t * b); break;
    case DiffusionOrder::Second: {
      const Eigen::MatrixXd Nb = N_.asDiagonal().inverse() * b;
      const Eigen::MatrixXd rhs = t * b + (0.5 * t * t) * (KFF_ * Nb);
      x = usesPcg() ? solvePcg(rhs, t) : solver_.solve(rhs);
      break;
    }
    case DiffusionOrder::ImplicitEuler: {
      const double h = t / params_.steps;
      x = Eigen::MatrixXd::Zero(partition_.numFree(), G.cols());
      for (int s = 0; s < params_.steps; ++s) x = solver_.solve(N_.asDiagonal() * x + h * b);
      break;
    }
  }
  return x;
}

// B x = rhs, B = N + t K + t^2/2 K N^-1 K, by conjugate gradients preconditioned with
// P = S N^-1 S, S = N + g K, g = t / sqrt(2) (docs/method.md, "Diffused weights"). P^-1 y =
// S^-1 (N (S^-1 y)) costs two back-substitutions against the factor of S. Per mode of N^-1 K
// with s = t lambda, P^-1 B has the eigenvalue (1 + s + s^2/2) / (1 + sqrt(2) s + s^2/2) in
// [(2 + sqrt 2) / 4, 1]. B is never formed, and an iteration multiplies by K once: P = N +
// 2 g K + g^2 K N^-1 K = B + (2 g - t) K, and P p follows the search directions (P p_0 = r_0,
// P p_(k+1) = r_(k+1) + beta P p_k), so B p = P p - (2 g - t) K p. That recurrence holds only
// as far as the back-substitutions apply P^-1 exactly, so the true residual rhs - B x decides
// when the recursive one has converged; a column it finds short goes on from there.
Eigen::MatrixXd DiffusionCore::solvePcg(const Eigen::MatrixXd& rhs, double t) {
  Timer timer;
  const double g = t / std::sqrt(2.0);  // the factored S = N + g K (prepareMatrix)
  const double d = 2.0 * g - t;
  const double half = 0.5 * t * t;
  const auto Ninv = N_.asDiagonal().inverse();
  auto applyB = [&](const Eigen::MatrixXd& v) -> Eigen::MatrixXd {
    const Eigen::MatrixXd Kv = KFF_ * v;
    return N_.asDiagonal() * v + t * Kv + half * (KFF_ * (Ninv * Kv));
  };
  auto applyPinv = [&](const Eigen::MatrixXd& v) -> Eigen::MatrixXd {
    const Eigen::MatrixXd y = solver_.solve(v);
    return solver_.solve(N_.asDiagonal() * y);
  };
  // One CG per column; the columns share the preconditioner's back-substitutions (one block
  // solve each), and a column stops changing once it has converged.
  const Eigen::Index cols = rhs.cols();
  Eigen::MatrixXd x = Eigen::MatrixXd::Zero(rhs.rows(), cols);
  const Eigen::VectorXd rhsNorm = rhs.colwise().norm().transpose();
  std::vector<bool> active(static_cast<size_t>(cols));
  Eigen::VectorXd relative = Eigen::VectorXd::Zero(cols);
  for (Eigen::Index c = 0; c < cols; ++c) {
    active[static_cast<size_t>(c)] = rhsNorm(c) > 0.0;  // 0: all magnitudes 0, or no free vertex
    if (active[static_cast<size_t>(c)]) relative(c) = 1.0;
  }
  const auto anyActive = [&] { return std::find(active.begin(), active.end(), true) != active.end(); };
  DiffusionSolveInfo& info = lastSolve_;
  int k = 0;
  Eigen::MatrixXd r = rhs;  // rhs - B x, exact at each round's start
  for (int round = 0; round < kDiffusionCgRounds && anyActive() && k < kDiffusionCgMaxIterations;
       ++round) {
    Eigen::MatrixXd z = applyPinv(r);
    Eigen::MatrixXd p = z, Pp = r;
    Eigen::VectorXd rz = r.cwiseProduct(z).colwise().sum().transpose();
    while (k < kDiffusionCgMaxIterations) {
      const Eigen::MatrixXd q = Pp - d * (KFF_ * p);
      ++k;
      for (Eigen::Index c = 0; c < cols; ++c) {
        if (!active[static_cast<size_t>(c)]) continue;
        const double alpha = rz(c) / p.col(c).dot(q.col(c));
        x.col(c) += alpha * p.col(c);
        r.col(c) -= alpha * q.col(c);
        relative(c) = r.col(c).norm() / rhsNorm(c);
        if (relative(c) <= kDiffusionCgTolerance) active[static_cast<size_t>(c)] = false;
      }
      if (!anyActive()) break;
      z = applyPinv(r);
      for (Eigen::Index c = 0; c < cols; ++c) {
        if (!active[static_cast<size_t>(c)]) continue;
        const double rzNext = r.col(c).dot(z.col(c)), beta = rzNext / rz(c);
        p.col(c) = z.col(c) + beta * p.col(c);
        Pp.col(c) = r.col(c) + beta * Pp.col(c);
        rz(c) = rzNext;
      }
    }
    r = rhs - applyB(x);
    for (Eigen::Index c = 0; c < cols; ++c) {
      if (!(rhsNorm(c) > 0.0)) continue;
      relative(c) = r.col(c).norm() / rhsNorm(c);
      active[static_cast<size_t>(c)] = relative(c) > kDiffusionCgTolerance;
    }
  }
  info.cgIterations = k;
  info.cgResidual = relative.size() > 0 ? relative.maxCoeff() : 0.0;
  info.converged = info.cgResidual <= kDiffusionCgTolerance;
  info.cgSeconds = timer.seconds();
  if (!info.converged) {
    std::ostringstream message;
    message << "weights: conjugate gradients stopped after " << k
            << " iterations at relative residual " << info.cgResidual << " (wanted "
            << kDiffusionCgTolerance << ")";
    warn(message.str());
  }
  return x;
}

Eigen::VectorXd diffuseWeights(const Discretization& disc, const HandleSet& handles,
                               const DiffusionParams& params) {
  DiffusionWeights session(disc);
  session.setHandles(handles);
  session.setParams(params);
  return session.solve();
}

// DiffusionWeights: the public face of DiffusionCore.
DiffusionWeights::DiffusionWeights(const Discretization& disc, SolverBackend backend)
    : core_(std::make_unique<DiffusionCore>(disc, backend)) {}
DiffusionWeights::~DiffusionWeights() = default;
DiffusionWeights::DiffusionWeights(DiffusionWeights&&) noexcept = default;
DiffusionWeights& DiffusionWeights::operator=(DiffusionWeights&&) noexcept = default;
void DiffusionWeights::setHandles(const std::vector<std::vector<int>>& vertexSets,
                                  const std::vector<double>& ranges,
                                  const std::vector<double>& magnitudes) {
  core_->setHandles(vertexSets, ranges, magnitudes);
}
void DiffusionWeights::setHandles(const HandleSet& handles) { core_->setHandles(handles); }
void DiffusionWeights::setMagnitude(int handle, double m) { core_->setMagnitude(handle, m); }
void DiffusionWeights::setRange(int handle, double r) { core_->setRange(handle, r); }
void DiffusionWeights::setParams(const DiffusionParams& params) { core_->setParams(params); }
const DiffusionParams& DiffusionWeights::params() const { return core_->params(); }
double DiffusionWeights::absoluteTime() const { return core_->absoluteTime(); }
Eigen::VectorXd DiffusionWeights::solve() { return core_->solve(); }
void DiffusionWeights::setHandleBasis(bool on) { core_->setHandleBasis(on); }
const SolverStats& DiffusionWeights::stats() const { return core_->stats(); }
const DiffusionSolveInfo& DiffusionWeights::lastSolve() const { return core_->lastSolve(); }
Eigen::VectorXd DiffusionWeights::rangeField() const { return core_->rangeField(); }

}  // namespace diffreg
