// The exact local step (local_step.h): a block coordinate descent on eq. 3 in the targets that
// never raises it, and the per-element fit candidate tried where it can win.
#include "test_deformation_fixtures.h"

#include <diffreg/deformation/local_step.h>
#include <diffreg/deformation/system.h>

#include <catch2/catch.hpp>

#include <cmath>

using namespace diffreg;
using namespace diffreg::testing;

namespace {

// The bar bent smoothly: each point turned about the z axis by an angle growing along x.
Eigen::MatrixXd bend(const Eigen::MatrixXd& rest, double amount) {
  Eigen::MatrixXd X = rest;
  for (Eigen::Index v = 0; v < rest.rows(); ++v) {
    const double a = amount * rest(v, 0) / 4.0;
    const double x = rest(v, 0), y = rest(v, 1);
    X(v, 0) = std::cos(a) * x - std::sin(a) * y;
    X(v, 1) = std::sin(a) * x + std::cos(a) * y;
  }
  return X;
}

struct Setup {
  std::unique_ptr<Discretization> disc;
  std::unique_ptr<ResidualModel> model;
  std::unique_ptr<RegularizedSystem> system;
  explicit Setup(MeshKind kind) : disc(makeBar(kind)) {
    model = std::make_unique<ResidualModel>(*disc, Energy::Arap);
    system = std::make_unique<RegularizedSystem>(*model);
    system->setWeights(makeRegularizationWeights(*disc, Regularization::Uniform, 0.5));
  }
  const Regularizer& reg() const { return system->regularizer(); }
  double step(const Eigen::MatrixXd& X, const Stacked* previous, Stacked& t,
              LocalStepScratch& scratch, double reference = 0.0) const {
    return localStep(*model, reg(), LocalStep::Exact, X, previous, t, scratch, reference);
  }
  // The targets at X settled by `steps` more exact steps after the first (from the per-element
  // fit); their energy.
  double settle(const Eigen::MatrixXd& X, int steps, Stacked& t, LocalStepScratch& scratch) const {
    double E = step(X, nullptr, t, scratch);
    for (int i = 0; i < steps; ++i) E = step(X, &t, t, scratch);
    return E;
  }
  double energy(const Eigen::MatrixXd& X, const Stacked& t) const {
    Stacked F;
    model->gradients(X, F);
    return model->energy(F, t, reg().weights());
  }
};

// Stored blocks are F_k^T and T_k^T: element e's block of S as a d x d matrix.
Eigen::MatrixXd block(const Stacked& S, int e, int d) {
  return Eigen::MatrixXd(S.block(static_cast<Eigen::Index>(e) * d, 0, d, d).transpose());
}

// Element k's blend of the exact step, computed one element at a time (local_step.h):
// C_k = w_k F_k + sum_l w_kl (F_k - F_l + T_l) and weight_k = w_k + sum_l w_kl, with neighbour
// l's target taken from targetsOf(l).
struct ElementBlend {
  Eigen::MatrixXd C;
  double weight;
};
template <class TargetsOf>
ElementBlend blendOf(const Regularizer& reg, const Stacked& F, int k, int d,
                     const TargetsOf& targetsOf) {
  const Eigen::MatrixXd Fk = block(F, k, d);
  ElementBlend b{reg.elementWeight()(k) * Fk, reg.elementWeight()(k)};
  for (int g = reg.facetBegin(k); g < reg.facetEnd(k); ++g) {
    const int l = reg.neighbour(g);
    b.C += reg.neighbourWeight(g) * (Fk - block(F, l, d) + block(targetsOf(l), l, d));
    b.weight += reg.neighbourWeight(g);
  }
  return b;
}

// EnergyModel::fit of ARAP for element k of `disc`, one element at a time.
Eigen::MatrixXd arapFit(const Discretization& disc, const Eigen::MatrixXd& C, double weight,
                        int k) {
  const EnergyModel& arap = energyModel(Energy::Arap);
  if (disc.dim() == 2) return arap.fit(Eigen::Matrix2d(C), weight);
  if (disc.kind() != MeshKind::Surface) return arap.fit(Eigen::Matrix3d(C), weight, nullptr);
  const Eigen::Vector3d n = disc.normals().row(k).transpose();
  return arap.fit(Eigen::Matrix3d(C), weight, &n);
}

}  // namespace

TEST_CASE(
    "the exact local step never raises eq. 3 from the previous targets, whether or not "
    "it tries the per-element fit",
    "[deformation][local_step]") {
  for (MeshKind kind : kAllKinds) {
    INFO(toString(kind));
    Setup s(kind);
    const Eigen::MatrixXd X0 = bend(s.disc->rest(), 0.6), X1 = bend(s.disc->rest(), 0.601);
    LocalStepScratch scratch;
    Stacked t0, t;
    const double E0 = s.step(X0, nullptr, t0, scratch);
    const double kept = s.energy(X1, t0);
    for (bool fitWon : {true, false}) {
      scratch.fitWon = fitWon;
      scratch.fitSkipped = 0;
      const double E = s.step(X1, &t0, t, scratch, E0);
      CHECK(scratch.fitSkipped == (fitWon ? 0 : 1));  // both ways are taken
      CHECK(E <= kept * (1 + 1e-14));
      CHECK(E == Approx(s.energy(X1, t)).epsilon(1e-12));
    }
  }
}

TEST_CASE(
    "the per-element fit is skipped only near the reference after a loss, and tried "
    "again after kFitRetry skips or a large turn",
    "[deformation][local_step]") {
  for (MeshKind kind : kAllKinds) {
    INFO(toString(kind));
    Setup s(kind);
    const Eigen::MatrixXd X0 = bend(s.disc->rest(), 0.6);
    LocalStepScratch scratch;
    Stacked t0, t;
    const double E0 = s.settle(X0, 10, t0, scratch);
    // A small change of the shape: the previous targets stay within the gap of E0.
    const Eigen::MatrixXd X1 = bend(s.disc->rest(), 0.601);
    REQUIRE(std::abs(s.energy(X1, t0) - E0) <= kFitCandidateGap * E0);
    scratch.fitWon = false;
    scratch.fitSkipped = 0;
    for (int i = 1; i <= kFitRetry; ++i) {
      s.step(X1, &t0, t, scratch, E0);
      CHECK(scratch.fitSkipped == i);
    }
    s.step(X1, &t0, t, scratch, E0);
    CHECK(scratch.fitSkipped == 0);  // tried

    // The whole bar turned by a quarter: far from the reference, so the fit is tried even
    // right after a loss, and it wins: the step ends where the step without a reference does.
    const Eigen::MatrixXd X2 = X0 * rotation(s.disc->dim(), 0.5 * M_PI).transpose();
    REQUIRE(std::abs(s.energy(X2, t0) - E0) > kFitCandidateGap * E0);
    scratch.fitWon = false;
    scratch.fitSkipped = 0;
    const double turned = s.step(X2, &t0, t, scratch, E0);
    CHECK(scratch.fitWon);
    LocalStepScratch fresh;
    Stacked t2;
    CHECK(turned == s.step(X2, &t0, t2, fresh));
    // A rigid turn: one step from the fit comes back near the settled energy of the unturned
    // shape, which the stale targets are far above.
    CHECK(turned < E0 * (1 + kFitCandidateGap));
  }
}

TEST_CASE(
    "settled exact targets are each the block minimizer of eq. 3, element by element "
    "(the sweeps fit elements in batches)",
    "[deformation][local_step]") {
  // T_k = fit(C_k, weight_k) with C_k = w_k F_k + sum_l w_kl (F_k - F_l + T_l) and weight_k =
  // w_k + sum_l w_kl (local_step.h), evaluated here one element at a time with
  // EnergyModel::fit, independently of the batched sweeps.
  for (MeshKind kind : kAllKinds) {
    INFO(toString(kind));
    Setup s(kind);
    const Eigen::MatrixXd X = bend(s.disc->rest(), 0.6);
    LocalStepScratch scratch;
    Stacked t;
    s.settle(X, 300, t, scratch);
    const Stacked& F = scratch.F;
    const int d = s.disc->dim();
    double worst = 0.0;
    for (int k = 0; k < s.disc->numElements(); ++k) {
      const ElementBlend b = blendOf(s.reg(), F, k, d, [&](int) -> const Stacked& { return t; });
      const Eigen::MatrixXd fitted = arapFit(*s.disc, b.C, b.weight, k);
      worst = std::max(worst, (fitted - block(t, k, d)).cwiseAbs().maxCoeff());
    }
    CHECK(worst < 1e-8);
  }
}

TEST_CASE(
    "over-relaxed sweeps settle a bend's targets further than Gauss-Seidel sweeps, never raise "
    "eq. 3, and settle where Gauss-Seidel does",
    "[deformation][local_step]") {
  for (MeshKind kind : kAllKinds)
    for (Energy energy : {Energy::Arap, Energy::Asap}) {
      const Setup s(kind);
      const ResidualModel model(*s.disc, energy);
      if (!model.iterative()) continue;  // planar ASAP is linear: no sweeps
      INFO(toString(kind) << " " << toString(energy));
      Stacked F, start;
      model.gradients(bend(s.disc->rest(), 0.6), F);
      model.fitTargets(F, start);  // every element fitted on its own: the smooth part unsettled
      const RegularizationWeights& w = s.reg().weights();
      const auto sweep = [&](bool overRelaxed, int count) {
        Stacked t = start;
        double E = model.energy(F, t, w);
        for (int i = 0; i < count; ++i) {
          sweepTargets(model, s.reg(), F, t, 1, overRelaxed);
          const double next = model.energy(F, t, w);
          CHECK(next <= E * (1 + 1e-14));
          E = next;
        }
        return E;
      };
      const double settled = sweep(false, 400);
      const double plain = sweep(false, 4), relaxed = sweep(true, 4);
      // What four sweeps leave to gain: over-relaxation leaves well under half of it.
      CHECK(relaxed - settled < 0.5 * (plain - settled));
      CHECK(sweep(true, 400) == Approx(settled).epsilon(1e-10));
    }
}

TEST_CASE(
    "an over-relaxed update that would raise its element's terms is replaced by the block "
    "minimizer: no element's terms rise in a sweep from scattered targets",
    "[deformation][local_step]") {
  // Targets fitted element by element to unrelated matrices, the sweep at the bar shrunk to a
  // twentieth: the blends C_k are then dominated by the neighbours' disagreeing targets, and
  // many over-relaxed fits overshoot by turns that raise weight ||T||^2 - 2 tr(T^T C_k) (with
  // the guard removed this test fails for every mesh kind). Each element's terms are
  // checked with its blend as the sweep saw it (a colour's neighbours are in other colours:
  // those swept before it hold their new targets), independently of the batched sweep.
  for (MeshKind kind : kAllKinds) {
    INFO(toString(kind));
    const Setup s(kind);
    const int d = s.disc->dim();
    Stacked F, t0;
    s.model->gradients(s.disc->rest(), F);
    for (Eigen::Index i = 0; i < F.size(); ++i) F(i) = std::sin(7.0 * i);
    s.model->fitTargets(F, t0);
    s.model->gradients(0.05 * bend(s.disc->rest(), 0.6), F);
    Stacked t1 = t0;
    sweepTargets(*s.model, s.reg(), F, t1, 1, true);

    const Regularizer& reg = s.reg();
    std::vector<int> colour(static_cast<size_t>(s.disc->numElements()));
    for (size_t c = 0; c < reg.colours().size(); ++c)
      for (int k : reg.colours()[c]) colour[static_cast<size_t>(k)] = static_cast<int>(c);
    int overshoots = 0, rises = 0;
    for (int k = 0; k < s.disc->numElements(); ++k) {
      const ElementBlend b = blendOf(reg, F, k, d, [&](int l) -> const Stacked& {
        return colour[static_cast<size_t>(l)] < colour[static_cast<size_t>(k)] ? t1 : t0;
      });
      const auto terms = [&](const Eigen::MatrixXd& T) {
        return b.weight * T.squaredNorm() - 2.0 * (T.transpose() * b.C).trace();
      };
      const Eigen::MatrixXd before = block(t0, k, d), after = block(t1, k, d);
      // The over-relaxed fit itself (local_step.h: omega from the neighbours' share).
      const double rho = std::min(kMaxCoupling, 1.0 - reg.elementWeight()(k) / b.weight);
      const double omega = 2.0 / (1.0 + std::sqrt(1.0 - rho * rho));
      const Eigen::MatrixXd relaxed =
          arapFit(*s.disc, omega * b.C - (omega - 1.0) * b.weight * before, b.weight, k);
      const double scale = b.weight * before.squaredNorm() + std::abs(terms(before));
      if (terms(relaxed) > terms(before) + 1e-12 * scale) ++overshoots;
      if (terms(after) > terms(before) + 1e-12 * scale) ++rises;
    }
    INFO(overshoots << " of " << s.disc->numElements() << " over-relaxed fits overshoot");
    CHECK(overshoots > 0);  // the case the guard is for does arise here
    CHECK(rises == 0);
  }
}
