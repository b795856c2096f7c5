// The BLAS's threads: single-threaded and without spinning workers once reserved for
// factorizations, the started count inside a BlasThreadScope, and a supernodal
// factorization under the reservation as accurate as any.
//
// One test case, in order: the reservation is process-wide and cannot be taken back.
#include <diffreg/solver/blas_threads.h>
#include <diffreg/solver/solver.h>

#include <catch2/catch.hpp>

#include <chrono>
#include <ctime>
#include <thread>

using namespace diffreg;

namespace {

// 7-point Laplacian of a k x k x k grid plus a small multiple of the identity (SPD): its factor
// has dense separator blocks, so CHOLMOD factors it supernodally on BLAS.
SparseMatrix cubeMatrix(int k) {
  std::vector<Eigen::Triplet<double>> t;
  auto id = [k](int i, int j, int l) { return (i * k + j) * k + l; };
  for (int i = 0; i < k; ++i)
    for (int j = 0; j < k; ++j)
      for (int l = 0; l < k; ++l) {
        const int a = id(i, j, l);
        t.emplace_back(a, a, 1e-3);
        const int next[3] = {i + 1 < k ? id(i + 1, j, l) : -1, j + 1 < k ? id(i, j + 1, l) : -1,
                             l + 1 < k ? id(i, j, l + 1) : -1};
        for (int b : next) {
          if (b < 0) continue;
          t.emplace_back(a, a, 1.0);
          t.emplace_back(b, b, 1.0);
          t.emplace_back(a, b, -1.0);
          t.emplace_back(b, a, -1.0);
        }
      }
  SparseMatrix A(k * k * k, k * k * k);
  A.setFromTriplets(t.begin(), t.end());
  return A;
}

double processCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// CPU time the whole process uses while this thread sleeps for `seconds`: what idle BLAS
// workers burn spinning.
double idleCpu(double seconds) {
  const double before = processCpuSeconds();
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
  return processCpuSeconds() - before;
}

}  // namespace

TEST_CASE("BLAS threads reserved for supernodal factorizations", "[solver]") {
#ifdef DIFFREG_STATIC_OPENBLAS  // OpenBLAS's archive is linked in: its controls must be found
  REQUIRE(blasThreadsControllable());
#endif
  if (!blasThreadsControllable()) {
    WARN("the BLAS has no run-time thread control (not OpenBLAS): nothing to check");
    return;
  }
  // Not reserved: a scope changes nothing.
  REQUIRE_FALSE(blasThreadsReserved());
  const int started = blasThreads();
  {
    BlasThreadScope scope;
    CHECK(blasThreads() == started);
  }
  CHECK(blasThreads() == started);

  reserveBlasThreads();
  CHECK(blasThreadsReserved());
  CHECK(blasThreads() == 1);
  CHECK(blasScopeThreads() == started);
  reserveBlasThreads();  // idempotent
  CHECK(blasScopeThreads() == started);
  {
    BlasThreadScope outer;
    CHECK(blasThreads() == started);
    {
      BlasThreadScope inner;
      CHECK(blasThreads() == started);
    }
    CHECK(blasThreads() == started);  // the outer scope still holds them
  }
  CHECK(blasThreads() == 1);
  {
    const BlasThreadScope unwanted(false);  // e.g. a simplicial factor's solve
    CHECK(blasThreads() == 1);
  }
  CHECK(blasThreads() == 1);

  if (defaultSolverBackend() != SolverBackend::Cholmod) return;
  const int k = 30;
  const SparseMatrix A = cubeMatrix(k);
  Eigen::MatrixXd X(A.rows(), 3);
  for (Eigen::Index i = 0; i < X.rows(); ++i) {
    const double x = static_cast<double>(i % k) / k, y = static_cast<double>(i / k % k) / k;
    X.row(i) << x, y, x * y;
  }
  const Eigen::MatrixXd B = A * X;
  SpdSolver solver;
  solver.compute(A);
  INFO(solver.info().method << ", BLAS threads in the factorization: " << started);
  REQUIRE(solver.info().method.find("supernodal") != std::string::npos);
  CHECK(blasThreads() == 1);
  const Eigen::MatrixXd Y = solver.solve(B);
  CHECK((A * Y - B).cwiseAbs().maxCoeff() <= 1e-10 * B.cwiseAbs().maxCoeff());
  CHECK((Y - X).cwiseAbs().maxCoeff() <= 1e-7);
  // The factorization's workers were stopped with its scope: none spins afterwards (a spinning
  // OpenBLAS worker burns a core for about 0.1 s after each threaded call).
  CHECK(idleCpu(0.1) < 0.03);
}
