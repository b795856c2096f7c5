#include <diffreg/deformation/regularizer.h>

#include <diffreg/core/error.h>
#include <diffreg/core/text.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

namespace diffreg {

namespace {

// Non-uniform weights must lie in [0, 1] (beta_k > 1 would make (1 - beta_k) a_k negative).
// The error names the vertex farthest outside and by how much. A vertex that no element uses
// enters no beta_k or beta_kl, so its value is not looked at.
void checkVertexWeights(const Eigen::VectorXd& x, const std::vector<bool>& active) {
  int worst = -1;
  double excess = 0.0;
  for (int i = 0; i < x.size(); ++i) {
    if (!active[static_cast<size_t>(i)]) continue;
    const double e = std::isnan(x(i)) ? INFINITY : std::max(x(i) - 1.0, -x(i));
    if (e > excess) {
      excess = e;
      worst = i;
    }
  }
  if (worst < 0) return;
  // Above 1 as 1 + the excess: ten digits of the value would print 1 for an excess of 1e-12.
  const double v = x(worst);
  char value[48];
  if (v > 1.0)
    std::snprintf(value, sizeof value, "1 + %.3g", v - 1.0);
  else
    std::snprintf(value, sizeof value, "%.3g", v);
  throw InvalidParameter(
      "regularization: the weight of vertex " + std::to_string(worst) + " is " + value +
      ", outside [0, 1]" +
      (v > 1.0 ? " (from rbf_weights, the summed Gaussians exceed 1 where another handle's "
                 "reaches a handle: rbf_weights clamp=true clamps them)"
               : ""));
}

}  // namespace

RegularizationWeights makeRegularizationWeights(const Discretization& disc, Regularization mode,
                                                double beta, const Eigen::VectorXd& x) {
  const int m = disc.numElements();
  const auto& facets = disc.facets();
  const int nf = static_cast<int>(facets.size());
  RegularizationWeights w;
  switch (mode) {
    case Regularization::None:
      w.element.setZero(m);
      w.facet.setZero(nf);
      break;
    case Regularization::Uniform:
      if (!(beta >= 0.0 && beta <= 1.0))
        throw InvalidParameter("regularization: beta = " + formatNumber(beta) +
                               " is outside [0, 1]");
      w.element.setConstant(m, beta);
      w.facet.setConstant(nf, beta);
      break;
    case Regularization::Nonuniform: {
      if (x.size() != disc.numVertices())
        throw InvalidParameter("regularization: " + std::to_string(x.size()) +
                               " vertex weights for a mesh of " +
                               std::to_string(disc.numVertices()) + " vertices");
      checkVertexWeights(x, disc.active());
      const Eigen::MatrixXi& el = disc.elements();
      w.element.resize(m);
      for (int k = 0; k < m; ++k) {
        double sum = 0.0;
        for (int i = 0; i < el.cols(); ++i) sum += x(el(k, i));
        w.element(k) = sum / static_cast<double>(el.cols());
      }
      w.facet.resize(nf);
      for (int f = 0; f < nf; ++f) {
        double sum = 0.0;
        for (int i = 0; i < facets[f].size; ++i) sum += x(facets[f].vertices[i]);
        w.facet(f) = sum / static_cast<double>(facets[f].size);
      }
      break;
    }
  }
  return w;
}

Regularizer::Regularizer(const Discretization& disc) : disc_(disc) {
  const int m = disc.numElements();
  const auto& facets = disc.facets();
  facetStart_.assign(static_cast<size_t>(m) + 1, 0);
  for (const Facet& f : facets) {
    ++facetStart_[static_cast<size_t>(f.k) + 1];
    ++facetStart_[static_cast<size_t>(f.l) + 1];
  }
  for (int k = 0; k < m; ++k) facetStart_[k + 1] += facetStart_[k];
  elementFacets_.resize(static_cast<size_t>(facetStart_[m]));
  neighbour_.resize(elementFacets_.size());
  std::vector<int> fill(facetStart_.begin(), facetStart_.end() - 1);
  for (size_t f = 0; f < facets.size(); ++f) {
    const int atK = fill[facets[f].k]++, atL = fill[facets[f].l]++;
    elementFacets_[atK] = elementFacets_[atL] = static_cast<int>(f);
    neighbour_[atK] = facets[f].l;
    neighbour_[atL] = facets[f].k;
  }
  setWeights(makeRegularizationWeights(disc, Regularization::None, 0.0));
}

void Regularizer::setWeights(const RegularizationWeights& weights) {
  const auto& facets = disc_.facets();
  const double ell = disc_.meanEdgeLength();
  weights_ = weights;
  elementWeight_ = (1.0 - weights.element.array()) * disc_.measures().array();
  facetWeight_.resize(static_cast<Eigen::Index>(facets.size()));
  coupling_ = false;
  for (size_t f = 0; f < facets.size(); ++f) {
    const double w = ell * weights.facet(static_cast<Eigen::Index>(f)) * facets[f].c;
    facetWeight_(static_cast<Eigen::Index>(f)) = w;
    if (w != 0.0) coupling_ = true;
  }
  weak_.clear();
  weakColours_.clear();
  weakDone_ = false;
}

const std::vector<std::vector<int>>& Regularizer::weakComponents() const {
  findWeak();
  return weak_;
}

const std::vector<std::vector<int>>& Regularizer::weakColours() const {
  findWeak();
  return weakColours_;
}

int Regularizer::numWeak() const {
  int n = 0;
  for (const std::vector<int>& c : weakComponents()) n += static_cast<int>(c.size());
  return n;
}

void Regularizer::findWeak() const {
  if (weakDone_) return;
  const int m = disc_.numElements();
  weak_.clear();
  weakColours_.clear();
  weakFlag_.assign(static_cast<size_t>(m), 0);
  std::vector<char>& weak = weakFlag_;
  for (int k = 0; k < m && coupling_; ++k) {
    double coupled = 0.0;
    for (int g = facetBegin(k); g < facetEnd(k); ++g) coupled += neighbourWeight(g);
    weak[static_cast<size_t>(k)] = coupled > 0.0 && elementWeight_(k) <= kWeakAnchor * coupled;
  }
  std::vector<char> seen(static_cast<size_t>(m), 0);
  std::vector<int> stack;
  for (int start = 0; start < m; ++start) {
    if (!weak[static_cast<size_t>(start)] || seen[static_cast<size_t>(start)]) continue;
    std::vector<int> component;
    stack.assign(1, start);
    seen[static_cast<size_t>(start)] = 1;
    while (!stack.empty()) {
      const int k = stack.back();
      stack.pop_back();
      component.push_back(k);
      for (int g = facetBegin(k); g < facetEnd(k); ++g) {
        const int l = neighbour(g);
        if (weak[static_cast<size_t>(l)] && !seen[static_cast<size_t>(l)]) {
          seen[static_cast<size_t>(l)] = 1;
          stack.push_back(l);
        }
      }
    }
    std::sort(component.begin(), component.end());
    weak_.push_back(std::move(component));
  }
  if (!weak_.empty())
    for (const std::vector<int>& ids : colours()) {
      std::vector<int> part;
      for (int k : ids)
        if (weak[static_cast<size_t>(k)]) part.push_back(k);
      if (!part.empty()) weakColours_.push_back(std::move(part));
    }
  weakDone_ = true;
}

const std::vector<std::vector<int>>& Regularizer::colours() const {
  if (!colours_.empty() || disc_.numElements() == 0) return colours_;
  const int m = disc_.numElements();
  std::vector<int> colour(static_cast<size_t>(m), -1), taken;
  for (int k = 0; k < m; ++k) {
    taken.assign(static_cast<size_t>(facetEnd(k) - facetBegin(k) + 1), 0);
    for (int g = facetBegin(k); g < facetEnd(k); ++g) {
      const int c = colour[static_cast<size_t>(neighbour(g))];
      if (c >= 0 && c < static_cast<int>(taken.size())) taken[static_cast<size_t>(c)] = 1;
    }
    int c = 0;
    while (taken[static_cast<size_t>(c)]) ++c;
    colour[static_cast<size_t>(k)] = c;
    if (c >= static_cast<int>(colours_.size())) colours_.resize(static_cast<size_t>(c) + 1);
    colours_[static_cast<size_t>(c)].push_back(k);
  }
  return colours_;
}

}  // namespace diffreg
