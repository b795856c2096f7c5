// The RBF baseline for regularization weights (paper §3.2.2 and Fig. 10, docs/method.md, "The RBF
// baseline"):
//   x(v) = sum_j m_j phi(d(v, j) / (r_j sigma)),   phi(s) = exp(-s^2),
// d(v, j) the Euclidean or geodesic distance from v to the nearest vertex of handle j. The sum
// over handles is what lets x exceed max m_j between nearby handles (no maximum principle),
// which is the paper's argument for diffused weights.
#pragma once

#include <diffreg/core/names.h>
#include <diffreg/discretization/discretization.h>
#include <diffreg/handles/handles.h>
#include <diffreg/mesh/mesh.h>

#include <Eigen/Core>
#include <string>

namespace diffreg {

enum class RbfDistance {
  Euclidean,  ///< straight-line distance in the ambient space
  Geodesic,   ///< heat-method geodesic distance (weights/geodesic.h)
};

template <>
struct EnumTable<RbfDistance> {
  static constexpr const char* parameter = "distance";
  static constexpr const char* noun = "rbf distance";
  static constexpr EnumName<RbfDistance> names[] = {
      {RbfDistance::Euclidean, "euclidean"},
      {RbfDistance::Geodesic, "geodesic"},
  };
};

/// The range of sigma (in any unit) every front end accepts.
constexpr double kMinRbfSigma = 1e-12, kMaxRbfSigma = 1e6;

/// sigma in length units from a fraction of the bounding-box diagonal of the vertices of the
/// elements (Discretization::boundingBoxDiagonal, diffuse_weights' unit).
/// \throw InvalidParameter for fraction <= 0 (or not finite).
double rbfSigmaFromDiagonal(const Discretization& disc, double fraction);

/// Gaussian RBF weights (see the file comment), size n. Unreferenced vertices get 0, like the
/// diffused weights. With `clamp` the result is clamped to [0, 1]; otherwise it is left as the
/// plain sum, which may exceed max m_j.
/// \param sigma kernel width in length units (see rbfSigmaFromDiagonal); r_j scales it per
///        handle.
/// \throw InvalidParameter for sigma <= 0 (or not finite), no handles, an empty handle, a
///        vertex id out of range, r_j <= 0 or m_j < 0 (naming the handle).
/// \throw InvalidMesh, SingularSystem from the geodesic solver (RbfDistance::Geodesic).
Eigen::VectorXd rbfWeights(const Mesh& mesh, const HandleSet& handles, double sigma,
                           RbfDistance distance, bool clamp = false);

}  // namespace diffreg
