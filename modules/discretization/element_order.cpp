#include <diffreg/discretization/element_order.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <utility>

namespace diffreg {

namespace {

// The 21 low bits of x spread to every third bit.
std::uint64_t spread(std::uint64_t x) {
  x &= 0x1fffff;
  x = (x | x << 32) & 0x1f00000000ffffULL;
  x = (x | x << 16) & 0x1f0000ff0000ffULL;
  x = (x | x << 8) & 0x100f00f00f00f00fULL;
  x = (x | x << 4) & 0x10c30c30c30c30c3ULL;
  x = (x | x << 2) & 0x1249249249249249ULL;
  return x;
}

}  // namespace

double farFacetShare(const Discretization& disc) {
  const std::vector<Facet>& facets = disc.facets();
  if (facets.empty()) return 0.0;
  std::size_t far = 0;
  for (const Facet& f : facets) far += std::abs(f.k - f.l) > kLocalityReach;
  return static_cast<double>(far) / static_cast<double>(facets.size());
}

std::vector<int> mortonElementOrder(const Discretization& disc) {
  const int m = disc.numElements(), size = disc.elementSize(), d = disc.dim();
  if (m == 0) return {};
  // The centroids and their bounding box (unreferenced vertices left out).
  Eigen::MatrixXd centroid = Eigen::MatrixXd::Zero(m, d);
  for (int e = 0; e < m; ++e)
    for (int i = 0; i < size; ++i) centroid.row(e) += disc.rest().row(disc.elements()(e, i));
  centroid /= size;
  std::vector<std::pair<std::uint64_t, int>> keyed(static_cast<std::size_t>(m));  // ties by index
  const Eigen::RowVectorXd lo = centroid.colwise().minCoeff(), hi = centroid.colwise().maxCoeff();
  const double extent = (hi - lo).maxCoeff();
  const double scale = extent > 0.0 ? static_cast<double>(0x1fffff) / extent : 0.0;
  for (int e = 0; e < m; ++e) {
    std::uint64_t c = 0;
    for (int a = 0; a < d; ++a) {
      const double cell = (centroid(e, a) - lo(a)) * scale;
      c |= spread(static_cast<std::uint64_t>(cell > 0.0 ? std::min(cell, 2097151.0) : 0.0)) << a;
    }
    keyed[static_cast<std::size_t>(e)] = {c, e};
  }
  std::sort(keyed.begin(), keyed.end());
  std::vector<int> order(static_cast<std::size_t>(m));
  for (int i = 0; i < m; ++i)
    order[static_cast<std::size_t>(i)] = keyed[static_cast<std::size_t>(i)].second;
  return order;
}

std::vector<int> localityElementOrder(const Discretization& disc) {
  if (disc.numElements() < kLocalityMinElements || !(farFacetShare(disc) > kLocalityFarShare))
    return {};
  return mortonElementOrder(disc);
}

}  // namespace diffreg
