// Included first: it silences a GCC false positive in OpenMesh before any system header.
#include "test_deformation_fixtures.h"

#include <diffreg/deformation/deformer.h>
#include <diffreg/deformation/system.h>

#include <diffreg/core/error.h>
#include <diffreg/discretization/element_order.h>

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <type_traits>

using namespace diffreg;
using namespace diffreg::testing;

namespace {

double maxAbs(const Eigen::MatrixXd& X) { return X.cwiseAbs().maxCoeff(); }

// `disc` with its elements in a random order (a mesh written with no spatial order).
Discretization scrambledCopy(const Discretization& disc, unsigned seed) {
  std::vector<int> order(static_cast<size_t>(disc.numElements()));
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), std::mt19937(seed));
  return disc.withElementOrder(order);
}

// Every regularization setting of the tests: none, uniform 0.5, nonuniform bump (peak 0.8).
void applyMode(DeformationSession& s, Regularization mode, const Eigen::VectorXd& weights) {
  s.setRegularization(mode, 0.5, mode == Regularization::Nonuniform ? weights : Eigen::VectorXd());
}

// Bends the bar: end 0 fixed, end 1 rotated by `angle` about its centre and lifted.
Eigen::MatrixXd bentTargets(const Discretization& disc, const std::vector<int>& handles,
                            double angle) {
  const int d = disc.dim();
  Eigen::MatrixXd T = rows(disc.rest(), handles);
  const double xMax = disc.rest().col(0).maxCoeff();
  for (Eigen::Index i = 0; i < T.rows(); ++i) {
    if (T(i, 0) < 0.5 * xMax) continue;
    Eigen::RowVectorXd p = T.row(i);
    Eigen::RowVectorXd c = p;
    c(0) = xMax;
    c(1) = 0.5 * (disc.rest().col(1).maxCoeff() + disc.rest().col(1).minCoeff());
    if (d == 3) c(2) = 0.5 * (disc.rest().col(2).maxCoeff() + disc.rest().col(2).minCoeff());
    Eigen::MatrixXd R = Eigen::MatrixXd::Identity(d, d);
    R.topLeftCorner(2, 2) = Eigen::Rotation2Dd(angle).toRotationMatrix();
    T.row(i) = (p - c) * R.transpose() + c;
    T(i, 1) += 0.25 * xMax;
  }
  return T;
}

}  // namespace

TEST_CASE("handles at their rest positions give the rest shape and zero energy",
          "[deformation][session]") {
  for (MeshKind kind : kAllKinds) {
    const auto disc = makeBar(kind);
    const std::vector<int> handles = bothEnds(*disc);
    const Eigen::VectorXd x = bumpWeights(*disc, handles, 0.8, 1.0);
    for (Energy energy : kAllEnergies)
      for (Regularization mode :
           {Regularization::None, Regularization::Uniform, Regularization::Nonuniform}) {
        INFO(toString(kind) << " " << toString(energy) << " " << toString(mode));
        DeformationOptions o;
        o.energy = energy;
        DeformationSession s(*disc, o);
        applyMode(s, mode, x);
        s.setHandles(handles);
        const DeformationResult r = s.solve();
        CHECK(maxAbs(r.positions - disc->rest()) < 1e-9);
        CHECK(r.energies.back() < 1e-18);
        // Exact after the first global step: converged there, not iterating on rounding.
        CHECK(r.converged);
        CHECK(r.criterion == 0.0);
        CHECK(r.iterations <= 2);  // ASAP's initial guess, then one step
      }
  }
}

TEST_CASE("a first global step from the rest shape reports its criterion as not measured",
          "[deformation][session]") {
  for (MeshKind kind : kAllKinds)
    for (LocalStep step : {LocalStep::Exact, LocalStep::Reference}) {
      INFO(toString(kind) << " " << toString(step));
      const auto disc = makeBar(kind);
      const std::vector<int> handles = bothEnds(*disc);
      DeformationOptions o;
      o.localStep = step;
      o.regularization = Regularization::Uniform;
      o.beta = 0.3;
      DeformationSession s(*disc, o);
      s.setHandles(handles);
      s.setTargets(bentTargets(*disc, handles, 0.6));
      std::vector<double> reported;
      s.setProgress([&reported](int, double, double criterion) { reported.push_back(criterion); });
      const DeformationResult one = s.solve(1, 1e-7);
      REQUIRE(reported.size() == 1u);
      CHECK_FALSE(one.converged);
      // From the rest shape nothing precedes the first step; from ASAP's guess it is measured.
      const bool fromRest = one.initialGuess == "rest";
      CHECK(std::isnan(one.criterion) == fromRest);
      CHECK(std::isnan(reported[0]) == fromRest);
      reported.clear();
      const DeformationResult two = s.solve(2, 1e-7);
      REQUIRE(reported.size() == 2u);
      CHECK(std::isnan(reported[0]) == fromRest);
      CHECK(reported[1] > 0.0);
      CHECK(two.criterion == reported[1]);
    }
}

TEST_CASE("all handles moved by one rigid motion give that motion", "[deformation][session]") {
  for (MeshKind kind : kAllKinds) {
    const auto disc = makeBar(kind);
    const int d = disc->dim();
    const std::vector<int> handles = bothEnds(*disc);
    const Eigen::RowVectorXd shift = Eigen::RowVectorXd::LinSpaced(d, 0.5, -0.25);
    for (Energy energy : {Energy::Arap, Energy::Asap, Energy::Larap}) {
      // lARAP is exact for infinitesimal rotations only.
      const double angle = energy == Energy::Larap ? 1e-3 : 0.7;
      const Eigen::MatrixXd expected = transform(disc->rest(), 1.0, rotation(d, angle), shift);
      DeformationOptions o;
      o.energy = energy;
      o.regularization = Regularization::Uniform;
      o.beta = 0.3;
      DeformationSession s(*disc, o);
      s.setHandles(handles);
      s.setTargets(rows(expected, handles));
      const DeformationResult r = s.solve(300, 0.0);
      INFO(toString(kind) << " " << toString(energy));
      if (energy == Energy::Larap) {
        // The rotated handles are off the linear model by O(angle^2) = 1e-6.
        CHECK(maxAbs(r.positions - expected) < 1e-5);
        CHECK(r.energies.back() < 1e-10);
      } else if (kind != MeshKind::Surface) {
        CHECK(maxAbs(r.positions - expected) < 1e-8);
        CHECK(r.energies.back() < 1e-16);
      } else {
        // Per-triangle residuals do not see a vertex moving along the normal to first order,
        // so local/global converges slowly on thin shells: close, and the energy keeps falling.
        CHECK(maxAbs(r.positions - expected) < 0.03);  // bar length 4
        CHECK(r.energies.back() < 1e-4 * r.energies.front());
      }
    }
  }
}

// A session refers to its discretization, so a temporary one must not compile.
static_assert(!std::is_constructible_v<DeformationSession, Discretization&&>);
static_assert(!std::is_constructible_v<DeformationSession, Discretization&&, DeformationOptions>);
static_assert(std::is_constructible_v<DeformationSession, const Discretization&>);

TEST_CASE("uniform regularization with the default options regularizes, as the front ends do",
          "[deformation][session]") {
  const auto disc = makeBar(MeshKind::Planar);
  const std::vector<int> handles = bothEnds(*disc);
  Eigen::MatrixXd targets = rows(disc->rest(), handles);
  for (Eigen::Index i = 0; i < targets.rows(); ++i)
    if (targets(i, 0) > 1.0) targets(i, 1) += 1.5;  // the far end lifted
  const auto solveWith = [&](const DeformationOptions& o) {
    DeformationSession s(*disc, o);
    s.setHandles(handles);
    s.setTargets(targets);
    return s.solve().positions;
  };
  DeformationOptions uniform;
  uniform.regularization = Regularization::Uniform;
  DeformationOptions explicitBeta = uniform;
  explicitBeta.beta = kDefaultUniformBeta;  // the deform filter's, the editor's and Python's
  const Eigen::MatrixXd plain = solveWith(DeformationOptions{});
  const Eigen::MatrixXd byDefault = solveWith(uniform);
  CHECK(maxAbs(byDefault - plain) > 1e-2);
  CHECK(maxAbs(byDefault - solveWith(explicitBeta)) == 0.0);
}

TEST_CASE("planar ASAP reproduces a similarity of the handles exactly", "[deformation][session]") {
  const auto disc = makeBar(MeshKind::Planar);
  const std::vector<int> handles = {nearestVertex(*disc, Eigen::RowVector2d(0, 0)),
                                    nearestVertex(*disc, Eigen::RowVector2d(4, 1))};
  const Eigen::MatrixXd expected =
      transform(disc->rest(), 1.7, rotation(2, 2.0), Eigen::RowVector2d(-3, 5));
  DeformationOptions o;
  o.energy = Energy::Asap;
  const DeformationResult r = deform(*disc, o, handles, rows(expected, handles));
  CHECK(maxAbs(r.positions - expected) < 1e-10);
  CHECK(r.energies.size() == 1);
  CHECK(r.energies[0] < 1e-20);
}

TEST_CASE(
    "beta = 0 and all-zero weights equal the unregularized solve; equal weights equal "
    "uniform beta",
    "[deformation][session]") {
  for (MeshKind kind : kAllKinds) {
    const auto disc = makeBar(kind);
    const std::vector<int> handles = bothEnds(*disc);
    const Eigen::MatrixXd targets = bentTargets(*disc, handles, 0.6);
    for (Energy energy : kAllEnergies) {
      INFO(toString(kind) << " " << toString(energy));
      DeformationOptions o;
      o.energy = energy;
      // The same 30 plain iterations for every variant: equal systems give equal iterates
      // (an accelerated run could settle in another of the flat surface ARAP's minima).
      o.acceleration = Acceleration::None;
      o.maxIterations = 30;
      o.relTolerance = 0.0;
      DeformationSession s(*disc, o);
      s.setHandles(handles);
      s.setTargets(targets);
      const Eigen::MatrixXd plain = s.solve().positions;
      s.setBeta(0.0);
      CHECK(maxAbs(s.solve().positions - plain) < 1e-12);
      s.setWeights(Eigen::VectorXd::Zero(disc->numVertices()));
      CHECK(maxAbs(s.solve().positions - plain) < 1e-12);
      s.setBeta(0.35);
      const Eigen::MatrixXd uniform = s.solve().positions;
      CHECK(maxAbs(uniform - plain) > 1e-4);  // the regularizer does something
      s.setWeights(Eigen::VectorXd::Constant(disc->numVertices(), 0.35));
      CHECK(maxAbs(s.solve().positions - uniform) < 1e-10);
    }
  }
}

TEST_CASE("with beta = 0 the ARAP system matrix is the cotangent stiffness K",
          "[deformation][session]") {
  for (MeshKind kind : kAllKinds) {
    const auto disc = makeBar(kind);
    DeformationSession s(*disc);
    INFO(toString(kind));
    const SparseMatrix diff = s.systemMatrix() - disc->stiffness();
    CHECK(diff.cwiseAbs().sum() < 1e-12 * disc->stiffness().cwiseAbs().sum());
    s.setBeta(0.0);
    CHECK((s.systemMatrix() - disc->stiffness()).cwiseAbs().sum() <
          1e-12 * disc->stiffness().cwiseAbs().sum());
  }
}

TEST_CASE("the gradient from the residuals, C (F - t), is A x - C t on the free unknowns",
          "[deformation][system]") {
  for (MeshKind kind : kAllKinds)
    for (Energy energy : kAllEnergies)
      for (Regularization mode : {Regularization::None, Regularization::Nonuniform}) {
        INFO(toString(kind) << " " << toString(energy) << " " << toString(mode));
        const auto disc = makeBar(kind);
        const ResidualModel model(*disc, energy);
        RegularizedSystem system(model);
        const std::vector<int> handles = bothEnds(*disc);
        system.setHandles(handles);
        system.setWeights(makeRegularizationWeights(
            *disc, mode, 0.5, Eigen::VectorXd::LinSpaced(disc->numVertices(), 0.1, 0.9)));
        // Some shape and some targets, not related to each other.
        Eigen::MatrixXd X = disc->rest();
        for (Eigen::Index v = 0; v < X.rows(); ++v)
          X.row(v) += 0.1 * Eigen::RowVectorXd::LinSpaced(X.cols(), std::sin(v), std::cos(3 * v));
        Stacked t, F;
        Eigen::MatrixXd b;
        model.targets(X, t);
        t *= 0.9;
        model.gradients(X, F);
        const Eigen::MatrixXd x = model.toUnknowns(X);
        system.rightHandSide(t, b);
        Eigen::MatrixXd expected = system.matrix() * x - b, g;
        system.zeroFixed(expected);
        system.residualGradient(F, t, g);
        REQUIRE(g.rows() == expected.rows());
        CHECK((g - expected).cwiseAbs().maxCoeff() <= 1e-10 * expected.cwiseAbs().maxCoeff());
        CHECK(expected.cwiseAbs().maxCoeff() > 0.0);
      }
}

TEST_CASE("the rest right-hand side A x_rest is C t for the rest shape's own targets",
          "[deformation][system]") {
  // Every residual vanishes at the rest shape, so its targets are the rest blocks L_k x_rest
  // and C t = A x_rest: the first global step of every handle move reads the product. Far from
  // the origin (1e6 away, the bar 1 long) both carry the rounding of the edges themselves, eps
  // times the offset, and agree to that.
  for (MeshKind kind : kAllKinds)
    for (Energy energy : kAllEnergies)
      for (Regularization mode :
           {Regularization::None, Regularization::Uniform, Regularization::Nonuniform})
        for (double offset : {0.0, 1e6})
          for (bool reserve : {true, false}) {
            INFO(toString(kind) << " " << toString(energy) << " " << toString(mode) << " offset "
                                << offset << " reserve " << reserve);
            auto disc = makeBar(kind);
            if (offset != 0.0) {
              Eigen::MatrixXd moved = disc->rest();
              moved.array() += offset;
              disc = std::make_unique<Discretization>(disc->kind(), moved, disc->elements());
            }
            const ResidualModel model(*disc, energy);
            RegularizedSystem system(model, defaultSolverBackend(), reserve);
            system.setHandles(bothEnds(*disc));
            system.setWeights(makeRegularizationWeights(
                *disc, mode, 0.5, Eigen::VectorXd::LinSpaced(disc->numVertices(), 0.1, 0.9)));
            Stacked t;
            model.targets(disc->rest(), t);
            Eigen::MatrixXd expected, b;
            system.rightHandSide(t, expected);
            system.restRightHandSide(b);
            REQUIRE(b.rows() == expected.rows());
            REQUIRE(b.cols() == expected.cols());
            const double scale = system.matrix().cwiseAbs().sum() / system.matrix().rows();
            CHECK((b - expected).cwiseAbs().maxCoeff() <= 1e-12 * scale * (1.0 + offset));
            if (offset != 0.0) continue;
            // And the rest shape is what the handles at their rest positions give back.
            const Eigen::MatrixXd x =
                system.solveRightHandSide(b, rows(disc->rest(), bothEnds(*disc)));
            CHECK((x - disc->rest()).cwiseAbs().maxCoeff() < 1e-10);
          }
}

TEST_CASE("C t added colour by colour in parallel equals the serial sum over the elements",
          "[deformation][system]") {
  // Meshes of 5-9K elements: generated in rows, they scatter in groups of consecutive
  // elements; with their elements scrambled, by single elements, and then the sphere's poles
  // (96 triangles around a vertex) take the colouring past its 64 colours of bit masks. No two
  // groups of a colour may share an unknown (checked directly: a lost or doubled share from two
  // threads would be rare), and the sum is the serial one.
  std::vector<std::unique_ptr<Discretization>> meshes;
  meshes.push_back(std::make_unique<Discretization>(makeRectangle(4.0, 1.0, 120, 30)));
  meshes.push_back(std::make_unique<Discretization>(makeSphere(1.0, 96, 48)));
  meshes.push_back(std::make_unique<Discretization>(makeTetBox(4.0, 1.0, 1.0, 24, 6, 6)));
  for (size_t i = 1; i < 3; ++i)
    meshes.push_back(std::make_unique<Discretization>(scrambledCopy(*meshes[i], 3)));
  const std::vector<bool> grouped = {true, true, true, false, false};
  for (size_t mesh = 0; mesh < meshes.size(); ++mesh)
    for (Energy energy : {Energy::Arap, Energy::Asap}) {
      const auto& disc = meshes[mesh];
      INFO(toString(disc->kind()) << " " << mesh << " " << toString(energy));
      const ResidualModel model(*disc, energy);
      RegularizedSystem system(model);
      system.setWeights(
          makeRegularizationWeights(*disc, Regularization::Nonuniform, 0.0,
                                    Eigen::VectorXd::LinSpaced(disc->numVertices(), 0.1, 0.9)));
      Eigen::MatrixXd X = disc->rest();
      for (Eigen::Index v = 0; v < X.rows(); ++v)
        X.row(v) += 0.05 * Eigen::RowVectorXd::LinSpaced(X.cols(), std::sin(v), std::cos(3 * v));
      Stacked t;
      model.targets(X, t);  // then moved off them (planar ASAP's targets are constant zeros)
      for (Eigen::Index i = 0; i < t.rows(); ++i)
        for (Eigen::Index j = 0; j < t.cols(); ++j) t(i, j) += 0.1 * std::sin(7.0 * i + j);
      Eigen::MatrixXd b;
      system.rightHandSide(t, b);
      // The serial reference: tau_k = w_k t_k + sum_l w_kl (t_k - t_l), b += L_k^T tau_k.
      const Regularizer& reg = system.regularizer();
      const ResidualModel::Operators L = model.operators();
      const int r = model.rows(), c = model.columns();
      Eigen::MatrixXd expected = Eigen::MatrixXd::Zero(model.numUnknowns(), c);
      for (int k = 0; k < disc->numElements(); ++k) {
        Eigen::MatrixXd tau = reg.elementWeight()(k) * t.middleRows(k * r, r);
        for (int g = reg.facetBegin(k); g < reg.facetEnd(k); ++g)
          tau += reg.neighbourWeight(g) *
                 (t.middleRows(k * r, r) - t.middleRows(reg.neighbour(g) * r, r));
        for (int j = 0; j < model.localSize(); ++j)
          for (int a = 0; a < r; ++a) expected.row(model.unknown(k, j)) += L(k, a, j) * tau.row(a);
      }
      REQUIRE(b.rows() == expected.rows());
      CHECK(maxAbs(b - expected) <= 1e-12 * maxAbs(expected));
      // Each element in one group; an unknown's last group of the same colour is its own.
      std::vector<int> groupOf(static_cast<size_t>(disc->numElements()), -1);
      std::vector<int> owner(static_cast<size_t>(model.numUnknowns()), -1);
      const auto colours = system.scatterGroups();
      bool disjoint = true;
      int group = 0, largest = 0;
      for (size_t c = 0; c < colours.size(); ++c) {
        const int colourStart = group;
        for (const std::vector<int>& members : colours[c]) {
          largest = std::max(largest, static_cast<int>(members.size()));
          for (int k : members) {
            CHECK(groupOf[static_cast<size_t>(k)] == -1);
            groupOf[static_cast<size_t>(k)] = group;
            for (int j = 0; j < model.localSize(); ++j) {
              int& o = owner[static_cast<size_t>(model.unknown(k, j))];
              if (o >= colourStart && o != group) disjoint = false;
              o = group;
            }
          }
          ++group;
        }
      }
      CHECK(disjoint);
      CHECK(std::count(groupOf.begin(), groupOf.end(), -1) == 0);
      CHECK((largest > 1) == grouped[mesh]);
      if (mesh == 3) CHECK(colours.size() > 64);
      CHECK(maxAbs(expected) > 0.0);
    }
}

TEST_CASE("the system's pattern is that of its element and facet blocks",
          "[deformation][system]") {
  // Meshes of more unknowns than one thread's share of the columns (kPatternGrain), so that with
  // two or more threads the columns are built in parts; with its elements scrambled, each part
  // of the sphere reads elements from all over the mesh. Every layout: one unknown per vertex
  // (ARAP, ASAP on surfaces and tets), two (ASAP on planar meshes) and three (lARAP on surfaces
  // and tets), with and without the facet couplings.
  std::vector<std::pair<std::unique_ptr<Discretization>, std::vector<Energy>>> meshes;
  const std::vector<Energy> all = {Energy::Arap, Energy::Asap, Energy::Larap};
  meshes.emplace_back(std::make_unique<Discretization>(makeSphere(1.0, 96, 48)), all);
  meshes.emplace_back(std::make_unique<Discretization>(makeRectangle(4.0, 1.0, 150, 40)), all);
  meshes.emplace_back(std::make_unique<Discretization>(makeTetBox(4.0, 1.0, 1.0, 32, 12, 12)),
                      std::vector<Energy>{Energy::Arap, Energy::Asap});
  meshes.emplace_back(std::make_unique<Discretization>(makeTetBox(4.0, 1.0, 1.0, 20, 8, 8)),
                      std::vector<Energy>{Energy::Larap});
  meshes.emplace_back(std::make_unique<Discretization>(scrambledCopy(*meshes[0].first, 11)), all);
  for (const auto& [disc, energies] : meshes)
    for (Energy energy : energies)
      for (bool couplings : {false, true}) {
        INFO(toString(disc->kind()) << " " << toString(energy) << " couplings " << couplings);
        const ResidualModel model(*disc, energy);
        REQUIRE(model.numUnknowns() > kPatternGrain);
        RegularizedSystem system(model, defaultSolverBackend(), couplings);
        const SparseMatrix& A = system.matrix();
        // The reference, column by column: every unknown that shares an element with the
        // column's, or sits in an element across a facet from one of its elements.
        std::vector<std::vector<int>> expected(static_cast<size_t>(model.numUnknowns()));
        const auto addPairs = [&](int k, int l) {
          for (int i = 0; i < model.localSize(); ++i)
            for (int j = 0; j < model.localSize(); ++j) {
              expected[static_cast<size_t>(model.unknown(k, i))].push_back(model.unknown(l, j));
              expected[static_cast<size_t>(model.unknown(l, j))].push_back(model.unknown(k, i));
            }
        };
        for (int k = 0; k < disc->numElements(); ++k) addPairs(k, k);
        if (couplings)
          for (const Facet& f : disc->facets()) addPairs(f.k, f.l);
        bool same = A.outerSize() == model.numUnknowns();
        for (Eigen::Index p = 0; p < A.outerSize() && same; ++p) {
          std::vector<int>& column = expected[static_cast<size_t>(p)];
          std::sort(column.begin(), column.end());
          column.erase(std::unique(column.begin(), column.end()), column.end());
          same =
              A.outerIndexPtr()[p + 1] - A.outerIndexPtr()[p] == static_cast<int>(column.size()) &&
              std::equal(column.begin(), column.end(), A.innerIndexPtr() + A.outerIndexPtr()[p]);
        }
        CHECK(same);
      }
}

TEST_CASE("the ARAP energy never increases across iterations when beta = 0",
          "[deformation][session]") {
  for (MeshKind kind : kAllKinds) {
    const auto disc = makeBar(kind);
    const std::vector<int> handles = bothEnds(*disc);
    DeformationSession s(*disc);
    s.setHandles(handles);
    s.setTargets(bentTargets(*disc, handles, 1.2));
    const DeformationResult r = s.solve(30, 0.0);
    INFO(toString(kind) << " initial guess " << r.initialGuess);
    CHECK(r.initialGuess == (kind == MeshKind::Planar ? "asap" : "rest"));
    REQUIRE(r.energies.size() >= 3);
    CHECK(r.energies.back() < r.energies.front());
    for (size_t i = 1; i < r.energies.size(); ++i)
      CHECK(r.energies[i] <= r.energies[i - 1] * (1 + 1e-12));
  }
}

TEST_CASE("scaling the mesh and the handle motion by 100 scales the result by 100",
          "[deformation][session]") {
  for (MeshKind kind : kAllKinds) {
    const auto disc = makeBar(kind), big = makeBar(kind, 100.0);
    const std::vector<int> handles = bothEnds(*disc);
    const Eigen::MatrixXd targets = bentTargets(*disc, handles, 0.8);
    const Eigen::VectorXd x = bumpWeights(*disc, handles, 0.9, 1.0);
    for (Energy energy : kAllEnergies)
      for (Regularization mode :
           {Regularization::None, Regularization::Uniform, Regularization::Nonuniform}) {
        INFO(toString(kind) << " " << toString(energy) << " " << toString(mode));
        DeformationOptions o;
        o.energy = energy;
        o.regularization = mode;
        o.beta = 0.5;
        if (mode == Regularization::Nonuniform) o.weights = x;
        o.maxIterations = 5;
        const DeformationResult a = deform(*disc, o, handles, targets);
        const DeformationResult b = deform(*big, o, handles, 100.0 * targets);
        CHECK(maxAbs(b.positions - 100.0 * a.positions) < 1e-9 * maxAbs(b.positions));
        CHECK(b.energies.back() == Approx(a.energies.back()).epsilon(1e-9).margin(1e-20));
      }
  }
}

TEST_CASE(
    "moving targets refactorizes nothing, new weights refactorize numerically, new "
    "handles analyze again",
    "[deformation][session]") {
  for (MeshKind kind : kAllKinds)
    for (Energy energy : kAllEnergies) {
      const auto disc = makeBar(kind);
      const std::vector<int> handles = bothEnds(*disc);
      DeformationOptions o;
      o.energy = energy;
      o.maxIterations = 3;
      DeformationSession s(*disc, o);
      s.setHandles(handles);
      s.setTargets(bentTargets(*disc, handles, 0.3));
      s.solve();
      // ARAP on planar meshes owns a second factorization: its ASAP initial guess.
      const int systems = energy == Energy::Arap && kind == MeshKind::Planar ? 2 : 1;
      INFO(toString(kind) << " " << toString(energy));
      CHECK(s.stats().symbolic == systems);
      CHECK(s.stats().numeric == systems);

      SolverStats before = s.stats();
      s.setTargets(bentTargets(*disc, handles, 0.5));
      s.solve();
      CHECK((s.stats() - before).symbolic == 0);
      CHECK((s.stats() - before).numeric == 0);
      CHECK((s.stats() - before).solves >= 1);

      before = s.stats();
      s.setWeights(bumpWeights(*disc, handles, 0.7, 1.0));
      s.solve();
      s.setBeta(0.2);
      s.solve();
      s.setRegularization(Regularization::None, 0.0);
      s.solve();
      CHECK((s.stats() - before).symbolic == 0);
      CHECK((s.stats() - before).numeric == 3 * systems);

      before = s.stats();
      std::vector<int> fewer = handles;
      fewer.pop_back();
      s.setHandles(fewer);  // the targets at rest: the first step is exact, the run ends there
      s.solve();
      CHECK((s.stats() - before).symbolic == systems);
      CHECK((s.stats() - before).numeric == systems);
      before = s.stats();
      fewer.pop_back();
      s.setHandles(fewer);
      s.setTargets(bentTargets(*disc, fewer, 0.3));  // moved: iterations
      s.solve();
      CHECK((s.stats() - before).symbolic == systems);
      CHECK((s.stats() - before).numeric == systems);
    }
}

TEST_CASE("a component left free is a clear singular-system error", "[deformation][session]") {
  // Two separate bars; handles only on the first.
  const auto one = makeBar(MeshKind::Planar);
  const int n = one->numVertices();
  Eigen::MatrixXd P(2 * n, 2);
  P << one->rest(), one->rest().rowwise() + Eigen::RowVector2d(0, 3);
  Eigen::MatrixXi E(2 * one->numElements(), 3);
  E << one->elements(), one->elements().array() + n;
  const Discretization two(MeshKind::Planar, P, E);
  const std::vector<int> handles = bothEnds(*one);
  for (Energy energy : kAllEnergies) {
    INFO(toString(energy));
    DeformationOptions o;
    o.energy = energy;
    DeformationSession s(two, o);
    s.setHandles(handles);
    CHECK_THROWS_AS(s.solve(), SingularSystem);
    CHECK_THROWS_WITH(s.solve(), Catch::Matchers::Contains("mesh component 1") &&
                                     Catch::Matchers::Contains("has 0 handle vertices"));
  }
}

TEST_CASE(
    "a component whose every vertex is a handle needs no handle points, even with "
    "beta = 1",
    "[deformation][session]") {
  // A surface of two components: the tube bar held at both ends, and a flat strip (the planar
  // bar at z = 0, beside it) held at every vertex and moved. With beta = 1 a component needs 4
  // non-coplanar handle points, which the flat strip cannot have; held everywhere it needs none.
  const auto tube = makeBar(MeshKind::Surface);
  const auto strip = makeBar(MeshKind::Planar);
  const int n = tube->numVertices(), ns = strip->numVertices();
  Eigen::MatrixXd P = Eigen::MatrixXd::Zero(n + ns, 3);
  P.topRows(n) = tube->rest();
  P.bottomRows(ns).leftCols(2) = strip->rest();
  P.bottomRows(ns).col(1).array() += 5.0;
  Eigen::MatrixXi E(tube->numElements() + strip->numElements(), 3);
  E << tube->elements(), strip->elements().array() + n;
  const Discretization two(MeshKind::Surface, P, E);
  std::vector<int> handles = bothEnds(*tube);
  for (int v = n; v < n + ns; ++v) handles.push_back(v);
  Eigen::MatrixXd targets = rows(P, handles);
  targets.bottomRows(ns).rowwise() += Eigen::RowVector3d(0.5, 0.25, 0.125);
  for (double beta : {0.5, 1.0}) {
    INFO("beta " << beta);
    DeformationOptions o;
    o.regularization = Regularization::Uniform;
    o.beta = beta;
    DeformationSession s(two, o);
    s.setHandles(handles);
    s.setTargets(targets);
    const DeformationResult r = s.solve();
    CHECK(r.converged);
    CHECK((rows(r.positions, handles) - targets).cwiseAbs().maxCoeff() == 0.0);
    // The tube, held at its ends at rest, stays at rest.
    CHECK((r.positions.topRows(n) - tube->rest()).cwiseAbs().maxCoeff() < 1e-9);
  }
}

TEST_CASE("too few handle points for the energy or for beta = 1 is a singular-system error",
          "[deformation][session]") {
  const auto planar = makeBar(MeshKind::Planar);
  const int corner = nearestVertex(*planar, Eigen::RowVector2d(0, 0));
  const int other = nearestVertex(*planar, Eigen::RowVector2d(4, 0));
  const int third = nearestVertex(*planar, Eigen::RowVector2d(4, 1));
  auto session = [&](Energy energy, const std::vector<int>& handles, double beta) {
    DeformationOptions o;
    o.energy = energy;
    o.regularization = Regularization::Uniform;
    o.beta = beta;
    auto s = std::make_unique<DeformationSession>(*planar, o);
    s->setHandles(handles);
    return s;
  };
  // One point pins ARAP and Dirichlet; ASAP and lARAP in 2D need two.
  CHECK_NOTHROW(session(Energy::Arap, {corner}, 0.5)->solve());
  CHECK_NOTHROW(session(Energy::Dirichlet, {corner}, 0.5)->solve());
  CHECK_THROWS_WITH(session(Energy::Asap, {corner}, 0.5)->solve(),
                    Catch::Matchers::Contains("asap needs 2 distinct handle points"));
  CHECK_THROWS_WITH(session(Energy::Larap, {corner}, 0.5)->solve(),
                    Catch::Matchers::Contains("larap needs 2 distinct handle points"));
  CHECK_NOTHROW(session(Energy::Larap, {corner, other}, 0.5)->solve());
  // ARAP with one point starts from the rest shape (the ASAP guess would be singular).
  CHECK(session(Energy::Arap, {corner}, 0.5)->solve().initialGuess == "rest");
  // beta = 1: S alone needs 3 affinely independent points in 2D.
  CHECK_THROWS_WITH(session(Energy::Arap, {corner, other}, 1.0)->solve(),
                    Catch::Matchers::Contains("with beta = 1 on the whole component needs 3 "
                                              "non-collinear handle points"));
  CHECK_NOTHROW(session(Energy::Arap, {corner, other, third}, 1.0)->solve());

  // Surfaces and tets: lARAP needs 3 non-collinear points.
  for (MeshKind kind : {MeshKind::Surface, MeshKind::Tet}) {
    const auto disc = makeBar(kind);
    DeformationOptions o;
    o.energy = Energy::Larap;
    DeformationSession s(*disc, o);
    const int a = nearestVertex(*disc, disc->rest().row(0));
    const std::vector<int> end = endVertices(*disc, 1, 1e-9);
    s.setHandles({a, end[0]});
    INFO(toString(kind));
    CHECK_THROWS_WITH(s.solve(), Catch::Matchers::Contains("3 non-collinear handle points"));
  }
}

TEST_CASE("bad session input is a clear error", "[deformation][session]") {
  const auto disc = makeBar(MeshKind::Surface);
  const int n = disc->numVertices();
  DeformationSession s(*disc);
  CHECK_THROWS_MATCHES(s.solve(), InvalidParameter,
                       Catch::Matchers::Message("deformation: no handles set"));
  CHECK_THROWS_AS(s.setHandles({}), InvalidParameter);
  CHECK_THROWS_MATCHES(s.setHandles({0, n}), InvalidParameter,
                       Catch::Matchers::Message("deformation: handle vertex " + std::to_string(n) +
                                                " is out of range [0, " + std::to_string(n) + ")"));
  CHECK_THROWS_WITH(s.setHandles({3, 3}), Catch::Matchers::Contains("listed twice"));
  s.setHandles(bothEnds(*disc));
  CHECK_THROWS_AS(s.setTargets(Eigen::MatrixXd::Zero(2, 3)), InvalidParameter);
  Eigen::MatrixXd t = rows(disc->rest(), bothEnds(*disc));
  t(0, 0) = std::nan("");
  CHECK_THROWS_WITH(s.setTargets(t), Catch::Matchers::Contains("not finite"));
  CHECK_THROWS_WITH(s.setBeta(1.01), Catch::Matchers::Contains("outside [0, 1]"));
  CHECK_THROWS_AS(s.setBeta(-0.5), InvalidParameter);
  CHECK_THROWS_AS(s.setWeights(Eigen::VectorXd::Zero(n - 1)), InvalidParameter);
  CHECK_THROWS_AS(s.setWeights(Eigen::VectorXd::Constant(n, -0.1)), InvalidParameter);
  // Weights with another mode would be ignored: an error, in the session and in its options.
  const Eigen::VectorXd ones = Eigen::VectorXd::Ones(n);
  CHECK_THROWS_WITH(s.setRegularization(Regularization::Uniform, 0.5, ones),
                    Catch::Matchers::Contains("regularization is uniform") &&
                        Catch::Matchers::Contains("only with nonuniform"));
  DeformationOptions withWeights;
  withWeights.weights = ones;  // regularization None by default
  CHECK_THROWS_WITH(DeformationSession(*disc, withWeights),
                    Catch::Matchers::Contains("regularization is none"));
  CHECK_THROWS_AS(s.solve(0, 1e-6), InvalidParameter);
  // The session still works after rejected input.
  CHECK(maxAbs(s.solve().positions - disc->rest()) < 1e-9);
}

TEST_CASE("vertices without elements stay at their rest positions", "[deformation][session]") {
  const auto bar = makeBar(MeshKind::Planar);
  Eigen::MatrixXd P(bar->numVertices() + 1, 2);
  P << bar->rest(), Eigen::RowVector2d(7, 7);
  const Discretization disc(MeshKind::Planar, P, bar->elements());
  const std::vector<int> handles = bothEnds(*bar);
  DeformationOptions o;
  const DeformationResult r = deform(disc, o, handles, bentTargets(*bar, handles, 0.4));
  CHECK(r.positions.allFinite());
  CHECK(r.positions.row(bar->numVertices()) == Eigen::RowVector2d(7, 7));
}

TEST_CASE(
    "a mesh whose elements are stored in scrambled order deforms as it would in locality "
    "order, converges where the mesh in order does, and gets its weights back in its order",
    "[deformation][session]") {
  // Large enough for the locality order (element_order.h); generated in rows, so the mesh in
  // order keeps its own.
  const std::vector<Mesh> meshes = {makeRectangle(4.0, 1.0, 96, 24), makeSphere(1.0, 48, 48),
                                    makeTetBox(4.0, 1.0, 1.0, 24, 6, 6)};
  for (const Mesh& mesh : meshes) {
    const Discretization ordered(mesh);
    const Discretization scrambled = scrambledCopy(ordered, 5);
    const Discretization sorted = scrambled.withElementOrder(mortonElementOrder(scrambled));
    INFO(toString(ordered.kind()));
    REQUIRE(localityElementOrder(ordered).empty());
    REQUIRE(localityElementOrder(sorted).empty());
    REQUIRE(!localityElementOrder(scrambled).empty());

    const double span = ordered.rest().col(0).maxCoeff() - ordered.rest().col(0).minCoeff();
    std::vector<int> handles = endVertices(ordered, 0, 0.1 * span);
    for (int v : endVertices(ordered, 1, 0.1 * span)) handles.push_back(v);
    DeformationOptions o;
    o.regularization = Regularization::Nonuniform;
    o.weights = bumpWeights(ordered, handles, 0.9, 0.3 * span);
    const Eigen::MatrixXd targets = bentTargets(ordered, handles, 0.2);

    // The same computation as on the mesh stored in Morton order: the same numbers.
    o.maxIterations = 15;
    o.relTolerance = 0.0;
    const DeformationResult a = deform(scrambled, o, handles, targets);
    const DeformationResult b = deform(sorted, o, handles, targets);
    CHECK(a.positions == b.positions);
    CHECK(a.energies == b.energies);

    // The sweeps' order is not the mesh's, so the path differs from the mesh in order. Both
    // converge, on the planar and tet bars to the same energy. The closed sphere pulled at its
    // caps has stationary points apart (0.247 and 0.265 at a 1e-12 tolerance, in the two
    // orders): surface ARAP's flat valleys, where any change of the sweeps' order can lead
    // elsewhere.
    o.maxIterations = 3000;
    o.relTolerance = kDefaultTolerance;
    const DeformationResult c = deform(scrambled, o, handles, targets);
    const DeformationResult d = deform(ordered, o, handles, targets);
    CHECK(c.converged);
    CHECK(d.converged);
    if (ordered.kind() != MeshKind::Surface)
      CHECK(c.energies.back() == Approx(d.energies.back()).epsilon(1e-4));

    const DeformationSession s(scrambled, o);
    const RegularizationWeights expected =
        makeRegularizationWeights(scrambled, o.regularization, o.beta, o.weights);
    CHECK(s.regularizationWeights().element == expected.element);
    CHECK(s.regularizationWeights().facet == expected.facet);
  }
}

TEST_CASE("a solve that is not finite names the thinnest element, in the mesh's numbering",
          "[deformer][hostile]") {
  // A strip of 2500 unit squares; the lower triangle of square 5 is split at a point 1e-13
  // above the midpoint of its bottom edge, over a sliver.
  const int columns = 2500;
  Eigen::MatrixXd P(2 * (columns + 1) + 1, 3);
  for (int i = 0; i <= columns; ++i) {
    P.row(i) << i, 0, 0;
    P.row(columns + 1 + i) << i, 1, 0;
  }
  const int s = 2 * (columns + 1), split = 5;
  P.row(s) << split + 0.5, 1e-13, 0;
  std::vector<Eigen::Vector3i> faces;
  for (int i = 0; i < columns; ++i) {
    const int a = i, b = i + 1, c = columns + 2 + i, d = columns + 1 + i;
    if (i == split) {
      faces.emplace_back(a, s, c);
      faces.emplace_back(s, b, c);
    } else {
      faces.emplace_back(a, b, c);
    }
    faces.emplace_back(a, c, d);
  }
  faces.emplace_back(split, split + 1, s);  // the sliver
  // Out of order: the regularized session then orders them for locality (kLocalityMinElements).
  std::shuffle(faces.begin(), faces.end(), std::mt19937(3));
  const Eigen::Vector3i sliver(split, split + 1, s);
  const auto at = std::find(faces.begin(), faces.end(), sliver) - faces.begin();
  Eigen::MatrixXi F(static_cast<Eigen::Index>(faces.size()), 3);
  for (size_t k = 0; k < faces.size(); ++k) F.row(static_cast<Eigen::Index>(k)) = faces[k];
  const Discretization disc(MeshKind::Planar, P, F);
  const std::vector<int> handles = {0, columns + 1, columns, 2 * columns + 1};
  Eigen::MatrixXd targets(4, 2);
  targets << 0, 0, 0, 1, columns, 2, columns, 3;
  REQUIRE(F.rows() >= kLocalityMinElements);
  REQUIRE(!localityElementOrder(disc).empty());
  for (const Regularization r : {Regularization::None, Regularization::Uniform}) {
    INFO(toString(r));  // uniform: the session orders the elements for locality
    DeformationOptions o;
    o.regularization = r;
    CHECK_THROWS_AS(deform(disc, o, handles, targets), NonFiniteSolution);
    CHECK_THROWS_WITH(deform(disc, o, handles, targets),
                      Catch::Contains("the thinnest triangle is " + std::to_string(at) +
                                      " (0-based; area / longest edge^2 5e-14"));
  }
}
