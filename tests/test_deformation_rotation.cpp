// The local step's closed-form and iterative rotations agree with the SVD, and the session's
// performance options (reserved couplings, progress callback) change no result.
#include "test_deformation_fixtures.h"

#include <diffreg/core/error.h>
#include <diffreg/deformation/rotation.h>

#include <catch2/catch.hpp>
#include <random>

using namespace diffreg;
using namespace diffreg::testing;

namespace {

template <int D>
Eigen::Matrix<double, D, D> randomMatrix(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Matrix<double, D, D> F;
  for (int i = 0; i < D; ++i)
    for (int j = 0; j < D; ++j) F(i, j) = n(rng);
  return F;
}

/// `targets` (rows of the bar's handle vertices) with the far end (x > 2) lifted by `dy` in y.
Eigen::MatrixXd liftFarEnd(Eigen::MatrixXd targets, double dy) {
  for (Eigen::Index i = 0; i < targets.rows(); ++i)
    if (targets(i, 0) > 2.0) targets(i, 1) += dy;
  return targets;
}

}  // namespace

TEST_CASE("the planar closed form is the SVD's closest rotation", "[deformation][rotation]") {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 2000; ++trial) {
    const Eigen::Matrix2d F = randomMatrix<2>(rng);
    double trace = 0.0;
    const Eigen::Matrix2d R = closestRotation2(F, trace);
    Eigen::Vector2d sigma;
    const Eigen::Matrix2d S = closestRotation<2>(F, sigma);
    CHECK((R - S).cwiseAbs().maxCoeff() < 1e-10);
    CHECK(R.determinant() == Approx(1.0).epsilon(1e-12));
    CHECK(trace == Approx(sigma.sum()).epsilon(1e-10));
    CHECK(trace == Approx((R.transpose() * F).trace()).epsilon(1e-12));
  }
  // A reflection with equal singular values: every rotation is as close; the identity is taken.
  double trace = 1.0;
  const Eigen::Matrix2d R = closestRotation2(Eigen::Vector2d(1.0, -1.0).asDiagonal(), trace);
  CHECK(R.isIdentity());
  CHECK(trace == 0.0);
}

TEST_CASE("the polar Newton iteration is the SVD's closest rotation for det F > 0",
          "[deformation][rotation]") {
  std::mt19937 rng(11);
  int accepted = 0, refused = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const Eigen::Matrix3d F = randomMatrix<3>(rng);
    Eigen::Matrix3d R = Eigen::Matrix3d::Constant(7.0);
    double trace = 0.0;
    if (!polarRotation3(F, R, trace)) {
      ++refused;
      CHECK(R == Eigen::Matrix3d::Constant(7.0));  // untouched
      continue;
    }
    ++accepted;
    REQUIRE(F.determinant() > 0.0);
    Eigen::Vector3d sigma;
    const Eigen::Matrix3d S = closestRotation<3>(F, sigma);
    CHECK((R - S).cwiseAbs().maxCoeff() < 1e-8);
    CHECK(trace == Approx(sigma.sum()).epsilon(1e-8));
  }
  // About half the random matrices are inverted (det < 0): those go to the SVD.
  CHECK(accepted > 800);
  CHECK(refused > 800);
  Eigen::Matrix3d R;
  double trace = 0.0;
  CHECK_FALSE(polarRotation3(Eigen::Vector3d(1.0, 1.0, -1.0).asDiagonal(), R, trace));
  CHECK_FALSE(polarRotation3(Eigen::Vector3d(1.0, 1.0, 0.0).asDiagonal(), R, trace));
}

TEST_CASE("the tangent-plane closed form is the SVD rotation restricted to the tangent plane",
          "[deformation][rotation]") {
  std::mt19937 rng(13);
  int accepted = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    Eigen::Vector3d n = randomMatrix<3>(rng).col(0).normalized();
    if (trial == 0) n = Eigen::Vector3d(0, 0, -1);  // the frame's branch point
    if (trial == 1) n = Eigen::Vector3d(0, 0, 1);
    const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - n * n.transpose();
    const Eigen::Matrix3d F = randomMatrix<3>(rng) * P;  // F n = 0, as for surface elements
    // T = Q E^T for the polar factor Q of F E in the tangent frame E of n.
    const Matrix32 E = tangentFrame(n);
    Matrix32 Q;
    double trace = 0.0;
    if (!tangentPolar(F * E, Q, trace)) continue;
    ++accepted;
    const Eigen::Matrix3d T = Q * E.transpose();
    CHECK((E.transpose() * E - Eigen::Matrix2d::Identity()).cwiseAbs().maxCoeff() < 1e-14);
    CHECK((E.transpose() * n).norm() < 1e-14);
    Eigen::Vector3d sigma;
    const Eigen::Matrix3d R = closestRotation<3>(F, sigma);
    const Eigen::Matrix3d S = R - (R * n) * n.transpose();
    CHECK((T - S).cwiseAbs().maxCoeff() < 1e-8);
    CHECK(trace == Approx(sigma.sum()).epsilon(1e-8));
    CHECK((T * n).norm() < 1e-12);
  }
  CHECK(accepted > 1900);
  // A deformed element collapsed to a segment is left to the SVD.
  const Eigen::Vector3d n(0, 0, 1);
  Eigen::Matrix3d F = Eigen::Matrix3d::Zero();
  F(0, 0) = 1.0;
  Matrix32 Q;
  double trace = 0.0;
  CHECK_FALSE(tangentPolar(F * tangentFrame(n), Q, trace));
  // ... whose thin SVD form is still a pair of orthonormal columns, the best one for F.
  Q = tangentPolarSvd(F * tangentFrame(n), trace);
  CHECK((Q.transpose() * Q - Eigen::Matrix2d::Identity()).cwiseAbs().maxCoeff() < 1e-12);
  CHECK(trace == Approx(1.0));
  const Eigen::Matrix3d T = rotationTarget(F, &n, trace);
  CHECK(T(0, 0) == Approx(1.0));
  CHECK((T * n).norm() < 1e-12);
}

TEST_CASE("a session without reserved couplings gives the same deformation",
          "[deformation][session]") {
  for (MeshKind kind : kAllKinds) {
    const auto disc = makeBar(kind);
    const std::vector<int> handles = bothEnds(*disc);
    const Eigen::MatrixXd targets = liftFarEnd(rows(disc->rest(), handles), 1.0);
    DeformationOptions reserved, lean;
    reserved.maxIterations = lean.maxIterations = 10;
    lean.reserveRegularization = false;
    DeformationSession a(*disc, reserved), b(*disc, lean);
    a.setHandles(handles);
    b.setHandles(handles);
    a.setTargets(targets);
    b.setTargets(targets);
    INFO(toString(kind));
    const auto pa = a.solve().positions, pb = b.solve().positions;
    CHECK((pa - pb).cwiseAbs().maxCoeff() < 1e-9);
    // The plain energy's pattern is smaller, until the regularizer needs its couplings.
    a.setRegularization(Regularization::Uniform, 0.5);
    b.setRegularization(Regularization::Uniform, 0.5);
    const SolverStats beforeA = a.stats(), beforeB = b.stats();
    const auto qa = a.solve().positions, qb = b.solve().positions;
    CHECK((qa - qb).cwiseAbs().maxCoeff() < 1e-9);
    CHECK((qa - pa).cwiseAbs().maxCoeff() > 1e-3);  // the regularizer did act
    CHECK((a.stats() - beforeA).symbolic == 0);
    CHECK((b.stats() - beforeB).symbolic >= 1);
  }
}

TEST_CASE("the progress callback sees every iteration's energy", "[deformation][session]") {
  for (MeshKind kind : kAllKinds)
    for (Energy energy : kAllEnergies) {
      const auto disc = makeBar(kind);
      const std::vector<int> handles = bothEnds(*disc);
      const Eigen::MatrixXd targets = liftFarEnd(rows(disc->rest(), handles), 1.0);
      // Capped at 8, and to convergence, whose last iterations include the plain steps that
      // decide stationarity.
      for (int cap : {8, 5000}) {
        std::vector<std::pair<int, double>> seen;
        DeformationOptions o;
        o.energy = energy;
        o.maxIterations = cap;
        o.progress = [&](int iteration, double E, double) { seen.emplace_back(iteration, E); };
        const DeformationResult r = deform(*disc, o, handles, targets);
        INFO(toString(kind) << " " << toString(energy) << ", cap " << cap << ", " << r.iterations
                            << " iterations");
        if (cap > 8) CHECK(r.converged);
        REQUIRE(static_cast<int>(seen.size()) == r.iterations);
        for (size_t i = 0; i < seen.size(); ++i) {
          CHECK(seen[i].first == static_cast<int>(i) + 1);
          CHECK(seen[i].second == r.energies[r.energies.size() - seen.size() + i]);
        }
      }
    }
}

TEST_CASE("setProgress installs, replaces and removes the callback of later solves",
          "[deformation][session]") {
  const auto disc = makeBar(MeshKind::Surface);
  const std::vector<int> handles = bothEnds(*disc);
  int first = 0, second = 0;
  DeformationOptions o;
  o.progress = [&first](int, double, double) { ++first; };
  DeformationSession s(*disc, o);
  s.setHandles(handles);
  s.setTargets(liftFarEnd(rows(disc->rest(), handles), 1.0));
  const DeformationResult a = s.solve(6, 0.0);
  CHECK(first == a.iterations);
  s.setProgress([&second](int iteration, double, double) { second = iteration; });
  const DeformationResult b = s.solve(6, 0.0);
  CHECK(first == a.iterations);  // replaced
  CHECK(second == b.iterations);
  s.setProgress(nullptr);
  second = 0;
  const DeformationResult c = s.solve(6, 0.0);
  CHECK(c.iterations == b.iterations);
  CHECK(second == 0);
  CHECK(first == a.iterations);
}

TEST_CASE("solveFrom continues from a given shape: a drag needs few iterations",
          "[deformation][session]") {
  for (MeshKind kind : kAllKinds) {
    const auto disc = makeBar(kind);
    const std::vector<int> handles = bothEnds(*disc);
    const Eigen::MatrixXd targets = liftFarEnd(rows(disc->rest(), handles), 1.0);
    DeformationSession s(*disc);
    s.setHandles(handles);
    s.setTargets(targets);
    const DeformationResult settled = s.solve(300, 0.0);
    INFO(toString(kind));
    // From its own result: no energy increase (each local/global step is a descent step).
    const DeformationResult again = s.solveFrom(settled.positions, 1, 0.0);
    CHECK(again.initialGuess == "given");
    CHECK(again.energies.front() == Approx(settled.energies.back()).epsilon(1e-9));
    CHECK(again.energies.back() <= settled.energies.back() * (1 + 1e-12));
    // A small drag of the moved end: from the previous shape the run converges in fewer
    // iterations than from the rest shape (or the ASAP guess). (Both are minima; ARAP can have
    // several, so the energies need not be equal.)
    s.setTargets(liftFarEnd(targets, 0.05));
    const DeformationResult warm =
        s.solveFrom(settled.positions, kDefaultIterations, kDefaultTolerance);
    const DeformationResult fresh = s.solve(kDefaultIterations, kDefaultTolerance);
    INFO("warm " << warm.iterations << " iterations, fresh " << fresh.iterations);
    CHECK(warm.converged);
    CHECK(fresh.converged);
    CHECK(warm.iterations < fresh.iterations);
    CHECK_THROWS_AS(s.solveFrom(Eigen::MatrixXd::Zero(3, disc->dim()), 10, 0.0), InvalidParameter);
    Eigen::MatrixXd bad = settled.positions;
    bad(0, 0) = std::nan("");
    CHECK_THROWS_AS(s.solveFrom(bad, 10, 0.0), InvalidParameter);
  }
}

TEST_CASE("a flat mesh deformed as a surface in 3D follows the planar iterates exactly",
          "[deformation][session]") {
  // The planar bar, and the same bar rotated into 3D as a surface: with in-plane targets the
  // surface energy (tangent-plane rotations) is the planar one, so every iterate must agree.
  const auto planar = makeBar(MeshKind::Planar);
  const Eigen::Matrix3d R = rotation(3, 0.7);
  Eigen::MatrixXd flat = Eigen::MatrixXd::Zero(planar->numVertices(), 3);
  flat.leftCols(2) = planar->rest().leftCols(2);
  const Discretization surface(MeshKind::Surface, flat * R.transpose(), planar->elements());
  const std::vector<int> handles = bothEnds(*planar);
  const Eigen::MatrixXd targets = liftFarEnd(rows(planar->rest(), handles).leftCols(2), 1.0);
  Eigen::MatrixXd targets3 = Eigen::MatrixXd::Zero(targets.rows(), 3);
  targets3.leftCols(2) = targets;

  {
    DeformationSession a(*planar), b(surface);  // ARAP
    a.setHandles(handles);
    b.setHandles(handles);
    a.setTargets(targets);
    b.setTargets(targets3 * R.transpose());
    // Both from the rest shape (planar ARAP would otherwise start from ASAP), 20 iterations:
    // at 29 the planar run has reached rounding and stops (a plain step up by rounding ends
    // a run), where the rotated one, rounded otherwise, runs on.
    const DeformationResult p = a.solveFrom(planar->rest().leftCols(2), 20, 0.0);
    const DeformationResult s = b.solveFrom(surface.rest(), 20, 0.0);
    REQUIRE(p.energies.size() == 21);
    REQUIRE(p.energies.size() == s.energies.size());
    for (size_t i = 0; i < p.energies.size(); ++i)
      CHECK(s.energies[i] == Approx(p.energies[i]).epsilon(1e-9).margin(1e-12));
    const Eigen::MatrixXd back = s.positions * R;  // rotated back into the plane
    CHECK((back.leftCols(2) - p.positions).cwiseAbs().maxCoeff() < 1e-7);
    CHECK(back.col(2).cwiseAbs().maxCoeff() < 1e-9);
  }
}
