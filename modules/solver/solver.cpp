#include <diffreg/solver/solver.h>

#include <diffreg/solver/blas_threads.h>

#include <diffreg/core/error.h>
#include <diffreg/core/timer.h>

#include <Eigen/SparseCholesky>
#ifdef DIFFREG_HAVE_CHOLMOD
#include <cholmod.h>
#endif
#include <algorithm>
#include <cmath>
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

// Both backends behind one small interface. CHOLMOD through its C API: the symbolic analysis
// chooses the fill-reducing ordering (AMD, and METIS as well when AMD's fill is poor or its
// factor large, see kNestedDissectionFactor) and between a simplicial and a supernodal
// factorization by the work per nonzero of L: small and very sparse factors (flops / nnz(L)
// below kSupernodalSwitch) go up-looking and simplicial, which avoids the per-supernode BLAS and
// OpenMP overhead that dominates them; larger ones supernodal on BLAS. The supernodal factor is
// LL^T; the simplicial one LDL^T, whose back-substitutions divide by no pivot on their
// dependency chain (measured, the two factors alternating in one process: one right-hand side
// 3-14% faster from 21K down to 1K unknowns, three about the same), with every pivot of D
// checked to be positive: a matrix that is not positive definite is always reported.
namespace {
#ifdef DIFFREG_HAVE_CHOLMOD
// Measured on this project's systems (surface and tet deformation systems, eq. 7 / eq. 8
// weights, 1K to 100K unknowns): simplicial is faster below about 150-250 flops per nonzero of L
// (CHOLMOD's default switch, 40, is tuned for machines where BLAS calls are cheap).
constexpr double kSupernodalSwitch = 200.0;
// Above this many nonzeros of AMD's factor, METIS nested dissection is analyzed as well and
// kept when its factor is at least 10% smaller: on 100K-vertex surface systems it cuts nnz(L)
// by about a third (so every solve and factorization), which repays its longer analysis; below,
// the analysis would cost more than the solves it saves.
constexpr double kNestedDissectionFactor = 2e6;

const char* orderingName(int ordering) {
  switch (ordering) {
    case CHOLMOD_NATURAL: return "natural";
    case CHOLMOD_GIVEN: return "given";
    case CHOLMOD_AMD: return "AMD";
    case CHOLMOD_METIS: return "METIS";
    case CHOLMOD_NESDIS: return "NESDIS";
    case CHOLMOD_COLAMD: return "COLAMD";
    case CHOLMOD_POSTORDERED: return "natural, postordered";
  }
  return "?";
}

// A CHOLMOD view (no copy) of the lower triangle of a compressed symmetric matrix.
cholmod_sparse viewOf(const SparseMatrix& A) {
  cholmod_sparse s{};
  s.nrow = static_cast<size_t>(A.rows());
  s.ncol = static_cast<size_t>(A.cols());
  s.nzmax = static_cast<size_t>(A.nonZeros());
  s.p = const_cast<int*>(A.outerIndexPtr());
  s.i = const_cast<int*>(A.innerIndexPtr());
  s.x = const_cast<double*>(A.valuePtr());
  s.stype = -1;
  s.itype = CHOLMOD_INT;
  s.xtype = CHOLMOD_REAL;
  s.dtype = CHOLMOD_DOUBLE;
  s.sorted = 1;
  s.packed = 1;
  return s;
}

// The pivots of a simplicial LDL^T factor, as LL^T's test has them: kNotFinite when one is NaN
// (a matrix of sliver elements, cotangents of 1e13, whose LL^T factor did not solve either),
// else kNotPositive when one is not positive, else kPositive. D(j) is the first entry of column
// j. CHOLMOD reports only zero pivots of LDL^T, so an indefinite matrix would otherwise pass.
enum class Pivots { kPositive, kNotPositive, kNotFinite };
Pivots pivotsOf(const cholmod_factor& L) {
  const int* p = static_cast<const int*>(L.p);
  const double* x = static_cast<const double*>(L.x);
  Pivots result = Pivots::kPositive;
  for (size_t j = 0; j < L.n; ++j) {
    if (std::isnan(x[p[j]])) return Pivots::kNotFinite;
    if (!(x[p[j]] > 0.0)) result = Pivots::kNotPositive;
  }
  return result;
}
#endif
}  // namespace

struct SpdSolver::Impl {
  SolverBackend backend;
  Eigen::SimplicialLDLT<SparseMatrix> ldlt;
  SolverInfo info;
#ifdef DIFFREG_HAVE_CHOLMOD
  cholmod_common common{};
  cholmod_factor* factor = nullptr;
  // Solve workspace, reused while the number of right-hand sides is unchanged.
  cholmod_dense *x = nullptr, *y = nullptr, *e = nullptr;
#endif
  explicit Impl(SolverBackend b) : backend(b) {
#ifdef DIFFREG_HAVE_CHOLMOD
    cholmod_start(&common);
    common.print = 0;             // failures are reported as SingularSystem, not on stderr
    common.error_handler = nullptr;
    common.supernodal = CHOLMOD_AUTO;
    common.supernodal_switch = kSupernodalSwitch;
    common.final_ll = 0;  // simplicial LDL^T (pivots checked in factorize())
    common.quick_return_if_not_posdef = 1;
#else
    backend = SolverBackend::Eigen;
#endif
  }
  ~Impl() {
#ifdef DIFFREG_HAVE_CHOLMOD
    freeFactor();
    cholmod_finish(&common);
#endif
  }
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;

#ifdef DIFFREG_HAVE_CHOLMOD
  void freeFactor() {
    if (factor) cholmod_free_factor(&factor, &common);
    if (x) cholmod_free_dense(&x, &common);
    if (y) cholmod_free_dense(&y, &common);
    if (e) cholmod_free_dense(&e, &common);
  }
#endif

  void analyze(const SparseMatrix& A) {
#ifdef DIFFREG_HAVE_CHOLMOD
    if (backend == SolverBackend::Cholmod) {
      freeFactor();
      cholmod_sparse a = viewOf(A);
      factor = cholmod_analyze(&a, &common);
      if (!factor || common.status < CHOLMOD_OK)
        throw SingularSystem("solver: CHOLMOD's symbolic analysis failed (status " +
                             std::to_string(common.status) + ", " + std::to_string(A.rows()) +
                             " unknowns)");
      double lnz = common.lnz, fl = common.fl;
      if (factor->ordering == CHOLMOD_AMD && lnz > kNestedDissectionFactor) {
        const int nmethods = common.nmethods, ordering = common.method[0].ordering;
        common.nmethods = 1;
        common.method[0].ordering = CHOLMOD_METIS;
        cholmod_factor* nd = cholmod_analyze(&a, &common);
        common.nmethods = nmethods;
        common.method[0].ordering = ordering;
        if (nd && common.status == CHOLMOD_OK && common.lnz < 0.9 * lnz) {
          cholmod_free_factor(&factor, &common);
          factor = nd;
          lnz = common.lnz;
          fl = common.fl;
        } else if (nd) {
          cholmod_free_factor(&nd, &common);
        }
        common.status = CHOLMOD_OK;  // METIS failing leaves AMD's analysis in place
      }
      info.method = factor->is_super ? "CHOLMOD supernodal LL^T" : "CHOLMOD simplicial LDL^T";
      info.ordering = orderingName(factor->ordering);
      info.factorNonZeros = lnz;
      info.flops = fl;
      return;
    }
#endif
    ldlt.analyzePattern(A);
    info.method = "Eigen simplicial LDL^T";
    info.ordering = "AMD";
    info.factorNonZeros = info.flops = 0.0;
  }
  // Whether A is positive definite; throws NonFiniteSolution when its factor is not finite.
  bool factorize(const SparseMatrix& A) {
#ifdef DIFFREG_HAVE_CHOLMOD
    if (backend == SolverBackend::Cholmod) {
      cholmod_sparse a = viewOf(A);
      // Supernodal factors are the only work here that threaded BLAS speeds up.
      const BlasThreadScope threads(factor->is_super);
      const int ok = cholmod_factorize(&a, factor, &common);
      if (!ok || common.status != CHOLMOD_OK || factor->minor != factor->n) return false;
      if (factor->is_ll) return true;
      const Pivots pivots = pivotsOf(*factor);
      if (pivots == Pivots::kNotFinite)
        throw NonFiniteSolution("solver: the factorization of the system matrix (" +
                                std::to_string(A.rows()) + " unknowns) is not finite");
      return pivots == Pivots::kPositive;
    }
#endif
    ldlt.factorize(A);
    // LDL^T does not fail on indefinite matrices: positive definite means D > 0.
    return ldlt.info() == Eigen::Success && ldlt.vectorD().minCoeff() > 0.0;
  }
  Eigen::MatrixXd solve(const Eigen::MatrixXd& B) {
#ifdef DIFFREG_HAVE_CHOLMOD
    if (backend == SolverBackend::Cholmod) {
      cholmod_dense b{};
      b.nrow = static_cast<size_t>(B.rows());
      b.ncol = static_cast<size_t>(B.cols());
      b.nzmax = b.nrow * b.ncol;
      b.d = b.nrow;
      b.x = const_cast<double*>(B.data());
      b.xtype = CHOLMOD_REAL;
      b.dtype = CHOLMOD_DOUBLE;
      const BlasThreadScope threads(factor->is_super);
      if (!cholmod_solve2(CHOLMOD_A, factor, &b, nullptr, &x, nullptr, &y, &e, &common))
        throw SingularSystem("solver: CHOLMOD's solve failed (status " +
                             std::to_string(common.status) + ")");
      return Eigen::Map<const Eigen::MatrixXd>(static_cast<const double*>(x->x), B.rows(),
                                               B.cols());
    }
#endif
    return ldlt.solve(B);
  }
};

SpdSolver::SpdSolver(SolverBackend backend) : impl_(std::make_unique<Impl>(backend)) {}
SpdSolver::~SpdSolver() = default;
SpdSolver::SpdSolver(SpdSolver&&) noexcept = default;
SpdSolver& SpdSolver::operator=(SpdSolver&&) noexcept = default;

SolverInfo SpdSolver::info() const { return impl_->info; }

void SpdSolver::keepPattern(bool keep) {
  keepPattern_ = keep;
  if (!keep) std::vector<int>().swap(pattern_);
}

namespace {
std::vector<int> patternOf(const SparseMatrix& A) {
  std::vector<int> p(A.outerIndexPtr(), A.outerIndexPtr() + A.outerSize() + 1);
  p.insert(p.end(), A.innerIndexPtr(), A.innerIndexPtr() + A.nonZeros());
  return p;
}

// Whether compressed A has exactly this pattern (outer then inner indices).
bool samePattern(const SparseMatrix& A, const std::vector<int>& pattern) {
  const size_t outer = static_cast<size_t>(A.outerSize()) + 1;
  if (pattern.size() != outer + static_cast<size_t>(A.nonZeros())) return false;
  return std::equal(A.outerIndexPtr(), A.outerIndexPtr() + outer, pattern.begin()) &&
         std::equal(A.innerIndexPtr(), A.innerIndexPtr() + A.nonZeros(), pattern.begin() + outer);
}
}  // namespace

void SpdSolver::analyze(const SparseMatrix& A) {
  Timer timer;
  factorized_ = false;
  size_ = A.rows();
  analyzedEmpty_ = A.rows() == 0;
  analyzed_ = false;
  if (!A.isCompressed()) {
    SparseMatrix C = A;
    C.makeCompressed();
    if (keepPattern_) pattern_ = patternOf(C);
    if (!analyzedEmpty_) impl_->analyze(C);
  } else {
    if (keepPattern_) pattern_ = patternOf(A);
    if (!analyzedEmpty_) impl_->analyze(A);
  }
  analyzed_ = true;
  stats_.symbolic += 1;
  stats_.symbolicSeconds += timer.seconds();
}

void SpdSolver::factorize(const SparseMatrix& A) {
  if (!analyzed() || A.rows() != size_)
    throw SingularSystem("solver: factorize() needs analyze() of a matrix of the same size");
  Timer timer;
  factorized_ = false;
  bool ok = true;
  if (A.rows() > 0) {
    if (A.isCompressed()) {
      ok = impl_->factorize(A);
    } else {
      SparseMatrix C = A;
      C.makeCompressed();
      ok = impl_->factorize(C);
    }
  }
  if (!ok)
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
  if (analyzeAgain || !keepPattern_ || !analyzed() || M->rows() != size_ ||
      !samePattern(*M, pattern_))
    analyze(*M);
  factorize(*M);
}

Eigen::MatrixXd SpdSolver::solve(const Eigen::MatrixXd& B) {
  if (!factorized_) throw SingularSystem("solver: solve() before a successful factorization");
  if (B.rows() != size_)
    throw InvalidParameter("solver: right-hand side with " + std::to_string(B.rows()) +
                           " rows for " + std::to_string(size_) + " unknowns");
  Timer timer;
  Eigen::MatrixXd X = size_ == 0 ? Eigen::MatrixXd(0, B.cols()) : impl_->solve(B);
  stats_.solves += 1;
  stats_.solveSeconds += timer.seconds();
  // A finite sum has no NaN or infinite term; only a sum that is not finite (which an overflow
  // of finite terms can also make) needs the check of every entry.
  if (!std::isfinite(X.sum()) && !X.allFinite())
    throw NonFiniteSolution("solver: the solution is not finite (the system is singular)");
  return X;
}

Partition::Partition(const std::vector<bool>& fixed)
    : local_(fixed.size()), isFixed_(fixed.begin(), fixed.end()) {
  for (size_t i = 0; i < fixed.size(); ++i) {
    auto& list = fixed[i] ? fixed_ : free_;
    local_[i] = static_cast<int>(list.size());
    list.push_back(static_cast<int>(i));
  }
}

namespace {
// The block of A with the free rows and the free (colsFixed = false) or fixed columns, built
// column by column: local() is increasing within each class, so rows stay sorted.
SparseMatrix block(const Partition& p, const SparseMatrix& A, bool colsFixed) {
  const int cols = colsFixed ? p.numFixed() : p.numFree();
  const std::vector<int>& ids = colsFixed ? p.fixedIds() : p.freeIds();
  SparseMatrix B(p.numFree(), cols);
  Eigen::Index count = 0;
  for (int j : ids)
    for (SparseMatrix::InnerIterator it(A, j); it; ++it)
      if (!p.isFixed(static_cast<int>(it.row()))) ++count;
  B.resizeNonZeros(count);
  int* outer = B.outerIndexPtr();
  int* inner = B.innerIndexPtr();
  double* values = B.valuePtr();
  Eigen::Index at = 0;
  outer[0] = 0;
  for (int c = 0; c < cols; ++c) {
    for (SparseMatrix::InnerIterator it(A, ids[c]); it; ++it) {
      const int row = static_cast<int>(it.row());
      if (p.isFixed(row)) continue;
      inner[at] = p.local(row);
      values[at] = it.value();
      ++at;
    }
    outer[c + 1] = static_cast<int>(at);
  }
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

void EliminatedSolver::trustPatterns() {
  trusted_ = true;
  solver_.keepPattern(false);
}

void EliminatedSolver::setMatrix(const SparseMatrix& A, bool samePattern) {
  if (A.rows() != partition_.size() || A.cols() != partition_.size())
    throw InvalidParameter("solver: matrix size " + std::to_string(A.rows()) +
                           " does not match the partition (" + std::to_string(partition_.size()) +
                           " unknowns)");
  partition_.freeFixed(A).swap(AFJ_);  // swapped in: assigning a returned matrix would copy
  {
    // The solver reads the lower triangle only: keeping just that halves the copy that lives
    // through the factorization (and the pattern kept for comparison).
    const SparseMatrix AFF = SparseMatrix(partition_.freeFree(A).triangularView<Eigen::Lower>());
    if (trusted_ && samePattern && !forceAnalyze_ && solver_.analyzed())
      solver_.factorize(AFF);
    else
      solver_.compute(AFF, forceAnalyze_);
  }
  forceAnalyze_ = false;
}

Eigen::MatrixXd EliminatedSolver::solve(const Eigen::MatrixXd& b, const Eigen::MatrixXd& xFixed) {
  if (b.rows() != partition_.size() || xFixed.rows() != partition_.numFixed())
    throw InvalidParameter("solver: right-hand side or fixed values of the wrong size");
  return solveFree(partition_.gatherFree(b), xFixed);
}

Eigen::MatrixXd EliminatedSolver::solveFixedResponse(const Eigen::MatrixXd& xFixed) {
  if (xFixed.rows() != partition_.numFixed())
    throw InvalidParameter("solver: fixed values of the wrong size");
  return solveFree(Eigen::MatrixXd::Zero(partition_.numFree(), xFixed.cols()), xFixed);
}

Eigen::MatrixXd EliminatedSolver::solveFree(Eigen::MatrixXd rhs, const Eigen::MatrixXd& xFixed) {
  if (partition_.numFixed() > 0) rhs.noalias() -= AFJ_ * xFixed;
  return partition_.scatter(solver_.solve(rhs), xFixed);
}

}  // namespace diffreg
