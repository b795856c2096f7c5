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

/// 3 x 2 blocks: a surface element's tangent frame [t1 t2], and a target or deformation
/// gradient in that frame.
using Matrix32 = Eigen::Matrix<double, 3, 2>;

/// The orthonormal tangent frame [t1 t2] of the unit normal n (t1 x t2 = n), without branches
/// on its direction (Duff et al., JCGT 2017).
inline Matrix32 tangentFrame(const Eigen::Vector3d& n) {
  const double sign = std::copysign(1.0, n.z());
  const double a = -1.0 / (sign + n.z()), b = n.x() * n.y() * a;
  Matrix32 E;
  E.col(0) << 1.0 + sign * n.x() * n.x() * a, sign * b, -sign * n.x();
  E.col(1) << b, sign + n.y() * n.y() * a, -n.y();
  return E;
}

/// The orthogonal polar factor Q = M (M^T M)^(-1/2) of a 3 x 2 M = [m1 m2] in closed form: for
/// the symmetric positive definite C = M^T M with delta = sqrt(det C), sqrt(C) = (C + delta I) /
/// tau, tau = sqrt(tr C + 2 delta) = sigma1 + sigma2; delta = |m1 x m2| = sigma1 sigma2 without
/// cancellation. Q maximizes tr(Q^T M) over 3 x 2 matrices with orthonormal columns, and
/// `trace` = tr(Q^T M) = sigma1 + sigma2. Returns false (Q untouched) when M is (nearly)
/// degenerate (sigma2 <= 1e-10 sigma1).
[[gnu::always_inline]] inline bool tangentPolar(const Matrix32& M, Matrix32& Q, double& trace) {
  // Scalar arithmetic throughout: the compiler packs Eigen's cross product into vectors
  // through the stack, which stalls this latency-bound loop body.
  const double a0 = M(0, 0), a1 = M(1, 0), a2 = M(2, 0), b0 = M(0, 1), b1 = M(1, 1), b2 = M(2, 1);
  const double c11 = a0 * a0 + a1 * a1 + a2 * a2, c22 = b0 * b0 + b1 * b1 + b2 * b2;
  const double c12 = a0 * b0 + a1 * b1 + a2 * b2;
  const double x = a1 * b2 - a2 * b1, y = a2 * b0 - a0 * b2, z = a0 * b1 - a1 * b0;
  const double tr = c11 + c22;
  const double delta = std::sqrt(x * x + y * y + z * z);
  if (!(delta > 1e-10 * tr)) return false;
  const double tau = std::sqrt(tr + 2.0 * delta);
  const double scale = 1.0 / (delta * tau);
  const double p1 = (c22 + delta) * scale, p2 = (c11 + delta) * scale, q = c12 * scale;
  Q << p1 * a0 - q * b0, p2 * b0 - q * a0,  //
      p1 * a1 - q * b1, p2 * b1 - q * a1,   //
      p1 * a2 - q * b2, p2 * b2 - q * a2;
  trace = tau;
  return true;
}

/// The thin SVD form Q = U V^T of tangentPolar's polar factor, for any M (kept out of line:
/// the closed form's callers are hot loops).
Matrix32 tangentPolarSvd(const Matrix32& M, double& trace);

/// Closest rotation to a 3 x 3 F with det F > 0 by the scaled Newton iteration for the polar
/// decomposition, X <- (g X + X^-T / g) / 2 with Frobenius scaling g = (|X^-1| / |X|)^(1/2)
/// (Higham 1986), which converges quadratically to the orthogonal polar factor, here a proper
/// rotation and equal to closestRotation<3>. `trace` = tr(R^T F). Returns false (R untouched)
/// when F is inverted or close to singular (det F <= 1e-6 (|F|_F / sqrt 3)^3) or the iteration
/// does not settle; the caller then uses the SVD.
/// In scalars on column-major arrays, R written column-major to the 9 doubles at `R` (as
/// tangentPolar: the local step's fits wait on this chain).
[[gnu::always_inline]] inline bool polarRotation3(const Eigen::Matrix3d& F, double* R,
                                                  double& trace) {
  const double f2 = F.squaredNorm();
  const double mean = std::sqrt(f2 / 3.0);
  if (!(F.determinant() > 1e-6 * mean * mean * mean)) return false;
  double X[9], C[9];
  for (int j = 0; j < 9; ++j) X[j] = F(j);
  for (int it = 0; it < 40; ++it) {
    // Cofactor matrix: det(X) X^-T; column a is the cross product of the other two columns.
    for (int a = 0; a < 3; ++a) {
      const double* u = X + 3 * ((a + 1) % 3);
      const double* v = X + 3 * ((a + 2) % 3);
      C[3 * a] = u[1] * v[2] - u[2] * v[1];
      C[3 * a + 1] = u[2] * v[0] - u[0] * v[2];
      C[3 * a + 2] = u[0] * v[1] - u[1] * v[0];
    }
    const double det = X[0] * C[0] + X[1] * C[1] + X[2] * C[2];
    if (!(det > 0.0)) return false;
    double x2 = 0.0, c2 = 0.0;
    for (int j = 0; j < 9; ++j) {
      x2 += X[j] * X[j];
      c2 += C[j] * C[j];
    }
    const double g = std::sqrt(std::sqrt(c2 / (det * det) / x2));
    const double p = 0.5 * g, q = 0.5 / (g * det);
    double change = 0.0;
    for (int j = 0; j < 9; ++j) {
      const double next = p * X[j] + q * C[j];
      change += (next - X[j]) * (next - X[j]);
      X[j] = next;
    }
    // The error after a step is about the square of the step before it.
    if (change < 1e-20) {
      trace = 0.0;
      for (int j = 0; j < 9; ++j) {
        R[j] = X[j];
        trace += X[j] * F(j);
      }
      return true;
    }
  }
  return false;
}

/// polarRotation3 into a matrix.
inline bool polarRotation3(const Eigen::Matrix3d& F, Eigen::Matrix3d& R, double& trace) {
  return polarRotation3(F, R.data(), trace);
}

/// closestRotation<3> and `trace` = the sum of its signed singular values (kept out of line: the
/// fallback of the closed forms in hot loops).
Eigen::Matrix3d closestRotation3(const Eigen::Matrix3d& C, double& trace);

/// The proper rotation R closest to C (d = 3, tets; or the tangent-plane target of a surface
/// element with unit rest normal `normal`: T = R P, P = I - n n^T), written column-major to the
/// 9 doubles at `T`, and `trace` = tr(T^T C). Surfaces: T = Q E^T with Q the polar factor of
/// M = C E for the tangent frame E of the normal (tangentPolar, with the SVD when M is nearly
/// degenerate), which maximizes tr(T^T C) for any C (C n need not vanish). Tets: the polar
/// Newton iteration, with the SVD for inverted or nearly singular C. Surfaces in scalars and
/// straight into `T`: the batched fits of the local step are bound by the latency of the
/// square roots, and small Eigen temporaries here went through the stack.
[[gnu::always_inline]] inline void rotationTarget(const Eigen::Matrix3d& C,
                                                  const Eigen::Vector3d* normal, double& trace,
                                                  double* T) {
  if (normal) {
    const Matrix32 E = tangentFrame(*normal);
    Matrix32 M, Q;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 2; ++c)
        M(r, c) = C(r, 0) * E(0, c) + C(r, 1) * E(1, c) + C(r, 2) * E(2, c);
    if (!tangentPolar(M, Q, trace)) Q = tangentPolarSvd(M, trace);
    for (int c = 0; c < 3; ++c)
      for (int r = 0; r < 3; ++r) T[c * 3 + r] = Q(r, 0) * E(c, 0) + Q(r, 1) * E(c, 1);
    return;
  }
  if (!polarRotation3(C, T, trace)) Eigen::Map<Eigen::Matrix3d>{T} = closestRotation3(C, trace);
}

/// rotationTarget as a matrix.
inline Eigen::Matrix3d rotationTarget(const Eigen::Matrix3d& C, const Eigen::Vector3d* normal,
                                      double& trace) {
  Eigen::Matrix3d T;
  rotationTarget(C, normal, trace, T.data());
  return T;
}

}  // namespace diffreg
