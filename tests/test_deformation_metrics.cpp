// Included first: it silences a GCC false positive in OpenMesh before any system header.
#include "test_deformation_fixtures.h"

#include <diffreg/deformation/metrics.h>

#include <diffreg/core/error.h>
#include <diffreg/deformation/rotation.h>
#include <diffreg/discretization/element_order.h>

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>

using namespace diffreg;
using namespace diffreg::testing;

namespace {

// The bar with both ends clamped and one point handle in the middle of its bottom side pushed
// up (into the bar) by `depth`. Handle 0 is the point handle.
struct PushedBar {
  std::unique_ptr<Discretization> disc;
  std::vector<int> handles;
  Eigen::MatrixXd targets;
};

PushedBar pushedBar(MeshKind kind, double depth) {
  PushedBar b;
  b.disc = makeBar(kind);
  const Eigen::MatrixXd& rest = b.disc->rest();
  Eigen::RowVectorXd p = 0.5 * (rest.colwise().minCoeff() + rest.colwise().maxCoeff());
  p(1) = rest.col(1).minCoeff();
  b.handles = {nearestVertex(*b.disc, p)};
  for (int v : bothEnds(*b.disc)) b.handles.push_back(v);
  b.targets = rows(rest, b.handles);
  b.targets(0, 1) += depth;
  return b;
}

struct Outcome {
  DeformationMetrics metrics;
  double dMaxNearHandle = 0.0;  // max D_k over elements within 0.5 of the point handle
};

// ARAP with the given regularization; metrics against the unregularized solution `plain`.
Outcome run(const PushedBar& b, Regularization mode, double beta, const Eigen::VectorXd& x,
            Eigen::MatrixXd* plain) {
  DeformationOptions o;
  o.energy = Energy::Arap;
  o.regularization = mode;
  o.beta = beta;
  if (mode == Regularization::Nonuniform) o.weights = x;
  o.maxIterations = 100;
  o.relTolerance = 1e-8;
  const DeformationResult r = deform(*b.disc, o, b.handles, b.targets);
  if (mode == Regularization::None) *plain = r.positions;
  Outcome out;
  // Distortion measured without regularization weights: the same D_k for all three runs.
  const auto none = makeRegularizationWeights(*b.disc, Regularization::None, 0.0);
  out.metrics = measureDeformation(*b.disc, Energy::Arap, r.positions, none, plain);
  const Eigen::VectorXd D = elementDistortion(*b.disc, Energy::Arap, r.positions);
  const Discretization& disc = *b.disc;
  for (int k = 0; k < disc.numElements(); ++k) {
    Eigen::RowVectorXd centre = Eigen::RowVectorXd::Zero(disc.dim());
    for (int i = 0; i < disc.elementSize(); ++i)
      centre += disc.rest().row(disc.elements()(k, i)) / disc.elementSize();
    if ((centre - disc.rest().row(b.handles[0])).norm() < 0.5)
      out.dMaxNearHandle = std::max(out.dMaxNearHandle, D(k));
  }
  return out;
}

// `mesh` with its elements shuffled, more than kLocalityMinElements of them, so that a session
// stores them in its own locality order; both ends held, the handle vertices with x > `split`
// lifted by `lift`.
PushedBar shuffledEnds(const Mesh& mesh, double split, double lift) {
  PushedBar b;
  const Discretization plain(mesh);
  REQUIRE(plain.numElements() > kLocalityMinElements);
  std::vector<int> order(static_cast<size_t>(plain.numElements()));
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), std::mt19937(7));
  b.disc = std::make_unique<Discretization>(plain.withElementOrder(order));
  REQUIRE_FALSE(localityElementOrder(*b.disc).empty());
  b.handles = bothEnds(*b.disc);
  b.targets = rows(b.disc->rest(), b.handles);
  for (Eigen::Index i = 0; i < b.targets.rows(); ++i)
    if (b.targets(i, 0) > split) b.targets(i, 1) += lift;
  return b;
}

}  // namespace

TEST_CASE("metrics of the rest shape and of simple motions", "[deformation][metrics]") {
  for (MeshKind kind : kAllKinds) {
    const auto disc = makeBar(kind);
    const auto w = makeRegularizationWeights(*disc, Regularization::Uniform, 0.5);
    INFO(toString(kind));
    const Eigen::MatrixXd& rest = disc->rest();
    const DeformationMetrics m = measureDeformation(*disc, Energy::Arap, rest, w, &rest);
    CHECK(m.dMax < 1e-24);
    CHECK(m.energy < 1e-24);
    CHECK(m.inverted == 0);
    REQUIRE(m.dist.has_value());
    CHECK(*m.dist == 0.0);
    CHECK_FALSE(measureDeformation(*disc, Energy::Arap, rest, w).dist.has_value());

    const Eigen::RowVectorXd shift = Eigen::RowVectorXd::Constant(disc->dim(), 0.5);
    CHECK(rmsDistance(rest.rowwise() + shift, rest) == Approx(shift.norm()));

    // A stretch by 1.5 along x (the bar's axis, tangent to every surface element):
    // F - I = 0.5 e_x e_x^T everywhere, so D_k = 0.25 and neighbouring residuals agree.
    Eigen::MatrixXd stretched = rest;
    stretched.col(0) *= 1.5;
    const DeformationMetrics s = measureDeformation(*disc, Energy::Dirichlet, stretched, w);
    CHECK(s.dMax == Approx(0.25));
    CHECK(s.dAve == Approx(0.25));
    CHECK(s.dDev == Approx(0.0).margin(1e-9));
    CHECK(facetSmoothness(*disc, Energy::Dirichlet, stretched).cwiseAbs().maxCoeff() < 1e-20);
  }
}

TEST_CASE("positions beyond 1e30 are refused, never measured as NaN or infinity",
          "[deformation][metrics][hostile]") {
  for (MeshKind kind : kAllKinds) {
    const auto disc = makeBar(kind);
    const auto w = makeRegularizationWeights(*disc, Regularization::Uniform, 0.5);
    INFO(toString(kind));
    const Eigen::MatrixXd& rest = disc->rest();
    // Scaled to a size whose squares overflow; moved far away; not finite.
    const Eigen::MatrixXd scaled = rest * 1e78;
    const Eigen::MatrixXd moved = (rest.array() + 1e155).matrix();
    Eigen::MatrixXd broken = rest;
    broken(1, 0) = std::numeric_limits<double>::quiet_NaN();
    for (const Eigen::MatrixXd* X :
         std::initializer_list<const Eigen::MatrixXd*>{&scaled, &moved, &broken}) {
      CHECK_THROWS_WITH(measureDeformation(*disc, Energy::Arap, *X, w),
                        Catch::Contains("metrics: the positions"));
      CHECK_THROWS_WITH(measureDeformation(*disc, Energy::Arap, rest, w, X),
                        Catch::Contains("metrics: the reference positions"));
      CHECK_THROWS_AS(elementDistortion(*disc, Energy::Arap, *X), InvalidParameter);
    }
    // Within the bound: finite.
    const DeformationMetrics large = measureDeformation(*disc, Energy::Arap, rest * 1e29, w, &rest);
    CHECK(std::isfinite(large.dMax));
    CHECK(std::isfinite(large.energy));
    CHECK(std::isfinite(*large.dist));
  }
}

TEST_CASE("inverted surface triangles: the closed-form rotation of the normal is the SVD's",
          "[deformation][metrics]") {
  // METHOD.md: a surface triangle is inverted when its deformed normal points against R_k n_k,
  // R_k the closest rotation to F_k. countInverted takes R_k n_k = q1 x q2 of the tangent polar
  // factor Q of F_k E (E the rest tangent frame) and the SVD only where tangentPolar declines
  // (nearly collapsed triangles). Per face: the two R_k n_k agree wherever the closed form
  // applies, the nearly flat faces do decline it, and the counts agree with the SVD's. (With
  // F_k n_k = 0 the criterion reduces to a collapsed triangle in exact arithmetic, as
  // docs/method.md says; the count keeps METHOD.md's form.)
  const auto disc = makeBar(MeshKind::Surface);
  const Eigen::MatrixXi& el = disc->elements();
  struct Face {
    Eigen::Vector3d svd, closed;  // R_k n_k both ways (closed: only when `applies`)
    bool applies = false;
    double sigmaRatio = 0.0;  // sigma_1 / sigma_2 of F_k
    bool inverted = false;    // by the SVD's R_k n_k
  };
  const auto faces = [&](const Eigen::MatrixXd& X) {
    std::vector<Face> out(static_cast<size_t>(disc->numElements()));
    for (int k = 0; k < disc->numElements(); ++k) {
      Face& f = out[static_cast<size_t>(k)];
      const Eigen::MatrixXd G = disc->gradient(k);
      Eigen::Matrix3d F = Eigen::Matrix3d::Zero();
      for (int i = 0; i < 3; ++i) F += X.row(el(k, i)).transpose() * G.row(i);
      const Eigen::Vector3d n = disc->normals().row(k).transpose();
      Eigen::Vector3d sigma;
      f.svd = closestRotation<3>(F, sigma) * n;
      f.sigmaRatio = sigma(0) / std::max(std::abs(sigma(1)), 1e-300);
      Matrix32 Q;
      double trace = 0.0;
      f.applies = tangentPolar(F * tangentFrame(n), Q, trace);
      if (f.applies) f.closed = Q.col(0).cross(Q.col(1));
      const Eigen::Vector3d a = (X.row(el(k, 1)) - X.row(el(k, 0))).transpose();
      const Eigen::Vector3d b = (X.row(el(k, 2)) - X.row(el(k, 0))).transpose();
      f.inverted = a.cross(b).dot(f.svd) <= 0.0;
    }
    return out;
  };
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  const Eigen::MatrixXd& rest = disc->rest();
  std::vector<std::pair<std::string, Eigen::MatrixXd>> shapes;
  shapes.emplace_back("rest", rest);
  Eigen::MatrixXd mirrored = rest;
  mirrored.col(0) *= -1.0;
  shapes.emplace_back("mirrored", mirrored);
  for (double amount : {0.05, 0.3, 2.0}) {
    Eigen::MatrixXd X = rest;
    for (Eigen::Index i = 0; i < X.size(); ++i) X(i) += amount * noise(rng);
    shapes.emplace_back("noise " + std::to_string(amount), X);
  }
  // Collapsed triangles (a band onto one point, another onto one line) and every seventh
  // triangle pressed flat to within 1e-12 of its first edge.
  Eigen::MatrixXd collapsed = rest, nearly = rest;
  for (Eigen::Index v = 0; v < rest.rows(); ++v) {
    if (std::abs(rest(v, 0) - 2.0) < 0.3) collapsed.row(v) = Eigen::RowVector3d(2.0, 0.0, 0.0);
    if (std::abs(rest(v, 0) - 1.0) < 0.3) collapsed.row(v) << rest(v, 0), 0.0, 0.0;
  }
  std::vector<int> pressed;
  std::vector<bool> touched(static_cast<size_t>(rest.rows()), false);
  for (int k = 0; k < disc->numElements(); k += 7) {
    // Faces with no vertex in common, so that one pressing does not undo another.
    if (touched[el(k, 0)] || touched[el(k, 1)] || touched[el(k, 2)]) continue;
    for (int i = 0; i < 3; ++i) touched[el(k, i)] = true;
    nearly.row(el(k, 2)) = 0.5 * (nearly.row(el(k, 0)) + nearly.row(el(k, 1))) +
                           1e-12 * Eigen::RowVector3d(noise(rng), noise(rng), noise(rng));
    pressed.push_back(k);
  }
  shapes.emplace_back("collapsed", collapsed);
  shapes.emplace_back("nearly flat", nearly);
  int closedForm = 0, fallback = 0;
  for (const auto& [name, X] : shapes) {
    INFO(name);
    const std::vector<Face> f = faces(X);
    int count = 0;
    for (size_t k = 0; k < f.size(); ++k) {
      INFO("face " << k);
      count += f[k].inverted;
      if (!f[k].applies) {
        ++fallback;
        continue;
      }
      ++closedForm;
      // Rounding of both: about machine epsilon times sigma_1 / sigma_2.
      CHECK((f[k].closed - f[k].svd).norm() <= 1e-13 * std::max(1.0, f[k].sigmaRatio));
    }
    CHECK(countInverted(*disc, X) == count);
  }
  // The pressed faces take the fallback (their neighbours, sharing a pressed vertex, need not).
  const std::vector<Face> flat = faces(nearly);
  for (int k : pressed) CHECK_FALSE(flat[static_cast<size_t>(k)].applies);
  CHECK(closedForm > 0);
  CHECK(pressed.size() > 10);
  CHECK(fallback >= static_cast<int>(pressed.size()));
}

TEST_CASE("D_ave and D_dev are area-weighted; smoothness per element is the max over its facets",
          "[deformation][metrics]") {
  const auto disc = makeBar(MeshKind::Planar);
  Eigen::MatrixXd X = disc->rest();
  X.col(1) += 0.1 * X.col(0).array().square().matrix();
  const auto none = makeRegularizationWeights(*disc, Regularization::None, 0.0);
  const DeformationMetrics m = measureDeformation(*disc, Energy::Arap, X, none);
  const Eigen::VectorXd D = elementDistortion(*disc, Energy::Arap, X);
  const Eigen::VectorXd& a = disc->measures();
  CHECK(m.dMax == Approx(D.maxCoeff()));
  CHECK(m.dAve == Approx(a.dot(D) / a.sum()));
  const double var = a.dot((D.array() - m.dAve).square().matrix()) / a.sum();
  CHECK(m.dDev == Approx(std::sqrt(var)));
  CHECK(m.energy == Approx(a.dot(D) / std::pow(disc->meanEdgeLength(), 2)));

  const Eigen::VectorXd S = facetSmoothness(*disc, Energy::Arap, X);
  const Eigen::VectorXd perElement = elementSmoothness(*disc, S);
  for (size_t f = 0; f < disc->facets().size(); ++f) {
    CHECK(perElement(disc->facets()[f].k) >= S(static_cast<Eigen::Index>(f)));
    CHECK(perElement(disc->facets()[f].l) >= S(static_cast<Eigen::Index>(f)));
  }
  CHECK(perElement.maxCoeff() == Approx(S.maxCoeff()));
  CHECK_THROWS_AS(elementSmoothness(*disc, Eigen::VectorXd::Zero(2)), InvalidParameter);
  CHECK_THROWS_AS(measureDeformation(*disc, Energy::Arap, X.leftCols(1), none), InvalidParameter);
  // A caller's D_k (its maps of these positions) gives the same metrics; a wrong count is refused.
  const ElementMaps maps = elementMaps(*disc, Energy::Arap, X);
  const DeformationMetrics own = measureDeformation(*disc, Energy::Arap, X, none);
  const DeformationMetrics given =
      measureDeformation(*disc, Energy::Arap, X, none, nullptr, nullptr, nullptr, &maps.distortion);
  CHECK(given.dMax == own.dMax);
  CHECK(given.dAve == own.dAve);
  CHECK(given.dDev == own.dDev);
  CHECK(given.energy == own.energy);
  const Eigen::VectorXd doubled = 2.0 * maps.distortion;
  CHECK(
      measureDeformation(*disc, Energy::Arap, X, none, nullptr, nullptr, nullptr, &doubled).dMax ==
      2.0 * own.dMax);
  const Eigen::VectorXd shorter = maps.distortion.head(3);
  CHECK_THROWS_AS(
      measureDeformation(*disc, Energy::Arap, X, none, nullptr, nullptr, nullptr, &shorter),
      InvalidParameter);
  CHECK_THROWS_AS(rmsDistance(X, X.topRows(3)), InvalidParameter);
}

TEST_CASE("regularization removes inverted elements and the distortion spike at a point handle",
          "[deformation][metrics]") {
  // Planar: pushed 1.2 into a bar of height 1; tet: pushed 2 into a box of height 1.
  for (auto [kind, depth] : {std::pair{MeshKind::Planar, 1.2}, std::pair{MeshKind::Tet, 2.0}}) {
    const PushedBar b = pushedBar(kind, depth);
    const Eigen::VectorXd x = bumpWeights(*b.disc, {b.handles[0]}, 0.5, 0.7);
    Eigen::MatrixXd plain;
    const Outcome none = run(b, Regularization::None, 0.0, x, &plain);
    const Outcome uniform = run(b, Regularization::Uniform, 0.5, x, &plain);
    const Outcome nonuniform = run(b, Regularization::Nonuniform, 0.0, x, &plain);
    INFO(toString(kind) << ": inverted " << none.metrics.inverted << " / "
                        << uniform.metrics.inverted << " / " << nonuniform.metrics.inverted
                        << ", D_max near the handle " << none.dMaxNearHandle << " / "
                        << uniform.dMaxNearHandle << " / " << nonuniform.dMaxNearHandle);
    CHECK(none.metrics.inverted > 0);
    CHECK(uniform.metrics.inverted < none.metrics.inverted);
    CHECK(nonuniform.metrics.inverted < none.metrics.inverted);
    CHECK(uniform.dMaxNearHandle < 0.7 * none.dMaxNearHandle);
    CHECK(nonuniform.dMaxNearHandle < 0.7 * none.dMaxNearHandle);
  }
}

TEST_CASE(
    "non-uniform regularization distorts less and moves less than uniform at the same "
    "peak beta (Table 1 pattern)",
    "[deformation][metrics]") {
  for (MeshKind kind : kAllKinds) {
    const PushedBar b = pushedBar(kind, 1.2);
    const double peak = 0.5;
    const Eigen::VectorXd x = bumpWeights(*b.disc, {b.handles[0]}, peak, 0.7);
    REQUIRE(x.maxCoeff() == Approx(peak));
    Eigen::MatrixXd plain;
    const Outcome none = run(b, Regularization::None, 0.0, x, &plain);
    const Outcome uniform = run(b, Regularization::Uniform, peak, x, &plain);
    const Outcome nonuniform = run(b, Regularization::Nonuniform, 0.0, x, &plain);
    INFO(toString(kind) << ": D_ave " << none.metrics.dAve << " / " << uniform.metrics.dAve << " / "
                        << nonuniform.metrics.dAve << ", Dist " << *uniform.metrics.dist << " / "
                        << *nonuniform.metrics.dist);
    CHECK(nonuniform.metrics.dAve < uniform.metrics.dAve);
    CHECK(*nonuniform.metrics.dist < *uniform.metrics.dist);
    // Both still smooth the spike at the handle.
    CHECK(uniform.dMaxNearHandle < none.dMaxNearHandle);
    CHECK(nonuniform.dMaxNearHandle < none.dMaxNearHandle);
  }
}

TEST_CASE("a run's last targets, in the mesh's element order, start the relaxed energy at its "
          "shape",
          "[deformation][metrics]") {
  // The bar of each kind, and a planar strip of more than kLocalityMinElements triangles whose
  // elements are shuffled, which the session stores in its own locality order: lastTargets()
  // maps them back.
  std::vector<std::pair<std::string, PushedBar>> cases;
  for (MeshKind kind : kAllKinds) cases.emplace_back(toString(kind), pushedBar(kind, 0.6));
  cases.emplace_back("shuffled strip", shuffledEnds(makeRectangle(4.0, 1.0, 72, 32), 2.0, 1.0));
  for (const auto& [name, b] : cases) {
    INFO(name);
    const Discretization& disc = *b.disc;
    DeformationOptions o;
    o.energy = Energy::Arap;
    o.regularization = Regularization::Uniform;
    o.beta = 0.5;
    DeformationSession session(disc, o);
    CHECK(session.lastTargets().size() == 0);  // no run yet
    session.setHandles(b.handles);
    session.setTargets(b.targets);
    const DeformationResult r = session.solve(3000, kDefaultTolerance);
    REQUIRE(r.converged);
    const ElementTargets T = session.lastTargets();
    const RegularizationWeights& w = session.regularizationWeights();
    // The targets belong to the run's last shape: with them eq. 3 is the run's last energy.
    const ResidualModel model(disc, Energy::Arap);
    Stacked F;
    model.gradients(r.positions, F);
    REQUIRE(T.rows() == F.rows());
    CHECK(model.energy(F, T, w) == Approx(r.energies.back()).epsilon(1e-12));
    // The relaxation from them reaches the value from the per-element fit, and no higher than
    // where the run stopped.
    const DeformationMetrics fromFit = measureDeformation(disc, Energy::Arap, r.positions, w);
    const DeformationMetrics fromRun =
        measureDeformation(disc, Energy::Arap, r.positions, w, nullptr, nullptr, &T);
    CHECK(fromRun.relaxed);
    CHECK(fromRun.energy == Approx(fromFit.energy).epsilon(1e-9));
    CHECK(fromRun.energy <= r.energies.back());
    const ElementTargets cut = T.topRows(T.rows() - disc.dim());
    CHECK_THROWS_AS(measureDeformation(disc, Energy::Arap, r.positions, w, nullptr, nullptr, &cut),
                    InvalidParameter);
    // New handle targets: nothing to continue, no targets.
    Eigen::MatrixXd moved = b.targets;
    moved(0, 1) += 0.05;
    session.setTargets(moved);
    CHECK(session.lastTargets().size() == 0);
  }
}

TEST_CASE("a run's own per-element fits give the maps its residuals without fitting again",
          "[deformation][metrics]") {
  // As above: the bar of each kind, and a planar strip and a sphere whose elements are shuffled,
  // which the session stores in its own element order.
  std::vector<std::pair<std::string, PushedBar>> cases;
  for (MeshKind kind : kAllKinds) cases.emplace_back(toString(kind), pushedBar(kind, 0.6));
  cases.emplace_back("shuffled strip", shuffledEnds(makeRectangle(4.0, 1.0, 72, 32), 2.0, 0.5));
  cases.emplace_back("shuffled sphere", shuffledEnds(makeSphere(1.0, 72, 36), 0.0, 0.5));
  for (const auto& [name, b] : cases) {
    const Discretization& disc = *b.disc;
    for (Energy energy : {Energy::Arap, Energy::Asap})
      for (Regularization mode : {Regularization::None, Regularization::Uniform})
        for (LocalStep step : {LocalStep::Exact, LocalStep::Reference}) {
          INFO(name << ", " << toString(energy) << ", " << toString(mode) << ", "
                    << toString(step));
          DeformationOptions o;
          o.energy = energy;
          o.regularization = mode;
          o.beta = 0.5;
          o.localStep = step;
          DeformationSession session(disc, o);
          session.setHandles(b.handles);
          session.setTargets(b.targets);
          const DeformationResult r = session.solve(7, kDefaultTolerance);
          const ElementTargets e = session.ownResiduals(r.positions);
          // Own fits: no coupled sweeps (no regularization, or the reference step), and an
          // iterative energy (a linear one, ASAP on planar meshes, keeps no last shape).
          const ResidualModel model(disc, energy);
          const bool own =
              model.iterative() && (mode == Regularization::None || step == LocalStep::Reference);
          if (!own) {
            CHECK(e.size() == 0);
            continue;
          }
          // The same residuals, bit for bit, and so the same maps.
          const auto same = [&](const Eigen::MatrixXd& X, const ElementTargets& own) {
            const Stacked fitted = model.residuals(X);
            return own.rows() == fitted.rows() && own.cols() == fitted.cols() && own == fitted;
          };
          CHECK(same(r.positions, e));
          const ElementMaps a = elementMapsFromResiduals(disc, energy, e);
          const ElementMaps c = elementMaps(disc, energy, r.positions);
          CHECK(a.distortion == c.distortion);
          CHECK(a.smoothness == c.smoothness);
          // Another shape: none.
          Eigen::MatrixXd other = r.positions;
          other(0, 0) += 1e-3;
          CHECK(session.ownResiduals(other).size() == 0);
          CHECK(session.ownResiduals(other.leftCols(1)).size() == 0);
          // Continued, started from a shape, stopped by the time budget: the shape each ends at.
          const DeformationResult resumed = session.resume(3, kDefaultTolerance);
          CHECK(same(resumed.positions, session.ownResiduals(resumed.positions)));
          const DeformationResult from = session.solveFrom(r.positions, 3, kDefaultTolerance);
          CHECK(same(from.positions, session.ownResiduals(from.positions)));
          session.setTimeBudget(1e-9);
          const DeformationResult cut = session.solve(1000, 0.0);
          CHECK(cut.iterations < 1000);
          CHECK(same(cut.positions, session.ownResiduals(cut.positions)));
          session.setTimeBudget(0.0);
          // New targets: none for the old shape until a run.
          Eigen::MatrixXd moved = b.targets;
          moved(0, 1) += 0.05;
          session.setTargets(moved);
          CHECK(session.ownResiduals(cut.positions).size() == 0);
          session.setTargets(b.targets);
          const DeformationResult again = session.solve(7, kDefaultTolerance);
          CHECK(same(again.positions, session.ownResiduals(again.positions)));
          // Coupled targets after a switch to uniform weights: none until a run, and a run with
          // the exact step couples them.
          if (mode == Regularization::None) {
            session.setRegularization(Regularization::Uniform, 0.5);
            CHECK(session.ownResiduals(again.positions).size() == 0);
            const DeformationResult coupled = session.solve(3, kDefaultTolerance);
            CHECK(session.ownResiduals(coupled.positions).size() ==
                  (step == LocalStep::Exact ? 0 : e.size()));
          }
        }
  }
  // Residuals of another size are refused with the shapes named.
  const PushedBar b = pushedBar(MeshKind::Planar, 0.6);
  const ElementTargets cut = ElementTargets::Zero(2, 2);
  CHECK_THROWS_AS(elementMapsFromResiduals(*b.disc, Energy::Arap, cut), InvalidParameter);
}

TEST_CASE("a run that throws leaves no last targets and nothing to continue",
          "[deformation][metrics]") {
  const PushedBar b = pushedBar(MeshKind::Planar, 0.6);
  bool stop = false;
  DeformationOptions o;
  o.energy = Energy::Arap;
  o.regularization = Regularization::Uniform;
  o.beta = 0.5;
  o.progress = [&stop](int iteration, double, double) {
    if (stop && iteration >= 3) throw std::runtime_error("stopped by the caller");
  };
  DeformationSession session(*b.disc, o);
  session.setHandles(b.handles);
  session.setTargets(b.targets);
  REQUIRE(session.solve(3000, kDefaultTolerance).converged);
  REQUIRE(session.lastTargets().size() > 0);
  stop = true;
  CHECK_THROWS_WITH(session.solve(3000, kDefaultTolerance), "stopped by the caller");
  CHECK(session.lastTargets().size() == 0);
  stop = false;
  CHECK(session.resume(3000, kDefaultTolerance).initialGuess != "continued");
}

TEST_CASE("Dist averages over the vertices of the elements only", "[deformation][metrics]") {
  // The bar with as many vertices again that no element uses: Table 1's Dist must not change.
  const auto bar = makeBar(MeshKind::Planar);
  const Eigen::Index n = bar->numVertices();
  Eigen::MatrixXd P = Eigen::MatrixXd::Zero(2 * n, 3);
  P.topLeftCorner(n, 2) = bar->rest();
  P.bottomLeftCorner(n, 2) = bar->rest().rowwise() + Eigen::RowVector2d(50.0, 0.0);
  const Discretization disc(MeshKind::Planar, P, bar->elements());
  const auto w = makeRegularizationWeights(disc, Regularization::None, 0.0);
  const Eigen::MatrixXd rest = disc.rest();
  Eigen::MatrixXd moved = rest;
  moved.topRows(n).rowwise() += Eigen::RowVector2d(0.3, 0.4);  // the strays stay
  const DeformationMetrics m = measureDeformation(disc, Energy::Arap, moved, w, &rest);
  REQUIRE(m.dist.has_value());
  CHECK(*m.dist == Approx(0.5));
  CHECK(rmsDistance(moved, rest) == Approx(0.5 / std::sqrt(2.0)));  // every row, as documented
}
