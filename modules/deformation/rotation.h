// Closest rotation to a small square matrix, shared by the local step and the metrics.
#pragma once

#include <Eigen/Core>
#include <Eigen/SVD>

namespace diffreg {

/// R = U V^T for F = U Sigma V^T, with det R > 0: when det(U V^T) < 0 the singular vector of
/// the smallest singular value is flipped and that value negated in `sigma` (so that
/// tr(R^T F) = sigma.sum()). Works for rank-deficient F (surface elements, F n = 0).
template <int D>
Eigen::Matrix<double, D, D> closestRotation(const Eigen::Matrix<double, D, D>& F,
                                            Eigen::Matrix<double, D, 1>& sigma) {
  // Square input: no QR preconditioner needed.
  const Eigen::JacobiSVD<Eigen::Matrix<double, D, D>, Eigen::NoQRPreconditioner> svd(
      F, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix<double, D, D> U = svd.matrixU();
  sigma = svd.singularValues();
  if ((U * svd.matrixV().transpose()).determinant() < 0.0) {
    U.col(D - 1) *= -1.0;
    sigma(D - 1) *= -1.0;
  }
  return U * svd.matrixV().transpose();
}

}  // namespace diffreg
