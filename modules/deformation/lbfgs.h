// The memory of limited-memory BFGS (Nocedal and Wright, Alg. 7.4), used by the deformation
// session as in Liu, Bouaziz and Kavan (2017): quasi-Newton steps on the energy in the positions,
// with the constant local/global system matrix A as the initial Hessian, so that a step without
// history is exactly the plain global step and the history adds the curvature A misses (the
// rotations' dependence on the positions).
#pragma once

#include <Eigen/Core>
#include <deque>
#include <functional>

namespace diffreg {

class LbfgsHistory {
 public:
  /// Keeps the last `pairs` >= 1 pairs.
  explicit LbfgsHistory(int pairs) : pairs_(pairs) {}

  void reset();
  /// Records the step s = x_(k+1) - x_k and the gradient change y = g_(k+1) - g_k. A pair
  /// without positive curvature (s . y <= 0) is dropped; returns whether it was kept.
  bool add(Eigen::MatrixXd s, Eigen::MatrixXd y);
  /// The quasi-Newton direction -H g by the two-loop recursion, H0 applied by `initial`.
  Eigen::MatrixXd direction(const Eigen::MatrixXd& g,
                            const std::function<Eigen::MatrixXd(const Eigen::MatrixXd&)>& initial)
      const;
  int size() const { return static_cast<int>(s_.size()); }

 private:
  int pairs_;
  std::deque<Eigen::MatrixXd> s_, y_;
  std::deque<double> rho_;
};

}  // namespace diffreg
