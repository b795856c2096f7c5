// Closest rotations to small square matrices, shared by the local step and the metrics: the
// general SVD form, and closed forms / iterations for the local step's hot loop that give the
// same rotation (to rounding) at a fraction of the cost.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <cmath>

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

/// Closest planar rotation to any 2 x 2 F in closed form: R = [c -s; s c] maximizes
/// tr(R^T F) = c (F00 + F11) + s (F10 - F01), so (c, s) is that vector normalized, and
/// `trace` = tr(R^T F) (the signed singular value sum of closestRotation<2>). When the vector is
/// zero every rotation is equally close (e.g. F = diag(1, -1)) and R = I.
inline Eigen::Matrix2d closestRotation2(const Eigen::Matrix2d& F, double& trace) {
  const double a = F(0, 0) + F(1, 1), b = F(1, 0) - F(0, 1);
  const double r = std::sqrt(a * a + b * b);
  Eigen::Matrix2d R;
  if (!(r > 0.0)) {
    trace = a;
    R.setIdentity();
    return R;
  }
  const double c = a / r, s = b / r;
  R << c, -s, s, c;
  trace = r;
  return R;
}

/// For a surface element with unit rest normal n and F = F P (F n = 0 up to rounding): the
/// closest rotation R to F restricted to the tangent plane, T = R P, in closed form. With an
/// orthonormal tangent frame (t1, t2) of n and M = [F t1, F t2] (3 x 2), T = Q [t1 t2]^T for the
/// polar factor Q = M (M^T M)^(-1/2), and for a symmetric positive definite 2 x 2 matrix C with
/// delta = sqrt(det C): sqrt(C) = (C + delta I) / tau, tau = sqrt(tr C + 2 delta) = sigma1 +
/// sigma2; delta = |F t1 x F t2| = sigma1 sigma2 without cancellation. `trace` = tr(T^T F) =
/// sigma1 + sigma2. Returns false (T untouched) when the deformed element is degenerate
/// (sigma2 <= 1e-10 sigma1); the caller then uses the SVD.
inline bool tangentRotation(const Eigen::Matrix3d& F, const Eigen::Vector3d& n, Eigen::Matrix3d& T,
                            double& trace) {
  // Orthonormal frame of n without branches on its direction (Duff et al., JCGT 2017).
  const double sign = std::copysign(1.0, n.z());
  const double a = -1.0 / (sign + n.z()), b = n.x() * n.y() * a;
  const Eigen::Vector3d t1(1.0 + sign * n.x() * n.x() * a, sign * b, -sign * n.x());
  const Eigen::Vector3d t2(b, sign + n.y() * n.y() * a, -n.y());
  const Eigen::Vector3d m1 = F * t1, m2 = F * t2;
  const double c11 = m1.squaredNorm(), c22 = m2.squaredNorm(), c12 = m1.dot(m2);
  const double tr = c11 + c22;
  const double delta = m1.cross(m2).norm();
  if (!(delta > 1e-10 * tr)) return false;
  const double tau = std::sqrt(tr + 2.0 * delta);
  const double scale = 1.0 / (delta * tau);
  const Eigen::Vector3d q1 = ((c22 + delta) * scale) * m1 - (c12 * scale) * m2;
  const Eigen::Vector3d q2 = ((c11 + delta) * scale) * m2 - (c12 * scale) * m1;
  T.noalias() = q1 * t1.transpose();
  T.noalias() += q2 * t2.transpose();
  trace = tau;
  return true;
}

/// Closest rotation to a 3 x 3 F with det F > 0 by the scaled Newton iteration for the polar
/// decomposition, X <- (g X + X^-T / g) / 2 with Frobenius scaling g = (|X^-1| / |X|)^(1/2)
/// (Higham 1986), which converges quadratically to the orthogonal polar factor, here a proper
/// rotation and equal to closestRotation<3>. `trace` = tr(R^T F). Returns false (R untouched)
/// when F is inverted or close to singular (det F <= 1e-6 (|F|_F / sqrt 3)^3) or the iteration
/// does not settle; the caller then uses the SVD.
inline bool polarRotation3(const Eigen::Matrix3d& F, Eigen::Matrix3d& R, double& trace) {
  const double f2 = F.squaredNorm();
  const double mean = std::sqrt(f2 / 3.0);
  if (!(F.determinant() > 1e-6 * mean * mean * mean)) return false;
  Eigen::Matrix3d X = F, C;
  for (int it = 0; it < 40; ++it) {
    // Cofactor matrix: det(X) X^-T.
    C.col(0) = X.col(1).cross(X.col(2));
    C.col(1) = X.col(2).cross(X.col(0));
    C.col(2) = X.col(0).cross(X.col(1));
    const double det = X.col(0).dot(C.col(0));
    if (!(det > 0.0)) return false;
    const double x2 = X.squaredNorm(), y2 = C.squaredNorm() / (det * det);
    const double g = std::sqrt(std::sqrt(y2 / x2));
    const Eigen::Matrix3d next = 0.5 * g * X + (0.5 / (g * det)) * C;
    const double change = (next - X).squaredNorm();
    X = next;
    // The error after a step is about the square of the step before it.
    if (change < 1e-20) {
      R = X;
      trace = R.cwiseProduct(F).sum();
      return true;
    }
  }
  return false;
}

/// The proper rotation R closest to C (d = 3, tets; or the tangent-plane target of a surface
/// element with unit rest normal `normal`: T = R P, P = I - n n^T) and `trace` = tr(T^T C).
/// Surfaces: T = Q [t1 t2]^T with Q the polar factor of M = [C t1, C t2] for a tangent frame
/// (t1, t2), which maximizes tr(T^T C) for any C (C n need not vanish); closed form, with the
/// thin SVD of M when M is (nearly) degenerate. Tets: the polar Newton iteration, with the SVD
/// for inverted or nearly singular C.
inline Eigen::Matrix3d rotationTarget(const Eigen::Matrix3d& C, const Eigen::Vector3d* normal,
                                      double& trace) {
  Eigen::Matrix3d T;
  if (normal) {
    if (tangentRotation(C, *normal, T, trace)) return T;
    const Eigen::Vector3d& n = *normal;
    Eigen::Matrix<double, 3, 2> frame;
    const Eigen::Vector3d helper =
        std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
    frame.col(0) = n.cross(helper).normalized();
    frame.col(1) = n.cross(frame.col(0));
    const Eigen::MatrixXd M = C * frame;  // dynamic: thin factors of a 3 x 2 matrix
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(M, Eigen::ComputeThinU | Eigen::ComputeThinV);
    T = svd.matrixU() * svd.matrixV().transpose() * frame.transpose();
    trace = svd.singularValues().sum();
    return T;
  }
  if (polarRotation3(C, T, trace)) return T;
  Eigen::Vector3d sigma;
  T = closestRotation<3>(C, sigma);
  trace = sigma.sum();
  return T;
}

}  // namespace diffreg
