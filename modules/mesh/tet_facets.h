// The facets of every tet of a tet mesh, grouped by their vertices: tets that share a facet
// (the discretization's adjacency) and facets of one tet only (the boundary surface).
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <vector>

namespace diffreg {

/// Facet `opposite` of tet `tet` (the one without its vertex `opposite`, 0-3), its three
/// vertices sorted in `key`.
struct TetFacet {
  std::array<int, 3> key;
  int tet;
  int opposite;
  bool operator<(const TetFacet& o) const {  // by key, then tet (no memcmp call)
    if (key[0] != o.key[0]) return key[0] < o.key[0];
    if (key[1] != o.key[1]) return key[1] < o.key[1];
    if (key[2] != o.key[2]) return key[2] < o.key[2];
    if (tet != o.tet) return tet < o.tet;
    return opposite < o.opposite;
  }
  bool sameKey(const TetFacet& o) const {
    return key[0] == o.key[0] && key[1] == o.key[1] && key[2] == o.key[2];
  }
};

/// The four facets of each of `tets` tets over `vertices` vertices (vertexOf(k, j): vertex j of
/// tet k, in [0, vertices)), ordered by key, then tet: bucketed by their smallest vertex and
/// each bucket sorted, the order of one sort of them all at a fraction of its cost.
template <class VertexOf>
std::vector<TetFacet> sortedTetFacets(int tets, int vertices, const VertexOf& vertexOf) {
  // Made twice (to count the buckets, then into them) rather than kept in an array of all
  // facets between the two passes.
  const auto facet = [&vertexOf](int k, int i) {
    TetFacet f{{-1, -1, -1}, k, i};
    int c = 0;
    for (int j = 0; j < 4; ++j)
      if (j != i) f.key[static_cast<std::size_t>(c++)] = vertexOf(k, j);
    // Three compare-exchanges; std::sort's general loop costs more than the rest of the facet.
    if (f.key[0] > f.key[1]) std::swap(f.key[0], f.key[1]);
    if (f.key[1] > f.key[2]) std::swap(f.key[1], f.key[2]);
    if (f.key[0] > f.key[1]) std::swap(f.key[0], f.key[1]);
    return f;
  };
  std::vector<int> bucket(static_cast<std::size_t>(vertices) + 1, 0);
  for (int k = 0; k < tets; ++k)
    for (int i = 0; i < 4; ++i) ++bucket[static_cast<std::size_t>(facet(k, i).key[0]) + 1];
  for (int v = 0; v < vertices; ++v)
    bucket[static_cast<std::size_t>(v) + 1] += bucket[static_cast<std::size_t>(v)];
  std::vector<TetFacet> facets(static_cast<std::size_t>(tets) * 4);
  {
    std::vector<int> fill(bucket.begin(), bucket.end() - 1);
    for (int k = 0; k < tets; ++k)
      for (int i = 0; i < 4; ++i) {
        const TetFacet f = facet(k, i);
        facets[static_cast<std::size_t>(fill[static_cast<std::size_t>(f.key[0])]++)] = f;
      }
  }
  for (int v = 0; v < vertices; ++v)
    std::sort(facets.begin() + bucket[static_cast<std::size_t>(v)],
              facets.begin() + bucket[static_cast<std::size_t>(v) + 1]);
  return facets;
}

}  // namespace diffreg
