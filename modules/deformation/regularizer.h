// The energy-smoothness regularizer of Martinez Esturo et al. (docs/method.md, "The
// regularizer"): S = sum_(k,l) c_kl ||e_k - e_l||^2 over interior facets, blended with the
// energy uniformly (eq. 2) or per element and facet (eq. 3):
//
//     E = sum_k (1 - beta_k) a_k D_k + sum_(k,l) beta_kl c_kl ||e_k - e_l||^2.
//
// This unit owns beta_k and beta_kl, the weights w_k = (1 - beta_k) a_k and
// w_kl = ell beta_kl c_kl they give (ell the mean rest edge length, so that a_k and c_kl are
// measured on the mesh scaled to unit mean edge length up to one common factor), the
// element-facet incidence the coupling assembly walks, and the colouring of the element
// adjacency graph that the exact local step sweeps.
#pragma once

#include <diffreg/deformation/energy.h>

#include <Eigen/Core>
#include <vector>

namespace diffreg {

/// An element is weakly anchored when its own weight w_k is at most this fraction of its
/// facets' weights sum_l w_kl (beta_k above about 0.93 on a regular triangle mesh).
constexpr double kWeakAnchor = 0.01;

class Regularizer {
 public:
  /// Element-facet incidence of `disc` (which must outlive this); no regularization.
  explicit Regularizer(const Discretization& disc);

  void setWeights(const RegularizationWeights& weights);
  const RegularizationWeights& weights() const { return weights_; }
  /// w_k = (1 - beta_k) a_k per element.
  const Eigen::VectorXd& elementWeight() const { return elementWeight_; }
  /// w_kl = ell beta_kl c_kl per facet.
  const Eigen::VectorXd& facetWeight() const { return facetWeight_; }
  /// True when some facet weight is nonzero: the elements' targets are coupled.
  bool coupling() const { return coupling_; }

  /// The facets of element k are incidence entries [facetBegin(k), facetEnd(k)).
  int facetBegin(int k) const { return facetStart_[static_cast<size_t>(k)]; }
  int facetEnd(int k) const { return facetStart_[static_cast<size_t>(k) + 1]; }
  /// Incidence entry g: its facet, the element on the other side, and w_kl.
  int facet(int g) const { return elementFacets_[static_cast<size_t>(g)]; }
  int neighbour(int g) const { return neighbour_[static_cast<size_t>(g)]; }
  double neighbourWeight(int g) const { return facetWeight_(elementFacets_[static_cast<size_t>(g)]); }

  /// Elements grouped by colour: no two elements of one colour share a facet, so the exact
  /// local step may update a colour's elements at once. Greedy, in element order (computed on
  /// first use; at most 1 + the largest number of facets of an element colours).
  const std::vector<std::vector<int>>& colours() const;

  /// The weakly anchored elements, w_k <= kWeakAnchor sum_l w_kl (beta_k = 1 inside a handle of
  /// magnitude 1, or nearly so), by connected component (facet adjacency). Only their
  /// neighbours hold their targets: a component's targets turning together barely change the
  /// energy, so sweeps settle that turn only slowly. Computed on first use after setWeights().
  const std::vector<std::vector<int>>& weakComponents() const;
  /// colours() restricted to the weakly anchored elements (empty colours left out).
  const std::vector<std::vector<int>>& weakColours() const;
  /// Number of weakly anchored elements.
  int numWeak() const;
  /// Whether element k is weakly anchored (after weakComponents() or numWeak()).
  bool weak(int k) const { return weakFlag_[static_cast<size_t>(k)] != 0; }

 private:
  const Discretization& disc_;
  RegularizationWeights weights_;
  Eigen::VectorXd elementWeight_, facetWeight_;
  bool coupling_ = false;
  std::vector<int> facetStart_, elementFacets_, neighbour_;
  void findWeak() const;
  // Computed on first use (single-threaded use of a const Regularizer, as for colours_).
  mutable std::vector<std::vector<int>> colours_, weak_, weakColours_;
  mutable std::vector<char> weakFlag_;
  mutable bool weakDone_ = false;
};

}  // namespace diffreg
