// HandleBasis: the first global step of a handle move as a superposition of precomputed
// responses. Moves whose handle groups each move affinely give the positions of the solve
// without the basis (to round-off) and spend no back-substitution on that step; other moves,
// and coupled energies, are solved as before.
// Included first: it silences a GCC false positive in OpenMesh before any system header.
#include "test_deformation_fixtures.h"

#include <diffreg/deformation/deformer.h>
#include <diffreg/deformation/handle_basis.h>

#include <catch2/catch.hpp>

using namespace diffreg;
using namespace diffreg::testing;

namespace {

// The far end turned by `angle` about its centre and lifted by `lift`; the near end stays.
Eigen::MatrixXd turnedTargets(const Discretization& disc, const std::vector<int>& handles,
                              double angle, double lift) {
  Eigen::MatrixXd T = rows(disc.rest(), handles);
  const double xMid = 0.5 * (disc.rest().col(0).maxCoeff() + disc.rest().col(0).minCoeff());
  std::vector<int> far;
  for (Eigen::Index i = 0; i < T.rows(); ++i)
    if (T(i, 0) > xMid) far.push_back(static_cast<int>(i));
  Eigen::MatrixXd F = rows(T, far);
  const Eigen::RowVectorXd centre = F.colwise().mean();
  Eigen::RowVectorXd shift = Eigen::RowVectorXd::Zero(T.cols());
  shift(1) = lift;
  F = transform(F.rowwise() - centre, 1.0, rotation(static_cast<int>(T.cols()), angle),
                centre + shift);
  for (size_t i = 0; i < far.size(); ++i) T.row(far[i]) = F.row(static_cast<Eigen::Index>(i));
  return T;
}

double relativeDifference(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return (a - b).cwiseAbs().maxCoeff() / b.cwiseAbs().maxCoeff();
}

}  // namespace

TEST_CASE("handle groups are the connected parts of the handle set", "[deformation][basis]") {
  for (MeshKind kind : kAllKinds) {
    INFO(toString(kind));
    const auto disc = makeBar(kind);
    const double tol = 1e-9 * disc->boundingBoxDiagonal();
    CHECK(HandleBasis(*disc, bothEnds(*disc)).groups() == 2);
    CHECK(HandleBasis(*disc, endVertices(*disc, 0, tol)).groups() == 1);
    // Two single vertices far apart, and one of them joined by its end: three groups.
    std::vector<int> ids = endVertices(*disc, 1, tol);
    const int mid = nearestVertex(*disc, 0.5 * (disc->rest().row(ids[0]) +
                                                disc->rest().row(endVertices(*disc, 0, tol)[0])));
    ids.push_back(mid);
    ids.push_back(endVertices(*disc, 0, tol)[0]);
    CHECK(HandleBasis(*disc, ids).groups() == 3);
  }
}

TEST_CASE("with the handle basis a session moves as without it, without the first solve",
          "[deformation][basis]") {
  for (MeshKind kind : kAllKinds)
    for (Energy energy : kAllEnergies) {
      const auto disc = makeBar(kind);
      const std::vector<int> handles = bothEnds(*disc);
      DeformationOptions o;
      o.energy = energy;
      INFO(toString(kind) << " " << toString(energy));
      DeformationSession plain(*disc, o), fast(*disc, o);
      fast.setHandleBasis(true);
      const Eigen::VectorXd bump = bumpWeights(*disc, handles, 0.7, 1.0);
      for (DeformationSession* s : {&plain, &fast}) {
        s->setWeights(bump);
        s->setHandles(handles);
        s->setTargets(turnedTargets(*disc, handles, 0.3, 0.2));
        s->solve(3, 0.0);  // factorizes (and builds the basis)
      }
      // Turned, lifted and then a non-affine move (one handle vertex alone nudged), each as an
      // iterative run and as its first global step.
      Eigen::MatrixXd nudged = turnedTargets(*disc, handles, -0.2, 0.4);
      nudged(0, 1) += 0.05;
      const std::vector<Eigen::MatrixXd> moves = {turnedTargets(*disc, handles, 0.6, -0.3),
                                                  turnedTargets(*disc, handles, 0.0, 0.5),
                                                  nudged};
      // Coupled layouts (2D ASAP, lARAP) are not separable: no basis, same solves. Planar ARAP
      // starts from the ASAP solution, not from the rest solve.
      const bool separable = !(energy == Energy::Larap || (kind == MeshKind::Planar &&
                                                           energy != Energy::Dirichlet));
      for (size_t m = 0; m < moves.size(); ++m) {
        INFO("move " << m);
        const bool affine = m < 2;
        for (int iterations : {1, 4}) {
          plain.setTargets(moves[m]);
          fast.setTargets(moves[m]);
          const SolverStats p0 = plain.stats(), f0 = fast.stats();
          const DeformationResult a = plain.solve(iterations, 0.0);
          const DeformationResult b = fast.solve(iterations, 0.0);
          REQUIRE(a.iterations == b.iterations);
          CHECK(relativeDifference(b.positions, a.positions) < 1e-10);
          for (size_t i = 0; i < handles.size(); ++i)
            CHECK(b.positions.row(handles[i]) ==
                  moves[m].row(static_cast<Eigen::Index>(i)).leftCols(disc->dim()));
          const int saved = (plain.stats() - p0).solves - (fast.stats() - f0).solves;
          CHECK(saved == (separable && affine ? 1 : 0));
          CHECK((fast.stats() - f0).numeric == 0);
        }
      }
      // New weights, then new handles: the basis is built again and serves affine moves.
      auto agree = [&](const Eigen::MatrixXd& targets) {
        plain.setTargets(targets);
        fast.setTargets(targets);
        const SolverStats p0 = plain.stats(), f0 = fast.stats();
        const DeformationResult a = plain.solve(1, 0.0);
        const DeformationResult b = fast.solve(1, 0.0);
        CHECK(relativeDifference(b.positions, a.positions) < 1e-10);
        return (plain.stats() - p0).solves - (fast.stats() - f0).solves;
      };
      const Eigen::VectorXd other = bumpWeights(*disc, handles, 0.4, 0.5);
      plain.setWeights(other);
      fast.setWeights(other);
      agree(moves[0]);                                // builds the basis again
      CHECK(agree(moves[1]) == (separable ? 1 : 0));  // uses it
      std::vector<int> fewer = endVertices(*disc, 0, 1e-9 * disc->boundingBoxDiagonal());
      const std::vector<int> far = endVertices(*disc, 1, 1e-9 * disc->boundingBoxDiagonal());
      fewer.insert(fewer.end(), far.begin(), far.begin() + static_cast<long>(far.size() / 2));
      plain.setHandles(fewer);
      fast.setHandles(fewer);
      agree(turnedTargets(*disc, fewer, 0.4, 0.3));
      CHECK(agree(turnedTargets(*disc, fewer, -0.3, 0.1)) == (separable ? 1 : 0));
    }
}

TEST_CASE("the handle basis tells a non-affine move at any scale and distance from the origin",
          "[deformation][basis]") {
  for (MeshKind kind : {MeshKind::Surface, MeshKind::Tet})
    for (double scale : {1e-9, 1.0, 1e6})
      for (double offset : {0.0, 1e3}) {
        INFO(toString(kind) << " scale " << scale << " offset " << offset);
        auto bar = makeBar(kind, scale);
        Eigen::MatrixXd P = bar->rest();
        P.array() += offset * scale;
        const Discretization disc(kind, P, bar->elements());
        const std::vector<int> handles = bothEnds(disc);
        DeformationSession plain(disc), fast(disc);
        fast.setHandleBasis(true);
        for (DeformationSession* s : {&plain, &fast}) {
          s->setHandles(handles);
          s->solve(1, 0.0);
        }
        const double size = disc.boundingBoxDiagonal();
        for (double nudge : {0.0, 1e-6, 1e-3}) {
          INFO("nudge " << nudge);
          Eigen::MatrixXd T = turnedTargets(disc, handles, 0.3, 0.2 * size);
          T(0, 1) += nudge * size;
          plain.setTargets(T);
          fast.setTargets(T);
          const SolverStats p0 = plain.stats(), f0 = fast.stats();
          const DeformationResult a = plain.solve(1, 0.0);
          const DeformationResult b = fast.solve(1, 0.0);
          const int saved = (plain.stats() - p0).solves - (fast.stats() - f0).solves;
          CHECK(saved == (nudge == 0.0 ? 1 : 0));
          const Eigen::MatrixXd moved = a.positions.rowwise() - P.colwise().mean();
          CHECK((b.positions - a.positions).cwiseAbs().maxCoeff() <=
                1e-10 * moved.cwiseAbs().maxCoeff());
        }
      }
}
