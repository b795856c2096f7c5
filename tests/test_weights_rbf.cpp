// The RBF baseline (paper §3.2.2, Fig. 10; docs/method.md, "The RBF baseline") and the heat-method geodesic
// distances it can use.
#include <diffreg/core/error.h>
#include <diffreg/discretization/discretization.h>
#include <diffreg/mesh/io.h>
#include <diffreg/mesh/shapes.h>
#include <diffreg/weights/diffusion.h>
#include <diffreg/weights/geodesic.h>
#include <diffreg/weights/rbf.h>

#include "test_support.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

using namespace diffreg;
using namespace diffreg::testing;

namespace {

Eigen::VectorXd euclidean(const Mesh& mesh, int source) {
  const Eigen::MatrixXd x = mesh.positions();
  return (x.rowwise() - x.row(source)).rowwise().norm();
}

Handle handle(std::vector<int> vertices, double magnitude = 1.0, double range = 1.0) {
  Handle h;
  h.vertices = std::move(vertices);
  h.magnitude = magnitude;
  h.range = range;
  return h;
}

HandleSet handleSet(std::vector<Handle> handles) {
  HandleSet set;
  set.handles = std::move(handles);
  return set;
}

}  // namespace

TEST_CASE("Geodesic distances on a flat rectangle match Euclidean distances", "[weights][rbf]") {
  const Mesh mesh = makeRectangle(4, 2, 32, 16);
  const double diagonal = std::sqrt(20.0);
  const int corner = nearest(mesh, {0, 0, 0});
  const Eigen::VectorXd d = geodesicDistances(mesh, {corner});
  const Eigen::VectorXd e = euclidean(mesh, corner);
  CHECK(d[corner] == 0.0);
  CHECK(d.minCoeff() >= 0.0);
  const double worst = (d - e).cwiseAbs().maxCoeff();
  CHECK(worst < 0.03 * diagonal);  // measured 1.5% of the diagonal
  CHECK(std::abs(d[nearest(mesh, {4, 2, 0})] - diagonal) < 0.03 * diagonal);

  SECTION("several sources give the distance to the nearest one") {
    const int other = nearest(mesh, {4, 2, 0});
    const Eigen::VectorXd both = geodesicDistances(mesh, {corner, other});
    const Eigen::VectorXd toOther = euclidean(mesh, other);
    CHECK(both[corner] == 0.0);
    CHECK(both[other] == 0.0);
    const double worst2 = (both - e.cwiseMin(toOther)).cwiseAbs().maxCoeff();
    CHECK(worst2 < 0.03 * diagonal);  // measured 1.4%
  }
}

TEST_CASE("Geodesic distances go around the gap of a U", "[weights][rbf]") {
  // Arms of width 1 and height 3 around a gap of width 1: from the top of the left arm's
  // inner side to the top of the right arm's, the path goes down 2, across 1 and up 2.
  const Mesh mesh = makeUShape(1.0, 1.0, 3.0, 4);
  const int a = nearest(mesh, {1, 3, 0}), b = nearest(mesh, {2, 3, 0});
  const double straight = euclidean(mesh, a)[b];
  REQUIRE(straight == Approx(1.0));
  const double around = geodesicDistances(mesh, {a})[b];
  CHECK(around > 4.0 * straight);
  // The shortest path is 5 long; the heat method overestimates next to the boundary at this
  // resolution (measured 5.56).
  CHECK(std::abs(around - 5.0) < 0.15 * 5.0);
}

TEST_CASE("Geodesic distances on a surface follow it", "[weights][rbf]") {
  // Open cylinder of radius 1: the point opposite at the same height is pi away along the
  // surface, 2 away in space.
  const Mesh cylinder = makeCylinder(1.0, 2.0, 48, 16);
  const int a = nearest(cylinder, {1, 0, 1}), b = nearest(cylinder, {-1, 0, 1});
  const Eigen::VectorXd d = geodesicDistances(cylinder, {a});
  CHECK(euclidean(cylinder, a)[b] == Approx(2.0));
  CHECK(d[b] == Approx(3.14159265358979).epsilon(0.05));
}

TEST_CASE("Geodesic distances on a tet box (own heat method)", "[weights][rbf]") {
  const Mesh box = makeTetBox(2, 1, 1, 8, 4, 4);
  const int corner = nearest(box, {0, 0, 0}), opposite = nearest(box, {2, 1, 1});
  const Eigen::VectorXd d = geodesicDistances(box, {corner});
  const Eigen::VectorXd e = euclidean(box, corner);
  CHECK(d[corner] == 0.0);
  CHECK(d.minCoeff() >= 0.0);
  // Convex: the geodesic distance is the straight one. Measured: 2.5% off at the opposite
  // corner, at most 7.3% of the diagonal anywhere.
  CHECK(std::abs(d[opposite] - e[opposite]) < 0.1 * e[opposite]);
  CHECK((d - e).cwiseAbs().maxCoeff() < 0.1 * e[opposite]);
}

TEST_CASE("Unreachable vertices are at infinite distance", "[weights][rbf]") {
  // Two separate squares: sources in the left one do not reach the right one.
  const Mesh two = makeCellShape({{true, false, true}}, 1.0);
  const int left = nearest(two, {0, 0, 0});
  const Eigen::VectorXd d = geodesicDistances(two, {left});
  const Eigen::MatrixXd x = two.positions();
  for (int v = 0; v < two.numVertices(); ++v) {
    if (x(v, 0) <= 1.0)
      CHECK(std::isfinite(d[v]));
    else
      CHECK(d[v] == std::numeric_limits<double>::infinity());
  }
  // An unreferenced vertex of a tet mesh is unreachable too.
  TetMesh tets = makeTetBox(1, 1, 1, 2, 2, 2).tet();
  tets.points.emplace_back(5, 5, 5);
  const Eigen::VectorXd dt = geodesicDistances(Mesh(tets), {0});
  CHECK(dt[int(tets.points.size()) - 1] == std::numeric_limits<double>::infinity());
  CHECK(dt.head(tets.points.size() - 1).allFinite());
  const int right = nearest(two, {3, 1, 0});
  const Eigen::VectorXd both = geodesicDistances(two, {left, right});
  CHECK(both.allFinite());
}

TEST_CASE("Geodesic distances reject bad sources", "[weights][rbf]") {
  const Mesh mesh = makeRectangle(1, 1, 2, 2);
  CHECK_THROWS_AS(geodesicDistances(mesh, {}), InvalidParameter);
  CHECK_THROWS_WITH(geodesicDistances(mesh, {-1}), Catch::Contains("out of range"));
  CHECK_THROWS_AS(geodesicDistances(mesh, {mesh.numVertices()}), InvalidParameter);
  const Mesh box = makeTetBox(1, 1, 1, 1, 1, 1);
  CHECK_THROWS_AS(geodesicDistances(box, {100}), InvalidParameter);
}

TEST_CASE("RBF distance names", "[weights][rbf]") {
  CHECK(parseEnum<RbfDistance>("euclidean") == RbfDistance::Euclidean);
  CHECK(parseEnum<RbfDistance>(toString(RbfDistance::Geodesic)) == RbfDistance::Geodesic);
  CHECK_THROWS_WITH(parseEnum<RbfDistance>("manhattan"),
                    Catch::Contains("manhattan") && Catch::Contains("euclidean, geodesic"));
}

TEST_CASE("RBF weights are the Gaussian sum of docs/method.md (The RBF baseline)",
          "[weights][rbf]") {
  const Mesh mesh = makeRectangle(8, 2, 32, 8);
  const int a = nearest(mesh, {0.5, 1, 0}), b = nearest(mesh, {7.5, 1, 0});
  const HandleSet handles = handleSet({handle({a}, 0.7, 1.0), handle({b}, 0.4, 2.0)});
  const double sigma = 0.5;
  for (RbfDistance kind : {RbfDistance::Euclidean, RbfDistance::Geodesic}) {
    const Eigen::VectorXd x = rbfWeights(mesh, handles, sigma, kind);
    // Far-apart handles: each handle's vertices carry its own magnitude.
    CHECK(x[a] == Approx(0.7).margin(1e-12));
    CHECK(x[b] == Approx(0.4).margin(1e-12));
    CHECK(x.minCoeff() >= 0.0);
  }
  // Euclidean: exactly m_j exp(-(d / (r_j sigma))^2) summed.
  const Eigen::VectorXd x = rbfWeights(mesh, handles, sigma, RbfDistance::Euclidean);
  const Eigen::VectorXd da = euclidean(mesh, a), db = euclidean(mesh, b);
  for (int v = 0; v < mesh.numVertices(); ++v) {
    const double expected = 0.7 * std::exp(-std::pow(da[v] / sigma, 2)) +
                            0.4 * std::exp(-std::pow(db[v] / (2.0 * sigma), 2));
    CHECK(x[v] == Approx(expected).margin(1e-14));
  }
  // A handle's set of vertices acts through its nearest vertex.
  const int c = nearest(mesh, {1.0, 1, 0});
  const Eigen::VectorXd y =
      rbfWeights(mesh, handleSet({handle({a, c})}), sigma, RbfDistance::Euclidean);
  const Eigen::VectorXd dc = euclidean(mesh, c);
  for (int v = 0; v < mesh.numVertices(); ++v)
    CHECK(y[v] == Approx(std::exp(-std::pow(std::min(da[v], dc[v]) / sigma, 2))).margin(1e-14));
}

TEST_CASE("Near handles: RBF weights overshoot, diffused weights do not (paper Fig. 10)",
          "[weights][rbf]") {
  // Two one-vertex handles 0.4 apart with m = 1 each and sigma = 0.4: midway, each Gaussian
  // gives exp(-1/4), so the sum is 1.56 > max m_j. Heat flow with t = 2 sigma^2 reaches about
  // as far (mean weight 0.11 against the RBF's 0.12 here: a point handle has little capacity,
  // so t must exceed the free-space match sigma^2 / 4) and obeys the maximum principle (all
  // angles of this mesh are <= 90 degrees).
  const Mesh mesh = makeRectangle(4, 2, 40, 20);
  const int a = nearest(mesh, {1.8, 1, 0}), b = nearest(mesh, {2.2, 1, 0});
  const int mid = nearest(mesh, {2.0, 1, 0});
  const HandleSet handles = handleSet({handle({a}), handle({b})});
  const double sigma = 0.4;
  for (RbfDistance kind : {RbfDistance::Euclidean, RbfDistance::Geodesic}) {
    const Eigen::VectorXd x = rbfWeights(mesh, handles, sigma, kind);
    CHECK(x[mid] > 1.4);
    CHECK(x.maxCoeff() > 1.4);
    const Eigen::VectorXd clamped = rbfWeights(mesh, handles, sigma, kind, true);
    CHECK(clamped.maxCoeff() == 1.0);
    CHECK(clamped.minCoeff() >= 0.0);
  }
  DiffusionParams params;
  params.t = 2.0 * sigma * sigma;
  params.unit = TimeUnit::Absolute;
  params.order = DiffusionOrder::First;
  const Eigen::VectorXd diffused = diffuseWeights(Discretization(mesh), handles, params);
  const Eigen::VectorXd rbf = rbfWeights(mesh, handles, sigma, RbfDistance::Euclidean);
  CHECK(diffused.maxCoeff() <= 1.0);
  CHECK(diffused.minCoeff() >= 0.0);
  CHECK(diffused[a] == 1.0);
  CHECK(diffused[mid] > 0.5);                 // the region between the handles is covered
  CHECK(diffused.mean() > 0.5 * rbf.mean());  // a similar range
  CHECK(diffused.mean() < 2.0 * rbf.mean());
}

TEST_CASE("Geodesic RBF weights follow the shape, Euclidean ones jump gaps", "[weights][rbf]") {
  const Mesh mesh = makeUShape(1.0, 1.0, 3.0, 4);
  const int a = nearest(mesh, {1, 3, 0}), b = nearest(mesh, {2, 3, 0});
  const HandleSet handles = handleSet({handle({a})});
  const double sigma = 1.0;
  CHECK(rbfWeights(mesh, handles, sigma, RbfDistance::Euclidean)[b] > 0.3);
  CHECK(rbfWeights(mesh, handles, sigma, RbfDistance::Geodesic)[b] < 1e-6);
}

TEST_CASE("RBF weights on tets and argument errors", "[weights][rbf]") {
  const Mesh box = makeTetBox(2, 1, 1, 4, 2, 2);
  const HandleSet one = handleSet({handle({0}, 0.5)});
  for (RbfDistance kind : {RbfDistance::Euclidean, RbfDistance::Geodesic}) {
    const Eigen::VectorXd x = rbfWeights(box, one, 0.5, kind);
    CHECK(x[0] == Approx(0.5));
    CHECK(x.minCoeff() >= 0.0);
    CHECK(x.maxCoeff() <= 0.5 + 1e-12);
  }
  CHECK(rbfSigmaFromDiagonal(Discretization(makeRectangle(4, 3, 4, 3)), 0.1) == Approx(0.5));
  CHECK_THROWS_AS(rbfSigmaFromDiagonal(Discretization(box), 0.0), InvalidParameter);
  CHECK_THROWS_WITH(rbfWeights(box, one, 0.0, RbfDistance::Euclidean), Catch::Contains("sigma"));
  CHECK_THROWS_AS(rbfWeights(box, one, -1.0, RbfDistance::Geodesic), InvalidParameter);
  CHECK_THROWS_AS(rbfWeights(box, one, std::nan(""), RbfDistance::Euclidean), InvalidParameter);
  CHECK_THROWS_WITH(rbfWeights(box, HandleSet{}, 0.5, RbfDistance::Euclidean),
                    Catch::Contains("no handles"));
  CHECK_THROWS_AS(rbfWeights(box, handleSet({handle({})}), 0.5, RbfDistance::Euclidean),
                  InvalidParameter);
  CHECK_THROWS_AS(rbfWeights(box, handleSet({handle({9999})}), 0.5, RbfDistance::Euclidean),
                  InvalidParameter);
  CHECK_THROWS_AS(rbfWeights(box, handleSet({handle({0}, 1.0, 0.0)}), 0.5, RbfDistance::Euclidean),
                  InvalidParameter);
  CHECK_THROWS_AS(rbfWeights(box, handleSet({handle({0}, -1.0)}), 0.5, RbfDistance::Euclidean),
                  InvalidParameter);
}

TEST_CASE("RBF sigma from the diagonal of the vertices of the elements only", "[weights][rbf]") {
  // One stray vertex far away, used by no element, does not widen every Gaussian.
  TempDir dir;
  const std::string square = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n";
  const Mesh plain = readMesh(dir.file("plain.obj", square));
  const Mesh stray = readMesh(dir.file("stray.obj", square + "v 100 100 0\n"));
  CHECK(rbfSigmaFromDiagonal(Discretization(plain), 0.1) == Approx(0.1 * std::sqrt(2.0)));
  CHECK(rbfSigmaFromDiagonal(Discretization(stray), 0.1) ==
        rbfSigmaFromDiagonal(Discretization(plain), 0.1));
}
