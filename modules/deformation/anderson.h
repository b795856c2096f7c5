// Anderson acceleration of a fixed-point map x -> G(x) (type II, Walker and Ni 2011; used for
// local/global geometry solvers by Peng, Deng, Zhang and Liu 2018): from the last m + 1
// iterates and their images, the next iterate is G(x_k) - sum_j theta_j (G(x_(j+1)) - G(x_j))
// with theta minimizing |f_k - sum_j theta_j (f_(j+1) - f_j)|, f = G(x) - x. The deformation
// session accepts it only when it lowers the energy (the safeguard), so the energy it reports
// still never rises.
#pragma once

#include <Eigen/Core>
#include <deque>

namespace diffreg {

class AndersonMixer {
 public:
  /// `history` m >= 1 differences kept.
  explicit AndersonMixer(int history) : history_(history) {}

  /// Forgets every earlier pair.
  void reset();
  /// Records the pair (x, G(x)) and writes the accelerated next iterate to `next`. Returns false
  /// (and leaves `next` alone) while there is no earlier pair, or when the least-squares
  /// problem is degenerate: the caller then takes G(x) itself.
  bool mix(const Eigen::MatrixXd& x, const Eigen::MatrixXd& g, Eigen::MatrixXd& next);

 private:
  int history_;
  Eigen::MatrixXd lastF_, lastG_;
  std::deque<Eigen::MatrixXd> dF_, dG_;
};

}  // namespace diffreg
