// Included first: it silences a GCC false positive in OpenMesh before any system header.
#include "test_deformation_fixtures.h"

#include <diffreg/deformation/energy.h>
#include <diffreg/deformation/residual_model.h>

#include <diffreg/core/error.h>

#include <catch2/catch.hpp>

#include <random>

using namespace diffreg;
using namespace diffreg::testing;

TEST_CASE("energy and regularization names parse and unknown names list the valid ones",
          "[deformation][energy]") {
  for (Energy e : kAllEnergies) CHECK(parseEnum<Energy>(toString(e)) == e);
  for (Regularization r :
       {Regularization::None, Regularization::Uniform, Regularization::Nonuniform})
    CHECK(parseEnum<Regularization>(toString(r)) == r);
  CHECK_THROWS_MATCHES(parseEnum<Energy>("arapp"), InvalidParameter,
                       Catch::Matchers::Message("energy: unknown energy 'arapp' (valid: arap, "
                                                "asap, larap, dirichlet)"));
  CHECK_THROWS_MATCHES(
      parseEnum<Regularization>("smooth"), InvalidParameter,
      Catch::Matchers::Message(
          "regularization: unknown mode 'smooth' (valid: none, uniform, nonuniform)"));
}

TEST_CASE("every residual vanishes at the rest shape", "[deformation][energy]") {
  for (MeshKind kind : kAllKinds) {
    const auto disc = makeBar(kind);
    for (Energy energy : kAllEnergies) {
      INFO(toString(kind) << " " << toString(energy));
      const ResidualModel model(*disc, energy);
      CHECK(model.residuals(disc->rest()).cwiseAbs().maxCoeff() < 1e-12);
    }
  }
}

TEST_CASE("rigid motions leave ARAP and ASAP residuals at zero and lARAP at second order",
          "[deformation][energy]") {
  for (MeshKind kind : kAllKinds) {
    const auto disc = makeBar(kind);
    const int d = disc->dim();
    const Eigen::RowVectorXd shift = Eigen::RowVectorXd::LinSpaced(d, 0.3, -0.7);
    const Eigen::MatrixXd big = transform(disc->rest(), 1.0, rotation(d, 0.8), shift);
    INFO(toString(kind));
    CHECK(ResidualModel(*disc, Energy::Arap).residuals(big).cwiseAbs().maxCoeff() < 1e-10);
    CHECK(ResidualModel(*disc, Energy::Asap).residuals(big).cwiseAbs().maxCoeff() < 1e-10);
    // Dirichlet is translation invariant only.
    const Eigen::MatrixXd moved = disc->rest().rowwise() + shift;
    CHECK(ResidualModel(*disc, Energy::Dirichlet).residuals(moved).cwiseAbs().maxCoeff() < 1e-10);
    CHECK(ResidualModel(*disc, Energy::Dirichlet).residuals(big).cwiseAbs().maxCoeff() > 0.1);
    // lARAP: residual O(angle^2).
    for (double angle : {1e-2, 1e-3}) {
      const Eigen::MatrixXd small = transform(disc->rest(), 1.0, rotation(d, angle), shift);
      const double r = ResidualModel(*disc, Energy::Larap).residuals(small).cwiseAbs().maxCoeff();
      CHECK(r < angle * angle);
      CHECK(r > 0.1 * angle * angle);
    }
  }
}

TEST_CASE("the ASAP residual vanishes for similarities and the 3D one for scaled rotations",
          "[deformation][energy]") {
  for (MeshKind kind : kAllKinds) {
    const auto disc = makeBar(kind);
    const int d = disc->dim();
    const Eigen::MatrixXd X =
        transform(disc->rest(), 2.5, rotation(d, -1.1), Eigen::RowVectorXd::Constant(d, 4.0));
    INFO(toString(kind));
    CHECK(ResidualModel(*disc, Energy::Asap).residuals(X).cwiseAbs().maxCoeff() < 1e-10);
    CHECK(ResidualModel(*disc, Energy::Arap).residuals(X).cwiseAbs().maxCoeff() > 0.5);
  }
}

TEST_CASE("the ARAP residual of a reflected planar element keeps det R > 0",
          "[deformation][energy]") {
  const auto disc = makeBar(MeshKind::Planar);
  Eigen::MatrixXd X = disc->rest();
  X.col(0) *= -1.0;  // mirror: every element inverted
  const ResidualModel model(*disc, Energy::Arap);
  const Eigen::VectorXd D = model.distortion(model.residuals(X));
  // Closest rotation to diag(-1, 1) is the identity or a half turn: ||F - R||^2 = 4.
  CHECK(D.minCoeff() == Approx(4.0));
  CHECK(D.maxCoeff() == Approx(4.0));
  CHECK(countInverted(*disc, X) == disc->numElements());
}

TEST_CASE("regularization weights: modes, means over element and facet vertices, bad input",
          "[deformation][energy]") {
  const auto disc = makeBar(MeshKind::Tet);
  const int n = disc->numVertices();
  const auto none = makeRegularizationWeights(*disc, Regularization::None, 0.7);
  CHECK(none.element.size() == disc->numElements());
  CHECK(none.facet.size() == static_cast<Eigen::Index>(disc->facets().size()));
  CHECK(none.element.cwiseAbs().maxCoeff() == 0.0);
  CHECK(none.facet.cwiseAbs().maxCoeff() == 0.0);
  const auto uni = makeRegularizationWeights(*disc, Regularization::Uniform, 0.7);
  CHECK(uni.element.minCoeff() == 0.7);
  CHECK(uni.facet.maxCoeff() == 0.7);

  const Eigen::VectorXd x = disc->rest().col(0) / disc->rest().col(0).maxCoeff();
  const auto w = makeRegularizationWeights(*disc, Regularization::Nonuniform, 0.0, x);
  const int k = disc->numElements() / 2;
  double mean = 0.0;
  for (int i = 0; i < 4; ++i) mean += x(disc->elements()(k, i)) / 4.0;
  CHECK(w.element(k) == Approx(mean));
  const Facet& f = disc->facets()[3];
  CHECK(w.facet(3) == Approx((x(f.vertices[0]) + x(f.vertices[1]) + x(f.vertices[2])) / 3.0));

  CHECK_THROWS_AS(makeRegularizationWeights(*disc, Regularization::Uniform, 1.5), InvalidParameter);
  CHECK_THROWS_AS(makeRegularizationWeights(*disc, Regularization::Uniform, -0.1),
                  InvalidParameter);
  CHECK_THROWS_AS(makeRegularizationWeights(*disc, Regularization::Uniform, std::nan("")),
                  InvalidParameter);
  CHECK_THROWS_MATCHES(
      makeRegularizationWeights(*disc, Regularization::Nonuniform, 0.0, Eigen::VectorXd::Zero(3)),
      InvalidParameter,
      Catch::Matchers::Message("regularization: 3 vertex weights for a mesh of " +
                               std::to_string(n) + " vertices"));
  Eigen::VectorXd bad = Eigen::VectorXd::Zero(n);
  bad(5) = 1.2;
  CHECK_THROWS_WITH(makeRegularizationWeights(*disc, Regularization::Nonuniform, 0.0, bad),
                    Catch::Matchers::Contains("vertex 5"));
}

TEST_CASE("the total energy is unchanged when the mesh and its motion are scaled together",
          "[deformation][energy]") {
  for (MeshKind kind : kAllKinds) {
    const auto disc = makeBar(kind), big = makeBar(kind, 100.0);
    Eigen::MatrixXd X = disc->rest();
    X.col(1) += 0.2 * X.col(0).array().square().matrix();  // a bend
    const auto w = makeRegularizationWeights(*disc, Regularization::Uniform, 0.4);
    const auto wBig = makeRegularizationWeights(*big, Regularization::Uniform, 0.4);
    for (Energy energy : kAllEnergies) {
      INFO(toString(kind) << " " << toString(energy));
      const ResidualModel a(*disc, energy), b(*big, energy);
      const double Ea = a.energy(a.residuals(X), w), Eb = b.energy(b.residuals(100.0 * X), wBig);
      CHECK(Ea > 0.0);
      CHECK(Eb == Approx(Ea).epsilon(1e-9));
    }
  }
}

TEST_CASE("each energy's batched 3D fit is its fit of each element", "[deformation][energy]") {
  // EnergyModel::fitBatch, which the exact local step calls for a few elements at a time:
  // ARAP and ASAP give their own loops; on surfaces and tets, a degenerate C included (the SVD
  // fallbacks). Both must be the element's fit().
  std::mt19937 rng(29);
  std::normal_distribution<double> normal;
  for (Energy energy : kAllEnergies) {
    if (!isIterative(energy, MeshKind::Surface) && !isIterative(energy, MeshKind::Tet)) continue;
    const EnergyModel& model = energyModel(energy);
    for (bool surface : {true, false}) {
      Eigen::Matrix3d C[kFitBatch];
      Eigen::Vector3d n[kFitBatch];
      const Eigen::Vector3d* normalOf[kFitBatch];
      double weight[kFitBatch], stored[kFitBatch][9];
      double* out[kFitBatch];
      for (int i = 0; i < kFitBatch; ++i) {
        n[i] = Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
        for (int j = 0; j < 9; ++j) C[i](j) = normal(rng);
        if (i == 3) C[i].col(1) = 2.0 * C[i].col(0);  // rank 2 (and rank 1 in the plane)
        if (i == 3) C[i].col(2) = -C[i].col(0);
        weight[i] = 0.5 + i % 3;
        normalOf[i] = surface ? &n[i] : nullptr;
        out[i] = stored[i];
      }
      model.fitBatch(kFitBatch, C, weight, normalOf, out);
      for (int i = 0; i < kFitBatch; ++i) {
        INFO(toString(energy) << (surface ? " surface" : " tet") << " element " << i);
        const Eigen::Matrix3d T = model.fit(C[i], weight[i], normalOf[i]);
        CHECK((Eigen::Map<const Eigen::Matrix3d>(stored[i]) - T).cwiseAbs().maxCoeff() < 1e-12);
      }
    }
  }
}
