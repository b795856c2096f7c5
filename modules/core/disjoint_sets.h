// Disjoint sets of 0..n-1 (union-find): the connected components of meshes, from their elements.
#pragma once

#include <cstddef>
#include <numeric>
#include <utility>
#include <vector>

namespace diffreg {

/// Union-find with path halving, each union linking the larger root under the smaller, so that
/// a set's root is its smallest member. A mesh's unions, element by element, otherwise build
/// long chains for find() to walk (linking find(a)'s root under find(b)'s took twice the time
/// on the shared meshes).
class DisjointSets {
 public:
  explicit DisjointSets(int n) : parent_(static_cast<std::size_t>(n)) {
    std::iota(parent_.begin(), parent_.end(), 0);
  }
  /// The smallest member of i's set.
  int find(int i) {
    while (parent_[static_cast<std::size_t>(i)] != i) {
      int& up = parent_[static_cast<std::size_t>(i)];
      up = parent_[static_cast<std::size_t>(up)];
      i = up;
    }
    return i;
  }
  /// Joins the sets of a and b.
  void unite(int a, int b) {
    a = find(a);
    b = find(b);
    if (a == b) return;
    if (a < b) std::swap(a, b);
    parent_[static_cast<std::size_t>(a)] = b;
  }

 private:
  std::vector<int> parent_;
};

}  // namespace diffreg
