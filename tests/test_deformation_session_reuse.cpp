// A session reuses what does not change between solves (factorization, the right-hand side of
// the rest targets): after any sequence of changes it solves exactly as a fresh session with the
// final settings.
// Included first: it silences a GCC false positive in OpenMesh before any system header.
#include "test_deformation_fixtures.h"

#include <diffreg/deformation/deformer.h>

#include <catch2/catch.hpp>

using namespace diffreg;
using namespace diffreg::testing;

namespace {

// The far end lifted by `h` times the bar length, the near end fixed.
Eigen::MatrixXd liftedTargets(const Discretization& disc, const std::vector<int>& handles,
                              double h) {
  Eigen::MatrixXd T = rows(disc.rest(), handles);
  const double xMax = disc.rest().col(0).maxCoeff();
  for (Eigen::Index i = 0; i < T.rows(); ++i)
    if (T(i, 0) > 0.5 * xMax) T(i, 1) += h * xMax;
  return T;
}

DeformationResult solveFresh(const Discretization& disc, const DeformationOptions& o,
                             const std::vector<int>& handles, const Eigen::MatrixXd& targets,
                             Regularization mode, double beta, const Eigen::VectorXd& weights) {
  DeformationSession s(disc, o);
  s.setRegularization(mode, beta, mode == Regularization::Nonuniform ? weights : Eigen::VectorXd());
  s.setHandles(handles);
  s.setTargets(targets);
  return s.solve(2, 0.0);
}

}  // namespace

TEST_CASE("a session after new weights, handles and targets solves as a fresh one",
          "[deformation][session]") {
  for (MeshKind kind : kAllKinds)
    for (Energy energy : kAllEnergies)
      for (bool reserve : {true, false}) {
        const auto disc = makeBar(kind);
        const std::vector<int> handles = bothEnds(*disc);
        const Eigen::VectorXd bump = bumpWeights(*disc, handles, 0.7, 1.0);
        DeformationOptions o;
        o.energy = energy;
        o.reserveRegularization = reserve;
        INFO(toString(kind) << " " << toString(energy) << (reserve ? " reserved" : ""));

        DeformationSession s(*disc, o);
        s.setHandles(handles);
        s.setTargets(liftedTargets(*disc, handles, 0.2));
        const DeformationResult plain = s.solve(2, 0.0);
        // Each change must reach the next solve: new weights change C and A, new targets only
        // the handle positions, new handles the partition.
        struct Step {
          Regularization mode;
          double beta, lift;
          bool fewerHandles;
        };
        std::vector<int> current = handles;
        for (const Step& step : {Step{Regularization::Uniform, 0.4, 0.2, false},
                                 Step{Regularization::Nonuniform, 0.0, 0.3, false},
                                 Step{Regularization::Nonuniform, 0.0, 0.3, true},
                                 Step{Regularization::None, 0.0, 0.2, true}}) {
          const bool nonuniform = step.mode == Regularization::Nonuniform;
          s.setRegularization(step.mode, step.beta, nonuniform ? bump : Eigen::VectorXd());
          if (step.fewerHandles && current.size() == handles.size()) {
            current.pop_back();
            s.setHandles(current);
          }
          const Eigen::MatrixXd targets = liftedTargets(*disc, current, step.lift);
          s.setTargets(targets);
          const DeformationResult reused = s.solve(2, 0.0);
          const DeformationResult fresh =
              solveFresh(*disc, o, current, targets, step.mode, step.beta, bump);
          REQUIRE(reused.energies.size() == fresh.energies.size());
          CHECK((reused.positions - fresh.positions).cwiseAbs().maxCoeff() <= 1e-12);
          for (size_t i = 0; i < fresh.energies.size(); ++i)
            CHECK(std::abs(reused.energies[i] - fresh.energies[i]) <=
                  1e-12 * (1.0 + std::abs(fresh.energies[i])));
        }
        // Back to the first settings: the first result again.
        s.setRegularization(Regularization::None, 0.0);
        s.setHandles(handles);
        s.setTargets(liftedTargets(*disc, handles, 0.2));
        CHECK((s.solve(2, 0.0).positions - plain.positions).cwiseAbs().maxCoeff() <= 1e-12);
      }
}
