#include "solver/solver.h"

#include "core/error.h"
#include "core/timer.h"

#include <Eigen/SparseCholesky>
#ifdef DIFFREG_HAVE_CHOLMOD
#include <Eigen/CholmodSupport>
#endif
#include <string>

namespace diffreg {

SolverStats& SolverStats::operator+=(const SolverStats& o) {
  symbolic += o.symbolic;
  numeric += o.numeric;
  solves += o.solves;
  symbolicSeconds += o.symbolicSeconds;
  numericSeconds += o.numericSeconds;
  solveSeconds += o.solveSeconds;
  return *this;
}

SolverStats operator-(const SolverStats& a, const SolverStats& b) {
  SolverStats d;
  d.symbolic = a.symbolic - b.symbolic;
  d.numeric = a.numeric - b.numeric;
  d.solves = a.solves - b.solves;
  d.symbolicSeconds = a.symbolicSeconds - b.symbolicSeconds;
  d.numericSeconds = a.numericSeconds - b.numericSeconds;
  d.solveSeconds = a.solveSeconds - b.solveSeconds;
  return d;
}

SolverBackend defaultSolverBackend() {
#ifdef DIFFREG_HAVE_CHOLMOD
  return SolverBackend::Cholmod;
#else
  return SolverBackend::Eigen;
#endif
}

const char* toString(SolverBackend backend) {
  return backend == SolverBackend::Cholmod ? "cholmod" : "eigen";
}

// Both backends behind one small interface; CHOLMOD's supernodal LL^T when available.
struct SpdSolver::Impl {
  SolverBackend backend;
  Eigen::SimplicialLDLT<SparseMatrix> ldlt;
#ifdef DIFFREG_HAVE_CHOLMOD
  Eigen::CholmodSupernodalLLT<SparseMatrix> cholmod;
#endif
  explicit Impl(SolverBackend b) : backend(b) {
#ifdef DIFFREG_HAVE_CHOLMOD
    cholmod.cholmod().print = 0;  // failures are reported as SingularSystem, not on stderr
#else
    backend = SolverBackend::Eigen;
#endif
  }
  void analyze(const SparseMatrix& A) {
#ifdef DIFFREG_HAVE_CHOLMOD
    if (backend == SolverBackend::Cholmod) return cholmod.analyzePattern(A);
#endif
    ldlt.analyzePattern(A);
  }
  bool factorize(const SparseMatrix& A) {
#ifdef DIFFREG_HAVE_CHOLMOD
    if (backend == SolverBackend::Cholmod) {
      cholmod.factorize(A);
      return cholmod.info() == Eigen::Success;
    }
#endif
    ldlt.factorize(A);
    // LDL^T does not fail on indefinite matrices: positive definite means D > 0.
    return ldlt.info() == Eigen::Success && ldlt.vectorD().minCoeff() > 0.0;
  }
  Eigen::MatrixXd solve(const Eigen::MatrixXd& B) {
#ifdef DIFFREG_HAVE_CHOLMOD
    if (backend == SolverBackend::Cholmod) return cholmod.solve(B);
#endif
    return ldlt.solve(B);
  }
};

SpdSolver::SpdSolver(SolverBackend backend) : impl_(std::make_unique<Impl>(backend)) {}
SpdSolver::~SpdSolver() = default;
SpdSolver::SpdSolver(SpdSolver&&) noexcept = default;
SpdSolver& SpdSolver::operator=(SpdSolver&&) noexcept = default;

namespace {
std::vector<int> patternOf(const SparseMatrix& A) {
  std::vector<int> p(A.outerIndexPtr(), A.outerIndexPtr() + A.outerSize() + 1);
  p.insert(p.end(), A.innerIndexPtr(), A.innerIndexPtr() + A.nonZeros());
  return p;
}
}  // namespace

void SpdSolver::analyze(const SparseMatrix& A) {
  Timer timer;
  factorized_ = false;
  size_ = A.rows();
  analyzedEmpty_ = A.rows() == 0;
  if (!A.isCompressed()) {
    SparseMatrix C = A;
    C.makeCompressed();
    pattern_ = patternOf(C);
    if (!analyzedEmpty_) impl_->analyze(C);
  } else {
    pattern_ = patternOf(A);
    if (!analyzedEmpty_) impl_->analyze(A);
  }
  stats_.symbolic += 1;
  stats_.symbolicSeconds += timer.seconds();
}

void SpdSolver::factorize(const SparseMatrix& A) {
  if (!analyzed() || A.rows() != size_)
    throw SingularSystem("solver: factorize() needs analyze() of a matrix of the same size");
  Timer timer;
  factorized_ = false;
  if (A.rows() > 0 && !impl_->factorize(A))
    throw SingularSystem("solver: the system matrix (" + std::to_string(A.rows()) +
                         " unknowns) is not positive definite");
  factorized_ = true;
  stats_.numeric += 1;
  stats_.numericSeconds += timer.seconds();
}

void SpdSolver::compute(const SparseMatrix& A, bool analyzeAgain) {
  SparseMatrix C;
  const SparseMatrix* M = &A;
  if (!A.isCompressed()) {
    C = A;
    C.makeCompressed();
    M = &C;
  }
  if (analyzeAgain || !analyzed() || M->rows() != size_ || patternOf(*M) != pattern_) analyze(*M);
  factorize(*M);
}

Eigen::MatrixXd SpdSolver::solve(const Eigen::MatrixXd& B) {
  if (!factorized_) throw SingularSystem("solver: solve() before a successful factorization");
  Timer timer;
  Eigen::MatrixXd X = size_ == 0 ? Eigen::MatrixXd(0, B.cols()) : impl_->solve(B);
  stats_.solves += 1;
  stats_.solveSeconds += timer.seconds();
  if (!X.allFinite())
    throw SingularSystem("solver: the solution is not finite (the system is singular)");
  return X;
}

Partition::Partition(const std::vector<bool>& fixed) : local_(fixed.size()), isFixed_(fixed) {
  for (size_t i = 0; i < fixed.size(); ++i) {
    auto& list = fixed[i] ? fixed_ : free_;
    local_[i] = static_cast<int>(list.size());
    list.push_back(static_cast<int>(i));
  }
}

namespace {
// The block of A with rows in `rowsFixed` and columns in `colsFixed` (false = free).
SparseMatrix block(const Partition& p, const SparseMatrix& A, bool colsFixed) {
  const int cols = colsFixed ? p.numFixed() : p.numFree();
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(static_cast<size_t>(A.nonZeros()));
  for (int j = 0; j < A.outerSize(); ++j) {
    if (p.isFixed(j) != colsFixed) continue;
    for (SparseMatrix::InnerIterator it(A, j); it; ++it)
      if (!p.isFixed(static_cast<int>(it.row())))
        t.emplace_back(p.local(static_cast<int>(it.row())), p.local(j), it.value());
  }
  SparseMatrix B(p.numFree(), cols);
  B.setFromTriplets(t.begin(), t.end());
  B.makeCompressed();
  return B;
}

Eigen::MatrixXd rows(const Eigen::MatrixXd& X, const std::vector<int>& ids) {
  Eigen::MatrixXd R(ids.size(), X.cols());
  for (size_t i = 0; i < ids.size(); ++i) R.row(i) = X.row(ids[i]);
  return R;
}
}  // namespace

SparseMatrix Partition::freeFree(const SparseMatrix& A) const { return block(*this, A, false); }
SparseMatrix Partition::freeFixed(const SparseMatrix& A) const { return block(*this, A, true); }
Eigen::MatrixXd Partition::gatherFree(const Eigen::MatrixXd& X) const { return rows(X, free_); }
Eigen::MatrixXd Partition::gatherFixed(const Eigen::MatrixXd& X) const { return rows(X, fixed_); }

Eigen::MatrixXd Partition::scatter(const Eigen::MatrixXd& xFree,
                                   const Eigen::MatrixXd& xFixed) const {
  const Eigen::Index cols = xFree.rows() > 0 ? xFree.cols() : xFixed.cols();
  Eigen::MatrixXd X(size(), cols);
  for (size_t i = 0; i < free_.size(); ++i) X.row(free_[i]) = xFree.row(i);
  for (size_t i = 0; i < fixed_.size(); ++i) X.row(fixed_[i]) = xFixed.row(i);
  return X;
}

EliminatedSolver::EliminatedSolver(SolverBackend backend) : solver_(backend) {}

void EliminatedSolver::setPartition(Partition partition) {
  partition_ = std::move(partition);
  forceAnalyze_ = true;  // a new split is a new pattern (paper Fig. 5: handles added/removed)
}

void EliminatedSolver::setMatrix(const SparseMatrix& A) {
  if (A.rows() != partition_.size() || A.cols() != partition_.size())
    throw InvalidParameter("solver: matrix size " + std::to_string(A.rows()) +
                           " does not match the partition (" + std::to_string(partition_.size()) +
                           " unknowns)");
  const SparseMatrix AFF = partition_.freeFree(A);
  AFJ_ = partition_.freeFixed(A);
  solver_.compute(AFF, forceAnalyze_);
  forceAnalyze_ = false;
}

Eigen::MatrixXd EliminatedSolver::solve(const Eigen::MatrixXd& b, const Eigen::MatrixXd& xFixed) {
  if (b.rows() != partition_.size() || xFixed.rows() != partition_.numFixed())
    throw InvalidParameter("solver: right-hand side or fixed values of the wrong size");
  Eigen::MatrixXd rhs = partition_.gatherFree(b);
  if (partition_.numFixed() > 0) rhs -= AFJ_ * xFixed;
  return partition_.scatter(solver_.solve(rhs), xFixed);
}

}  // namespace diffreg
