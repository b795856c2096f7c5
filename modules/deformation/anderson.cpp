#include <diffreg/deformation/anderson.h>

#include <Eigen/Dense>
#include <cmath>

namespace diffreg {

void AndersonMixer::reset() {
  lastF_.resize(0, 0);
  lastG_.resize(0, 0);
  dF_.clear();
  dG_.clear();
}

bool AndersonMixer::mix(const Eigen::MatrixXd& x, const Eigen::MatrixXd& g, Eigen::MatrixXd& next) {
  Eigen::MatrixXd f = g - x;
  const bool haveLast = lastF_.size() == f.size();
  if (haveLast) {
    dF_.push_back(f - lastF_);
    dG_.push_back(g - lastG_);
    if (static_cast<int>(dF_.size()) > history_) {
      dF_.pop_front();
      dG_.pop_front();
    }
  }
  lastF_ = std::move(f);
  lastG_ = g;
  if (dF_.empty()) return false;
  // Normal equations of the small least-squares problem, solved by a rank-revealing
  // decomposition (the differences become nearly dependent close to convergence).
  const int m = static_cast<int>(dF_.size());
  Eigen::MatrixXd gram(m, m);
  Eigen::VectorXd rhs(m);
  for (int i = 0; i < m; ++i) {
    rhs(i) = dF_[static_cast<size_t>(i)].cwiseProduct(lastF_).sum();
    for (int j = 0; j <= i; ++j)
      gram(i, j) = gram(j, i) = dF_[static_cast<size_t>(i)].cwiseProduct(dF_[static_cast<size_t>(j)]).sum();
  }
  const Eigen::VectorXd theta = gram.completeOrthogonalDecomposition().solve(rhs);
  if (!theta.allFinite()) return false;
  next = g;
  for (int i = 0; i < m; ++i) next -= theta(i) * dG_[static_cast<size_t>(i)];
  return next.allFinite();
}

}  // namespace diffreg
