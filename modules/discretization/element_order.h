// The order in which a deformation session stores a mesh's elements. The exact local step's
// sweeps read every element's and its neighbours' blocks several times per iteration; when
// neighbours sit far apart in storage (meshes written in no spatial order: on the shared
// armadillo 83% of the facets join elements more than 256 apart), most of those reads miss the
// cache once the blocks outgrow it. Elements sorted along a Morton (Z-order) curve of their
// centroids keep neighbours close. Non-uniform ARAP on the armadillo, 100 iterations: 8.2-8.7 s
// -> 5.2-5.7 s; to the default stop 197 s -> 105 s (docs/benchmarks.md, "Elements in locality
// order").
#pragma once

#include <diffreg/discretization/discretization.h>

#include <vector>

namespace diffreg {

/// Elements per mesh below which the order is left alone: their blocks stay in cache.
constexpr int kLocalityMinElements = 4096;
/// Facets joining elements more than kLocalityReach apart in storage count as far; the order is
/// changed when more than kLocalityFarShare of them are far (the median facet is far). Meshes
/// generated in rows keep theirs: one facet in three of a triangle grid joins two rows, far
/// apart on a large grid but in a regular stride that streams through the cache (and a copy of
/// the 1M-vertex sphere's discretization would cost 500 MB).
constexpr int kLocalityReach = 256;
constexpr double kLocalityFarShare = 0.5;

/// The share of `disc`'s interior facets whose two elements are more than kLocalityReach apart.
double farFacetShare(const Discretization& disc);

/// The elements sorted by the Morton code of their centroids in the centroids' bounding box
/// (21 bits per axis; ties by index): order[i] is the element stored i-th.
std::vector<int> mortonElementOrder(const Discretization& disc);

/// mortonElementOrder() when `disc` has at least kLocalityMinElements elements and more than
/// kLocalityFarShare of its facets are far (farFacetShare); empty when its order is kept.
std::vector<int> localityElementOrder(const Discretization& disc);

}  // namespace diffreg
