#include <diffreg/deformation/metrics.h>

#include <diffreg/core/error.h>
#include <diffreg/core/parallel.h>
#include <diffreg/deformation/local_step.h>
#include <diffreg/deformation/residual_model.h>
#include <diffreg/deformation/rotation.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace diffreg {
namespace {

void checkPositions(const Discretization& disc, const Eigen::MatrixXd& X,
                    const char* what = "positions") {
  if (X.rows() != disc.numVertices() || X.cols() != disc.dim())
    throw InvalidParameter("metrics: " + std::string(what) + " are " + std::to_string(X.rows()) +
                           " x " + std::to_string(X.cols()) + ", expected " +
                           std::to_string(disc.numVertices()) + " x " + std::to_string(disc.dim()));
  // As for the rest shape's size: beyond kMaxMeshSize the squares and products of the measures
  // overflow (a NaN distortion at 1e78, an infinite one or Dist at 1e155).
  // Unreferenced vertices are in no system and measured by nothing: only the others count.
  const std::vector<bool>& active = disc.active();
  double largest = 0.0;
  for (Eigen::Index i = 0; i < X.rows(); ++i) {
    if (!active[static_cast<size_t>(i)]) continue;
    if (!X.row(i).allFinite())
      throw InvalidParameter("metrics: the " + std::string(what) + " of vertex " +
                             std::to_string(i) + " (0-based) are not finite");
    largest = std::max(largest, X.row(i).cwiseAbs().maxCoeff());
  }
  if (largest > kMaxMeshSize) {
    char text[32];
    std::snprintf(text, sizeof text, "%.3g", largest);
    throw InvalidParameter("metrics: the " + std::string(what) +
                           " have a coordinate of magnitude " + text +
                           ", outside [-1e30, 1e30] where the measures keep double precision");
  }
}

}  // namespace

Eigen::VectorXd elementDistortion(const Discretization& disc, Energy energy,
                                  const Eigen::MatrixXd& positions) {
  checkPositions(disc, positions);
  const ResidualModel model(disc, energy);
  return model.distortion(model.residuals(positions));
}

Eigen::VectorXd facetSmoothness(const Discretization& disc, Energy energy,
                                const Eigen::MatrixXd& positions) {
  checkPositions(disc, positions);
  const ResidualModel model(disc, energy);
  return model.facetDifference(model.residuals(positions));
}

Eigen::VectorXd elementSmoothness(const Discretization& disc, const Eigen::VectorXd& perFacet) {
  const auto& facets = disc.facets();
  if (perFacet.size() != static_cast<Eigen::Index>(facets.size()))
    throw InvalidParameter("metrics: " + std::to_string(perFacet.size()) + " facet values for " +
                           std::to_string(facets.size()) + " facets");
  Eigen::VectorXd s = Eigen::VectorXd::Zero(disc.numElements());
  for (size_t f = 0; f < facets.size(); ++f) {
    const double v = perFacet(static_cast<Eigen::Index>(f));
    s(facets[f].k) = std::max(s(facets[f].k), v);
    s(facets[f].l) = std::max(s(facets[f].l), v);
  }
  return s;
}

ElementMaps elementMaps(const Discretization& disc, Energy energy,
                        const Eigen::MatrixXd& positions) {
  checkPositions(disc, positions);
  const ResidualModel model(disc, energy);
  const Stacked e = model.residuals(positions);
  return {model.distortion(e), elementSmoothness(disc, model.facetDifference(e))};
}

ElementMaps elementMapsFromResiduals(const Discretization& disc, Energy energy,
                                     const ElementTargets& residuals) {
  const ResidualModel model(disc, energy);
  const Eigen::Index rows = static_cast<Eigen::Index>(disc.numElements()) * model.rows();
  if (residuals.rows() != rows || residuals.cols() != model.columns())
    throw InvalidParameter("metrics: residuals of shape " + std::to_string(residuals.rows()) +
                           " x " + std::to_string(residuals.cols()) + " for " +
                           std::to_string(disc.numElements()) + " elements (expected " +
                           std::to_string(rows) + " x " + std::to_string(model.columns()) + ")");
  return {model.distortion(residuals), elementSmoothness(disc, model.facetDifference(residuals))};
}

namespace {

// Whether element k is inverted at X (countInverted), with fixed-size D x D matrices.
template <int D>
bool inverted(const Discretization& disc, const Eigen::MatrixXd& X, int k) {
  const Eigen::MatrixXi& el = disc.elements();
  const auto G = disc.gradient(k);
  Eigen::Matrix<double, D, D> F = Eigen::Matrix<double, D, D>::Zero();
  for (int i = 0; i < el.cols(); ++i)
    for (int r = 0; r < D; ++r)
      for (int c = 0; c < D; ++c) F(r, c) += X(el(k, i), r) * G(i, c);
  // The determinant by LU with partial pivoting, as Eigen computes it for dynamic sizes (the
  // closed form of fixed sizes may round a nearly degenerate element's the other way).
  if constexpr (D == 2) {
    return F.partialPivLu().determinant() <= 0.0;
  } else {
    if (disc.kind() != MeshKind::Surface) return F.partialPivLu().determinant() <= 0.0;
    // F n = 0, so R_k = [Q, q1 x q2] [E, n]^T with E the rest tangent frame and Q the polar
    // factor of M = F E, as the surface fit finds it (rotationTarget: the closed form, the SVD
    // for nearly collapsed triangles): R_k n = q1 x q2.
    const Matrix32 M = F * tangentFrame(disc.normals().row(k).transpose());
    Matrix32 Q;
    double trace = 0.0;
    if (!tangentPolar(M, Q, trace)) Q = tangentPolarSvd(M, trace);
    const Eigen::Vector3d Rn = Q.col(0).cross(Q.col(1));
    const Eigen::Vector3d a = (X.row(el(k, 1)) - X.row(el(k, 0))).transpose();
    const Eigen::Vector3d b = (X.row(el(k, 2)) - X.row(el(k, 0))).transpose();
    return a.cross(b).dot(Rn) <= 0.0;
  }
}

}  // namespace

int countInverted(const Discretization& disc, const Eigen::MatrixXd& X) {
  checkPositions(disc, X);
  const int m = disc.numElements();
  constexpr int kGrain = 4096;
  std::vector<int> counts(static_cast<size_t>(parallel::numChunks(m, kGrain)), 0);
  parallel::forChunks(m, kGrain, [&](int chunk, int begin, int end) {
    int count = 0;
    for (int k = begin; k < end; ++k)
      count += disc.dim() == 2 ? inverted<2>(disc, X, k) : inverted<3>(disc, X, k);
    counts[static_cast<size_t>(chunk)] = count;
  });
  int count = 0;
  for (int c : counts) count += c;
  return count;
}

double rmsDistance(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  if (a.rows() != b.rows() || a.cols() != b.cols() || a.rows() == 0)
    throw InvalidParameter("metrics: cannot compare positions of shapes " +
                           std::to_string(a.rows()) + " x " + std::to_string(a.cols()) + " and " +
                           std::to_string(b.rows()) + " x " + std::to_string(b.cols()));
  return std::sqrt((a - b).rowwise().squaredNorm().mean());
}

double rmsDistance(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b,
                   const std::vector<bool>& active) {
  if (a.rows() != b.rows() || a.cols() != b.cols() ||
      static_cast<Eigen::Index>(active.size()) != a.rows())
    throw InvalidParameter("metrics: cannot compare positions of shapes " +
                           std::to_string(a.rows()) + " x " + std::to_string(a.cols()) + " and " +
                           std::to_string(b.rows()) + " x " + std::to_string(b.cols()) + " over " +
                           std::to_string(active.size()) + " vertices");
  double sum = 0.0;
  Eigen::Index count = 0;
  for (Eigen::Index i = 0; i < a.rows(); ++i)
    if (active[static_cast<size_t>(i)]) {
      sum += (a.row(i) - b.row(i)).squaredNorm();
      ++count;
    }
  if (count == 0) throw InvalidParameter("metrics: no vertex of an element to compare");
  return std::sqrt(sum / static_cast<double>(count));
}

DeformationMetrics measureDeformation(const Discretization& disc, Energy energy,
                                      const Eigen::MatrixXd& positions,
                                      const RegularizationWeights& weights,
                                      const Eigen::MatrixXd* reference, const double* runEnergy,
                                      const ElementTargets* startTargets,
                                      const Eigen::VectorXd* distortion) {
  checkPositions(disc, positions);
  if (distortion && distortion->size() != disc.numElements())
    throw InvalidParameter("metrics: " + std::to_string(distortion->size()) +
                           " distortion values for " + std::to_string(disc.numElements()) +
                           " elements");
  const ResidualModel model(disc, energy);
  Eigen::VectorXd computed;
  if (!distortion) {
    computed = model.distortion(model.residuals(positions));
    distortion = &computed;
  }
  const Eigen::VectorXd& D = *distortion;
  const Eigen::VectorXd& a = disc.measures();
  DeformationMetrics m;
  m.dMax = D.maxCoeff();
  m.dAve = a.dot(D) / a.sum();
  m.dDev = std::sqrt(std::max(0.0, a.dot((D.array() - m.dAve).square().matrix()) / a.sum()));
  m.inverted = countInverted(disc, positions);
  // Eq. 3 of the shape: the targets relaxed as the exact local step does (D_k above keeps
  // each element's own closest rotation, the paper's distortion).
  if (runEnergy) {
    m.energy = *runEnergy;
    m.relaxed = false;
  } else {
    const Eigen::Index rows = static_cast<Eigen::Index>(disc.numElements()) * disc.dim();
    if (startTargets && (startTargets->rows() != rows || startTargets->cols() != disc.dim()))
      throw InvalidParameter("metrics: start targets of shape " +
                             std::to_string(startTargets->rows()) + " x " +
                             std::to_string(startTargets->cols()) + " for " +
                             std::to_string(disc.numElements()) + " elements (expected " +
                             std::to_string(rows) + " x " + std::to_string(disc.dim()) + ")");
    Regularizer regularizer(disc);
    regularizer.setWeights(weights);
    m.energy = relaxedEnergy(model, regularizer, positions, startTargets);
  }
  if (reference) {
    checkPositions(disc, *reference, "reference positions");
    m.dist = rmsDistance(positions, *reference, disc.active());
  }
  return m;
}

}  // namespace diffreg
