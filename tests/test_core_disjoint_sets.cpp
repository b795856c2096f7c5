// DisjointSets (modules/core/disjoint_sets.h): the sets of the unions made, rooted at their
// smallest member.
#include <diffreg/core/disjoint_sets.h>

#include <catch2/catch.hpp>

#include <algorithm>
#include <random>
#include <utility>
#include <vector>

using diffreg::DisjointSets;

TEST_CASE("disjoint sets: the components of the unions, each found as its smallest member",
          "[core]") {
  std::mt19937 rng(11);
  for (int n : {1, 2, 17, 300}) {
    for (int unions : {0, n / 3, n, 3 * n}) {
      INFO(n << " elements, " << unions << " unions");
      DisjointSets sets(n);
      std::vector<std::vector<int>> graph(static_cast<size_t>(n));
      std::uniform_int_distribution<int> pick(0, n - 1);
      for (int u = 0; u < unions; ++u) {
        const int a = pick(rng), b = pick(rng);
        sets.unite(a, b);
        graph[static_cast<size_t>(a)].push_back(b);
        graph[static_cast<size_t>(b)].push_back(a);
      }
      // The components by search over the same pairs, labelled by their smallest member.
      std::vector<int> label(static_cast<size_t>(n), -1);
      for (int s = 0; s < n; ++s) {
        if (label[static_cast<size_t>(s)] >= 0) continue;
        std::vector<int> stack{s};
        label[static_cast<size_t>(s)] = s;
        while (!stack.empty()) {
          const int v = stack.back();
          stack.pop_back();
          for (int w : graph[static_cast<size_t>(v)])
            if (label[static_cast<size_t>(w)] < 0) {
              label[static_cast<size_t>(w)] = s;
              stack.push_back(w);
            }
        }
      }
      for (int v = 0; v < n; ++v) {
        CHECK(sets.find(v) == label[static_cast<size_t>(v)]);
        CHECK(sets.find(sets.find(v)) == sets.find(v));
      }
    }
  }
}
