// The second-order weights solved by preconditioned conjugate gradients (docs/method.md,
// "Diffused weights"): the same weights as the direct Cholesky of the 2-ring matrix, in a few
// iterations on every kind of mesh and every t, with the paper's Fig. 5 factorization reuse.
#include <diffreg/weights/diffusion.h>

#include <diffreg/core/error.h>
#include <diffreg/mesh/io.h>
#include <diffreg/mesh/shapes.h>

#include <catch2/catch.hpp>

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

using namespace diffreg;

namespace {

// Vertices within `radius` of p.
std::vector<int> near(const Discretization& d, const Eigen::Vector3d& p, double radius) {
  std::vector<int> ids;
  for (int v = 0; v < d.numVertices(); ++v) {
    Eigen::Vector3d x = Eigen::Vector3d::Zero();
    x.head(d.dim()) = d.rest().row(v).transpose();
    if (d.active()[v] && (x - p).norm() <= radius) ids.push_back(v);
  }
  return ids;
}

// Three handles: around the vertices at the two ends of the longest bounding-box axis and at the
// top of the second longest, with different ranges (so N = M R^-1 is not a multiple of M) and
// magnitudes.
struct Handles {
  std::vector<std::vector<int>> sets;
  std::vector<double> ranges, magnitudes;
};

Handles threeHandles(const Discretization& d) {
  const Eigen::MatrixXd& X = d.rest();
  const Eigen::RowVectorXd lo = X.colwise().minCoeff(), hi = X.colwise().maxCoeff();
  Eigen::Index a0 = 0, a1 = 0;
  Eigen::RowVectorXd extent = hi - lo;
  extent.maxCoeff(&a0);
  extent(a0) = -1.0;
  extent.maxCoeff(&a1);
  Eigen::Index centres[3];
  X.col(a0).minCoeff(&centres[0]);
  X.col(a0).maxCoeff(&centres[1]);
  X.col(a1).maxCoeff(&centres[2]);
  const double radius = 0.08 * d.boundingBoxDiagonal();
  Handles h;
  std::vector<bool> taken(X.rows(), false);
  const double r[] = {1.0, 2.5, 0.6}, m[] = {1.0, 0.4, 0.7};
  for (int j = 0; j < 3; ++j) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    c.head(d.dim()) = X.row(centres[j]).transpose();
    std::vector<int> set;
    for (int v : near(d, c, radius))
      if (!taken[v]) set.push_back(v), taken[v] = true;
    if (set.empty()) continue;
    h.sets.push_back(set);
    h.ranges.push_back(r[j]);
    h.magnitudes.push_back(m[j]);
  }
  return h;
}

DiffusionParams secondOrder(double t, DiffusionSolve solve) {
  DiffusionParams p;
  p.t = t;
  p.unit = TimeUnit::Diagonal;
  p.order = DiffusionOrder::Second;
  p.solve = solve;
  p.clip = false;  // the raw solutions are compared
  return p;
}

// PCG and direct weights on `disc` for each t: equal to 1e-9, in few iterations.
void checkAgainstDirect(const Discretization& disc, const std::vector<double>& times) {
  const Handles h = threeHandles(disc);
  REQUIRE(h.sets.size() >= 2);
  DiffusionWeights pcg(disc), direct(disc);
  pcg.setHandles(h.sets, h.ranges, h.magnitudes);
  direct.setHandles(h.sets, h.ranges, h.magnitudes);
  for (double t : times) {
    INFO("t = " << t << " diagonal^2");
    pcg.setParams(secondOrder(t, DiffusionSolve::Pcg));
    direct.setParams(secondOrder(t, DiffusionSolve::Direct));
    const Eigen::VectorXd x = pcg.solve(), y = direct.solve();
    const DiffusionSolveInfo& info = pcg.lastSolve();
    INFO("CG: " << info.cgIterations << " iterations, relative residual " << info.cgResidual);
    CHECK(info.converged);
    CHECK(info.cgIterations >= 1);
    CHECK(info.cgIterations <= 15);  // the preconditioned condition number is below 1.18
    CHECK(info.cgResidual <= kDiffusionCgTolerance);
    CHECK((x - y).cwiseAbs().maxCoeff() <= 1e-9);
    CHECK(x.cwiseAbs().maxCoeff() > 0.1);  // not trivially equal
    CHECK(direct.lastSolve().cgIterations == 0);
  }
}

const std::vector<double> kTimes{1e-4, 1e-3, 0.01, 0.1, 1.0, 10.0};

}  // namespace

TEST_CASE("PCG second-order weights equal the direct solve: planar", "[weights][pcg]") {
  checkAgainstDirect(Discretization(makeRectangle(2, 1, 40, 20)), kTimes);
  checkAgainstDirect(Discretization(makeUShape(1.0, 1.0, 4.0, 6)), kTimes);
}

TEST_CASE("PCG second-order weights equal the direct solve: surface", "[weights][pcg]") {
  checkAgainstDirect(Discretization(makeSphere(1.0, 40, 25)), kTimes);
  checkAgainstDirect(Discretization(makeCylinder(1.0, 4.0, 32, 24)), kTimes);
}

TEST_CASE("PCG second-order weights equal the direct solve: tets", "[weights][pcg]") {
  checkAgainstDirect(Discretization(makeTetBox(3, 1, 1, 15, 5, 5)), kTimes);
}

TEST_CASE("PCG second-order weights equal the direct solve: shared meshes", "[weights][pcg]") {
  const std::filesystem::path dir = DIFFREG_SHARED_MESHES;
  for (const char* file : {"planar-woody.obj", "surface-decimated-knight.off",
                           "tet-decimated-knight.mesh", "tet-bar.mesh"}) {
    const std::filesystem::path path = dir / file;
    if (!std::filesystem::exists(path)) {
      WARN(path.string() << " not found; skipping");
      continue;
    }
    INFO(file);
    const Mesh mesh = readMesh(path.string());
    checkAgainstDirect(Discretization(mesh), {1e-3, 0.01, 0.1, 1.0});
  }
}

TEST_CASE("PCG second-order weights reuse factorizations as Fig. 5 prescribes", "[weights][pcg]") {
  const Discretization d(makeRectangle(4, 2, 16, 8));
  DiffusionWeights w(d);
  const std::vector<int> a = near(d, {0, 0, 0}, 0.3), b = near(d, {4, 2, 0}, 0.3);
  w.setHandles({a, b}, {1, 1}, {1, 1});
  w.setParams(secondOrder(0.05, DiffusionSolve::Pcg));
  // Every CG iteration applies the preconditioner once: two back-substitutions.
  int solves = 0;
  auto solved = [&] {
    w.solve();
    const int iterations = w.lastSolve().cgIterations;
    CHECK(iterations >= 1);
    CHECK(iterations <= 15);
    solves += 2 * iterations;
    CHECK(w.stats().solves == solves);
  };
  solved();
  CHECK(w.stats().symbolic == 1);  // a new handle set: symbolic + numeric
  CHECK(w.stats().numeric == 1);
  w.setMagnitude(1, 0.5);  // m: only the CG runs, for handle 1's own weights
  solved();
  CHECK(w.stats().symbolic == 1);
  CHECK(w.stats().numeric == 1);
  // The same handle's magnitude again (a slider): handle 1's own weights are kept, so nothing is solved,
  // and the weights equal a solve from scratch.
  w.setMagnitude(1, 0.8);
  const Eigen::VectorXd dragged = w.solve();
  CHECK(w.lastSolve().cgIterations == 0);
  CHECK(w.stats().solves == solves);
  DiffusionWeights scratch(d);
  scratch.setHandles({a, b}, {1, 1}, {1, 0.8});
  scratch.setParams(secondOrder(0.05, DiffusionSolve::Pcg));
  CHECK((dragged - scratch.solve()).cwiseAbs().maxCoeff() < 1e-10);
  w.setMagnitude(0, 0.7);  // the other handle: its own weights, once
  solved();
  scratch.setMagnitude(0, 0.7);
  CHECK((w.solve() - scratch.solve()).cwiseAbs().maxCoeff() < 1e-10);
  CHECK(w.lastSolve().cgIterations == 0);
  w.setParams(secondOrder(0.2, DiffusionSolve::Pcg));  // t: numeric only
  solved();
  CHECK(w.stats().symbolic == 1);
  CHECK(w.stats().numeric == 2);
  w.setRange(0, 2.0);  // r_j: numeric only
  solved();
  CHECK(w.stats().symbolic == 1);
  CHECK(w.stats().numeric == 3);
  w.setHandles({a, b, near(d, {2, 1, 0}, 0.3)}, {1, 1, 1}, {1, 1, 1});  // new set: symbolic
  solved();
  CHECK(w.stats().symbolic == 2);
  CHECK(w.stats().numeric == 4);

  // The preconditioner's factor has the first order's pattern: switching order refactors only.
  DiffusionParams first = secondOrder(0.2, DiffusionSolve::Pcg);
  first.order = DiffusionOrder::First;
  w.setParams(first);
  w.solve();
  CHECK(w.stats().symbolic == 2);
  CHECK(w.stats().numeric == 5);
  CHECK(w.lastSolve().cgIterations == 0);
  // The direct second order has the 2-ring pattern: analyzed again.
  w.setParams(secondOrder(0.2, DiffusionSolve::Direct));
  w.solve();
  CHECK(w.stats().symbolic == 3);
  CHECK(w.stats().numeric == 6);
}

TEST_CASE("With the handle basis every magnitude change is a superposition", "[weights][pcg]") {
  // setHandleBasis: the first solve runs one block CG for every handle's own weights (two
  // block back-substitutions per iteration, as one CG), and no change of a magnitude solves.
  const Discretization d(makeRectangle(4, 2, 16, 8));
  const std::vector<int> a = near(d, {0, 0, 0}, 0.3), b = near(d, {4, 2, 0}, 0.3),
                         c = near(d, {2, 1, 0}, 0.3);
  DiffusionWeights w(d);
  w.setHandleBasis(true);
  w.setHandles({a, b, c}, {1, 1, 2}, {1, 0.5, 0.25});
  w.setParams(secondOrder(0.05, DiffusionSolve::Pcg));
  DiffusionWeights scratch(d);
  scratch.setHandles({a, b, c}, {1, 1, 2}, {1, 0.5, 0.25});
  scratch.setParams(secondOrder(0.05, DiffusionSolve::Pcg));
  CHECK((w.solve() - scratch.solve()).cwiseAbs().maxCoeff() < 1e-10);
  const int iterations = w.lastSolve().cgIterations;
  CHECK(iterations >= 1);
  CHECK(iterations <= 15);
  CHECK(w.stats().solves == 2 * iterations);
  CHECK(w.lastSolve().cgResidual <= kDiffusionCgTolerance);

  for (const auto& [handle, m] : {std::pair<int, double>{1, 0.9}, {0, 0.3}, {2, 0.0}, {1, 0.1}}) {
    w.setMagnitude(handle, m);
    scratch.setMagnitude(handle, m);
    const Eigen::VectorXd x = w.solve();
    CHECK(w.lastSolve().cgIterations == 0);
    CHECK(w.stats().solves == 2 * iterations);  // not one back-substitution more
    CHECK((x - scratch.solve()).cwiseAbs().maxCoeff() < 1e-10);
  }
  // A new t: one numeric factorization and the block CG again.
  w.setParams(secondOrder(0.2, DiffusionSolve::Pcg));
  scratch.setParams(secondOrder(0.2, DiffusionSolve::Pcg));
  CHECK((w.solve() - scratch.solve()).cwiseAbs().maxCoeff() < 1e-10);
  CHECK(w.stats().symbolic == 1);
  CHECK(w.stats().numeric == 2);
  CHECK(w.lastSolve().cgIterations >= 1);
}

TEST_CASE("Magnitudes all zero give zero weights without CG iterations", "[weights][pcg]") {
  const Discretization d(makeRectangle(2, 1, 8, 4));
  DiffusionWeights w(d);
  w.setHandles({near(d, {0, 0, 0}, 0.3)}, {1.0}, {0.0});
  w.setParams(secondOrder(0.1, DiffusionSolve::Pcg));
  CHECK(w.solve().cwiseAbs().maxCoeff() == 0.0);
  CHECK(w.lastSolve().cgIterations == 0);
  CHECK(w.lastSolve().converged);
}

TEST_CASE("The second-order solve parses its names", "[weights][pcg]") {
  for (DiffusionSolve s : {DiffusionSolve::Pcg, DiffusionSolve::Direct})
    CHECK(parseEnum<DiffusionSolve>(toString(s)) == s);
  CHECK(DiffusionParams().solve == DiffusionSolve::Pcg);
  CHECK_THROWS_AS(parseEnum<DiffusionSolve>("lu"), InvalidParameter);
  CHECK_THROWS_WITH(parseEnum<DiffusionSolve>("lu"), Catch::Contains("pcg, direct"));
}
