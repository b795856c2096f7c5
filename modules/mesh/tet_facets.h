// The facets of every tet of a tet mesh, grouped by their vertices: tets that share a facet
// (the discretization's adjacency, the readers' check that tets make a solid) and facets of one
// tet only (the boundary surface).
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace diffreg {

/// The facets of a positively oriented tet (a, b, c, d) in their outward vertex order, the one
/// opposite vertex i first: kOutwardFacet[i].
inline constexpr int kOutwardFacet[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};

/// Facet `opposite` of tet `tet` (the one without its vertex `opposite`, 0-3). Its smallest
/// vertex is its group's (TetFacets); `rest` holds the other two, the middle one in the high
/// half. `odd`: sorting its outward vertex order (kOutwardFacet) took an odd permutation, which
/// tells the side of the facet its tet lies on. 16 bytes, so that sorting moves little.
struct TetFacet {
  std::uint64_t rest;
  int tet;
  std::uint8_t opposite;
  bool odd;
};

/// Every tet's four facets grouped by their smallest vertex v (facets[start[v] .. start[v + 1])),
/// each group ordered by `rest`, then tet: the order of one sort of them all by their sorted
/// vertices, at a fraction of its cost. A tet has a facet twice only with a repeated vertex,
/// which no mesh that passed its checks has.
struct TetFacets {
  std::vector<int> start;
  std::vector<TetFacet> facets;
};

/// The facets of `tets` tets over `vertices` vertices (vertexOf(k, j): vertex j of tet k, in
/// [0, vertices)).
template <class VertexOf>
TetFacets sortedTetFacets(int tets, int vertices, const VertexOf& vertexOf) {
  // Made twice (to count the groups, then into them) rather than kept in an array of all
  // facets between the two passes. Returns the smallest vertex.
  const auto facet = [&vertexOf](int k, int i, TetFacet& f) {
    int v[3] = {vertexOf(k, kOutwardFacet[i][0]), vertexOf(k, kOutwardFacet[i][1]),
                vertexOf(k, kOutwardFacet[i][2])};
    bool odd = false;
    // Three compare-exchanges; std::sort's general loop costs more than the rest of the facet.
    if (v[0] > v[1]) std::swap(v[0], v[1]), odd = !odd;
    if (v[1] > v[2]) std::swap(v[1], v[2]), odd = !odd;
    if (v[0] > v[1]) std::swap(v[0], v[1]), odd = !odd;
    f = {(std::uint64_t(static_cast<unsigned>(v[1])) << 32) | static_cast<unsigned>(v[2]), k,
         static_cast<std::uint8_t>(i), odd};
    return v[0];
  };
  TetFacets out;
  std::vector<int>& start = out.start;
  start.assign(static_cast<std::size_t>(vertices) + 1, 0);
  TetFacet f{};
  for (int k = 0; k < tets; ++k)
    for (int i = 0; i < 4; ++i) ++start[static_cast<std::size_t>(facet(k, i, f)) + 1];
  for (int v = 0; v < vertices; ++v)
    start[static_cast<std::size_t>(v) + 1] += start[static_cast<std::size_t>(v)];
  out.facets.resize(static_cast<std::size_t>(tets) * 4);
  {
    std::vector<int> fill(start.begin(), start.end() - 1);
    for (int k = 0; k < tets; ++k)
      for (int i = 0; i < 4; ++i) {
        const int v = facet(k, i, f);
        out.facets[static_cast<std::size_t>(fill[static_cast<std::size_t>(v)]++)] = f;
      }
  }
  for (int v = 0; v < vertices; ++v)
    std::sort(out.facets.begin() + start[static_cast<std::size_t>(v)],
              out.facets.begin() + start[static_cast<std::size_t>(v) + 1],
              [](const TetFacet& a, const TetFacet& b) {
                return a.rest != b.rest ? a.rest < b.rest : a.tet < b.tet;
              });
  return out;
}

/// Calls visit(key, first, count) for each distinct facet, in the order of `key`, its sorted
/// vertices: first[0 .. count) are the tets' facets on it (two on an interior facet of a solid,
/// one on its boundary).
template <class Visit>
void forEachFacet(const TetFacets& t, const Visit& visit) {
  const int vertices = static_cast<int>(t.start.size()) - 1;
  for (int v = 0; v < vertices; ++v) {
    const int end = t.start[static_cast<std::size_t>(v) + 1];
    for (int i = t.start[static_cast<std::size_t>(v)]; i < end;) {
      const TetFacet* first = t.facets.data() + i;
      int j = i + 1;
      while (j < end && t.facets[static_cast<std::size_t>(j)].rest == first->rest) ++j;
      const std::array<int, 3> key{v, static_cast<int>(first->rest >> 32),
                                   static_cast<int>(first->rest & 0xffffffffu)};
      visit(key, first, j - i);
      i = j;
    }
  }
}

}  // namespace diffreg
