#include <diffreg/deformation/lbfgs.h>

#include <vector>

namespace diffreg {

namespace {

double dot(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return a.cwiseProduct(b).sum();
}

}  // namespace

void LbfgsHistory::reset() {
  s_.clear();
  y_.clear();
  rho_.clear();
}

bool LbfgsHistory::add(Eigen::MatrixXd s, Eigen::MatrixXd y) {
  const double sy = dot(s, y);
  if (!(sy > 1e-14 * std::sqrt(dot(s, s) * dot(y, y)))) return false;
  s_.push_back(std::move(s));
  y_.push_back(std::move(y));
  rho_.push_back(1.0 / sy);
  if (static_cast<int>(s_.size()) > pairs_) {
    s_.pop_front();
    y_.pop_front();
    rho_.pop_front();
  }
  return true;
}

Eigen::MatrixXd LbfgsHistory::direction(
    const Eigen::MatrixXd& g,
    const std::function<Eigen::MatrixXd(const Eigen::MatrixXd&)>& initial) const {
  const int m = size();
  std::vector<double> alpha(static_cast<size_t>(m));
  Eigen::MatrixXd q = g;
  for (int i = m - 1; i >= 0; --i) {
    alpha[static_cast<size_t>(i)] = rho_[static_cast<size_t>(i)] * dot(s_[static_cast<size_t>(i)], q);
    q -= alpha[static_cast<size_t>(i)] * y_[static_cast<size_t>(i)];
  }
  Eigen::MatrixXd r = initial(q);
  q.resize(0, 0);  // not needed beside r (peak memory of a million-vertex session)
  for (int i = 0; i < m; ++i) {
    const double beta = rho_[static_cast<size_t>(i)] * dot(y_[static_cast<size_t>(i)], r);
    r += (alpha[static_cast<size_t>(i)] - beta) * s_[static_cast<size_t>(i)];
  }
  r *= -1.0;
  return r;
}

}  // namespace diffreg
