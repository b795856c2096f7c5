// SPD solver: correctness, counters of each phase, Dirichlet elimination, singular systems.
#include <diffreg/solver/solver.h>

#include <diffreg/core/error.h>

#include <catch2/catch.hpp>

using namespace diffreg;

namespace {

// 1D Laplacian on a path of n vertices (singular: constants in its kernel).
SparseMatrix pathLaplacian(int n) {
  std::vector<Eigen::Triplet<double>> t;
  for (int i = 0; i + 1 < n; ++i) {
    t.emplace_back(i, i, 1.0);
    t.emplace_back(i + 1, i + 1, 1.0);
    t.emplace_back(i, i + 1, -1.0);
    t.emplace_back(i + 1, i, -1.0);
  }
  SparseMatrix L(n, n);
  L.setFromTriplets(t.begin(), t.end());
  return L;
}

SparseMatrix identity(int n) {
  SparseMatrix I(n, n);
  I.setIdentity();
  return I;
}

}  // namespace

TEST_CASE("Both backends solve an SPD system with several right-hand sides", "[solver]") {
  const int n = 50;
  const SparseMatrix A = pathLaplacian(n) + 0.1 * identity(n);
  const Eigen::MatrixXd X = Eigen::MatrixXd::Random(n, 3);
  const Eigen::MatrixXd B = A * X;
  for (SolverBackend backend : {SolverBackend::Cholmod, SolverBackend::Eigen}) {
    SpdSolver solver(backend);
    solver.analyze(A);
    solver.factorize(A);
    CHECK((solver.solve(B) - X).norm() < 1e-10);
    CHECK(solver.stats().symbolic == 1);
    CHECK(solver.stats().numeric == 1);
    CHECK(solver.stats().solves == 1);
  }
}

TEST_CASE("compute() analyzes only when the pattern changes", "[solver]") {
  const int n = 20;
  SpdSolver solver;
  solver.compute(pathLaplacian(n) + identity(n));
  solver.compute(2.0 * pathLaplacian(n) + identity(n));  // same pattern: numeric only
  CHECK(solver.stats().symbolic == 1);
  CHECK(solver.stats().numeric == 2);
  solver.compute(identity(n));  // new pattern
  CHECK(solver.stats().symbolic == 2);
  solver.compute(identity(n), true);  // forced
  CHECK(solver.stats().symbolic == 3);
  CHECK(solver.stats().numeric == 4);
}

TEST_CASE("A matrix that is not positive definite is a SingularSystem", "[solver]") {
  for (SolverBackend backend : {SolverBackend::Cholmod, SolverBackend::Eigen}) {
    SpdSolver solver(backend);
    const SparseMatrix A = pathLaplacian(10) - identity(10);
    CHECK_THROWS_AS(solver.compute(A), SingularSystem);
    CHECK_THROWS_AS(solver.solve(Eigen::MatrixXd::Ones(10, 1)), SingularSystem);
  }
}

TEST_CASE("An indefinite matrix without a zero pivot is a SingularSystem", "[solver]") {
  // The simplicial factor is LDL^T, which succeeds on these: its pivots are checked.
  SparseMatrix lastNegative = pathLaplacian(10) + 0.1 * identity(10);
  lastNegative.coeffRef(9, 9) = -5.0;
  for (const SparseMatrix& A : {SparseMatrix(-1.0 * identity(10)), lastNegative})
    for (SolverBackend backend : {SolverBackend::Cholmod, SolverBackend::Eigen}) {
      SpdSolver solver(backend);
      CHECK_THROWS_AS(solver.compute(A), SingularSystem);
      CHECK_THROWS_AS(solver.solve(Eigen::MatrixXd::Ones(10, 1)), SingularSystem);
    }
}

TEST_CASE("Dirichlet elimination: harmonic interpolation of a linear function is linear",
          "[solver]") {
  const int n = 30;
  std::vector<bool> fixed(n, false);
  fixed[0] = fixed[n - 1] = true;
  EliminatedSolver solver;
  solver.setPartition(Partition(fixed));
  solver.setMatrix(pathLaplacian(n));
  Eigen::MatrixXd xFixed(2, 2);
  xFixed << 1.0, -2.0, 30.0, 5.0;
  const Eigen::MatrixXd x = solver.solve(Eigen::MatrixXd::Zero(n, 2), xFixed);
  for (int i = 0; i < n; ++i) {
    const double s = i / double(n - 1);
    CHECK(x(i, 0) == Approx(1.0 + 29.0 * s).epsilon(1e-12));
    CHECK(x(i, 1) == Approx(-2.0 + 7.0 * s).epsilon(1e-12));
  }
  // New targets: right-hand side only. New values, same pattern: numeric only.
  solver.solve(Eigen::MatrixXd::Zero(n, 2), 2.0 * xFixed);
  solver.setMatrix(3.0 * pathLaplacian(n));
  CHECK(solver.stats().symbolic == 1);
  CHECK(solver.stats().numeric == 2);
  CHECK(solver.stats().solves == 2);
  // A new partition (handles added): symbolic again.
  fixed[n / 2] = true;
  solver.setPartition(Partition(fixed));
  solver.setMatrix(pathLaplacian(n));
  CHECK(solver.stats().symbolic == 2);
}

TEST_CASE("a solver told when its pattern changes keeps no copy and still analyzes when it must",
          "[solver]") {
  const int n = 30;
  std::vector<bool> fixed(n, false);
  fixed[0] = fixed[n - 1] = true;
  EliminatedSolver trusted, checking;
  trusted.trustPatterns();
  for (EliminatedSolver* s : {&trusted, &checking}) s->setPartition(Partition(fixed));
  Eigen::MatrixXd xFixed(2, 1);
  xFixed << 1.0, 30.0;
  const Eigen::MatrixXd b = Eigen::MatrixXd::Ones(n, 1);
  // Same pattern, new values: numeric only, the same solution as the solver that compares.
  for (double scale : {1.0, 3.0}) {
    trusted.setMatrix(scale * pathLaplacian(n), scale != 1.0);
    checking.setMatrix(scale * pathLaplacian(n));
    CHECK((trusted.solve(b, xFixed) - checking.solve(b, xFixed)).cwiseAbs().maxCoeff() < 1e-12);
  }
  CHECK(trusted.stats().symbolic == 1);
  CHECK(trusted.stats().numeric == 2);
  // A new pattern (a longer-range coupling) announced as such: analyzed again, right answer.
  SparseMatrix wider = pathLaplacian(n);
  for (int i = 0; i + 2 < n; ++i) {
    wider.coeffRef(i, i + 2) -= 0.5;
    wider.coeffRef(i + 2, i) -= 0.5;
    wider.coeffRef(i, i) += 0.5;
    wider.coeffRef(i + 2, i + 2) += 0.5;
  }
  wider.makeCompressed();
  trusted.setMatrix(wider, false);
  checking.setMatrix(wider);
  CHECK(trusted.stats().symbolic == 2);
  CHECK(checking.stats().symbolic == 2);
  CHECK((trusted.solve(b, xFixed) - checking.solve(b, xFixed)).cwiseAbs().maxCoeff() < 1e-12);
  // A new partition always analyzes again, whatever the caller says.
  fixed[n / 2] = true;
  trusted.setPartition(Partition(fixed));
  trusted.setMatrix(wider, true);
  CHECK(trusted.stats().symbolic == 3);
}

TEST_CASE("A free component without fixed values is a SingularSystem", "[solver]") {
  // Two disconnected paths; only the first has a fixed vertex.
  const int n = 10;
  SparseMatrix L(2 * n, 2 * n);
  std::vector<Eigen::Triplet<double>> t;
  const SparseMatrix P = pathLaplacian(n);
  for (int c = 0; c < 2; ++c)
    for (int j = 0; j < P.outerSize(); ++j)
      for (SparseMatrix::InnerIterator it(P, j); it; ++it)
        t.emplace_back(c * n + it.row(), c * n + j, it.value());
  L.setFromTriplets(t.begin(), t.end());
  std::vector<bool> fixed(2 * n, false);
  fixed[0] = true;
  EliminatedSolver solver;
  solver.setPartition(Partition(fixed));
  CHECK_THROWS_AS(
      [&] {
        solver.setMatrix(L);
        solver.solve(Eigen::MatrixXd::Ones(2 * n, 1), Eigen::MatrixXd::Ones(1, 1));
      }(),
      SingularSystem);
}
