// The fill-reducing ordering of large factors: nested dissection replaces AMD when its factor is
// clearly smaller, and the solution stays as accurate.
#include <diffreg/solver/solver.h>

#include <catch2/catch.hpp>

using namespace diffreg;

namespace {

// 5-point Laplacian of a k x k grid plus a small multiple of the identity (SPD).
SparseMatrix gridMatrix(int k) {
  std::vector<Eigen::Triplet<double>> t;
  auto id = [k](int i, int j) { return i * k + j; };
  for (int i = 0; i < k; ++i)
    for (int j = 0; j < k; ++j) {
      t.emplace_back(id(i, j), id(i, j), 1e-3);
      if (i + 1 < k) {
        t.emplace_back(id(i, j), id(i, j), 1.0);
        t.emplace_back(id(i + 1, j), id(i + 1, j), 1.0);
        t.emplace_back(id(i, j), id(i + 1, j), -1.0);
        t.emplace_back(id(i + 1, j), id(i, j), -1.0);
      }
      if (j + 1 < k) {
        t.emplace_back(id(i, j), id(i, j), 1.0);
        t.emplace_back(id(i, j + 1), id(i, j + 1), 1.0);
        t.emplace_back(id(i, j), id(i, j + 1), -1.0);
        t.emplace_back(id(i, j + 1), id(i, j), -1.0);
      }
    }
  SparseMatrix A(k * k, k * k);
  A.setFromTriplets(t.begin(), t.end());
  return A;
}

}  // namespace

TEST_CASE("a large grid system is factored in nested-dissection order and solved accurately",
          "[solver]") {
  if (defaultSolverBackend() != SolverBackend::Cholmod) return;  // Eigen orders by AMD only
  const int k = 300;
  const SparseMatrix A = gridMatrix(k);
  Eigen::MatrixXd X(A.rows(), 3);
  for (Eigen::Index i = 0; i < X.rows(); ++i) {
    const double x = static_cast<double>(i % k) / k, y = static_cast<double>(i / k) / k;
    X.row(i) << x, y, x * y;
  }
  const Eigen::MatrixXd B = A * X;
  SpdSolver solver;
  solver.compute(A);
  const SolverInfo info = solver.info();
  INFO(info.method << ", " << info.ordering << ", nnz(L) = " << info.factorNonZeros);
  // A planar grid's nested dissection factor is much smaller than its minimum-degree one.
  CHECK(info.ordering == "METIS");
  const Eigen::MatrixXd Y = solver.solve(B);
  CHECK((Y - X).cwiseAbs().maxCoeff() <= 1e-8);
  CHECK((A * Y - B).cwiseAbs().maxCoeff() <= 1e-10 * B.cwiseAbs().maxCoeff());
}

TEST_CASE("small systems keep the minimum-degree ordering", "[solver]") {
  if (defaultSolverBackend() != SolverBackend::Cholmod) return;
  SpdSolver solver;
  solver.compute(gridMatrix(30));
  CHECK(solver.info().ordering == "AMD");
}
