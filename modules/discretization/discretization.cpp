#include "discretization/discretization.h"

#include "core/error.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>

namespace diffreg {
namespace {

// Union-find for the connected components of the element graph.
struct DisjointSets {
  std::vector<int> parent;
  explicit DisjointSets(int n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
  int find(int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  }
  void unite(int a, int b) { parent[find(a)] = find(b); }
};

// One (sorted vertex key, element) record per element facet, for adjacency by sorting.
struct FacetRecord {
  std::array<int, 3> key;
  int element;
  bool operator<(const FacetRecord& o) const {
    return key != o.key ? key < o.key : element < o.element;
  }
};

}  // namespace

Discretization::Discretization(const Mesh& mesh) {
  build(mesh.kind(), mesh.positions(), mesh.elements());
}

Discretization::Discretization(MeshKind kind, const Eigen::MatrixXd& positions,
                               const Eigen::MatrixXi& elements) {
  build(kind, positions, elements);
}

Eigen::MatrixXd Discretization::restFrame(int e) const {
  if (kind_ != MeshKind::Surface) return Eigen::MatrixXd::Identity(dim_, dim_);
  const Eigen::Vector3d n = normals_.row(e).transpose();
  return Eigen::Matrix3d::Identity() - n * n.transpose();
}

void Discretization::build(MeshKind kind, const Eigen::MatrixXd& positions,
                           const Eigen::MatrixXi& elements) {
  kind_ = kind;
  dim_ = kind == MeshKind::Planar ? 2 : 3;
  const int n = static_cast<int>(positions.rows());
  const int m = static_cast<int>(elements.rows());
  const int k = kind == MeshKind::Tet ? 4 : 3;
  if (positions.cols() < 3 && kind != MeshKind::Planar)
    throw InvalidMesh("discretization: positions need 3 columns");
  if (elements.cols() != k)
    throw InvalidMesh("discretization: " + std::string(toString(kind)) + " elements need " +
                      std::to_string(k) + " vertices each");
  if (m == 0) throw InvalidMesh("discretization: the mesh has no elements");
  for (int e = 0; e < m; ++e)
    for (int i = 0; i < k; ++i)
      if (elements(e, i) < 0 || elements(e, i) >= n)
        throw InvalidMesh("discretization: element " + std::to_string(e) + " has vertex index " +
                          std::to_string(elements(e, i)) + " out of range [0, " +
                          std::to_string(n) + ")");
  rest_ = positions.leftCols(dim_);
  elements_ = elements;
  Eigen::MatrixXd P3 = Eigen::MatrixXd::Zero(n, 3);
  P3.leftCols(std::min<int>(3, static_cast<int>(positions.cols()))) =
      positions.leftCols(std::min<int>(3, static_cast<int>(positions.cols())));

  // Facets (for adjacency) and unique edges (for the mean edge length), by sorting.
  const int facetSize = k - 1;
  std::vector<FacetRecord> facetRecords;
  facetRecords.reserve(static_cast<size_t>(m) * k);
  std::vector<std::pair<int, int>> edges;
  edges.reserve(static_cast<size_t>(m) * (k == 4 ? 6 : 3));
  for (int e = 0; e < m; ++e) {
    for (int i = 0; i < k; ++i) {
      FacetRecord r{{-1, -1, -1}, e};
      int c = 0;
      for (int j = 0; j < k; ++j)
        if (j != i) r.key[c++] = elements(e, j);
      std::sort(r.key.begin(), r.key.begin() + facetSize);
      facetRecords.push_back(r);
      for (int j = i + 1; j < k; ++j) {
        const int a = elements(e, i), b = elements(e, j);
        edges.emplace_back(std::min(a, b), std::max(a, b));
      }
    }
  }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  double edgeSum = 0.0;
  for (const auto& [a, b] : edges) edgeSum += (P3.row(a) - P3.row(b)).norm();
  meanEdge_ = edgeSum / static_cast<double>(edges.size());
  const double tinyMeasure = 1e-14 * std::pow(meanEdge_, kind == MeshKind::Tet ? 3 : 2);

  // Per-element gradients and measures. Edge vectors E = [p1-p0, p2-p0 (, p3-p0)]; the hat
  // gradients g_1..g_{k-1} are the columns of E (E^T E)^-1 (the dual basis in the element's
  // span), g_0 = -sum of the others. For tets E is square and this is E^-T.
  measures_.resize(m);
  grads_.resize(static_cast<Eigen::Index>(m) * k, dim_);
  if (kind == MeshKind::Surface) normals_.resize(m, 3);
  std::vector<Eigen::Triplet<double>> kTriplets;
  kTriplets.reserve(static_cast<size_t>(m) * k * k);
  mass_ = Eigen::VectorXd::Zero(n);
  for (int e = 0; e < m; ++e) {
    Eigen::Matrix<double, 3, Eigen::Dynamic> E(3, k - 1);
    for (int j = 1; j < k; ++j)
      E.col(j - 1) = (P3.row(elements(e, j)) - P3.row(elements(e, 0))).transpose();
    double measure;
    if (k == 4) {
      measure = E.determinant() / 6.0;
      if (measure <= tinyMeasure)
        throw InvalidMesh("discretization: tet " + std::to_string(e) +
                          (measure < 0 ? " is inverted" : " is degenerate (zero volume)"));
    } else {
      const Eigen::Vector3d cr = E.col(0).cross(E.col(1));
      measure = 0.5 * cr.norm();
      if (measure <= tinyMeasure)
        throw InvalidMesh("discretization: triangle " + std::to_string(e) +
                          " is degenerate (zero area)");
      if (kind == MeshKind::Surface) normals_.row(e) = cr.normalized().transpose();
    }
    const Eigen::MatrixXd dual = E * (E.transpose() * E).inverse();  // 3 x (k-1)
    Eigen::MatrixXd g(k, 3);
    g.bottomRows(k - 1) = dual.transpose();
    g.row(0) = -g.bottomRows(k - 1).colwise().sum();
    grads_.block(static_cast<Eigen::Index>(e) * k, 0, k, dim_) = g.leftCols(dim_);
    measures_(e) = measure;
    const Eigen::MatrixXd Ke = measure * g * g.transpose();
    for (int i = 0; i < k; ++i) {
      mass_(elements(e, i)) += measure / k;
      for (int j = 0; j < k; ++j)
        kTriplets.emplace_back(elements(e, i), elements(e, j), Ke(i, j));
    }
  }
  K_.resize(n, n);
  K_.setFromTriplets(kTriplets.begin(), kTriplets.end());
  K_.makeCompressed();

  // Interior facets: records with equal keys belong to neighbouring elements.
  std::sort(facetRecords.begin(), facetRecords.end());
  facets_.clear();
  for (size_t i = 0; i < facetRecords.size();) {
    size_t j = i + 1;
    while (j < facetRecords.size() && facetRecords[j].key == facetRecords[i].key) ++j;
    const auto& key = facetRecords[i].key;
    double c;
    if (facetSize == 2) {
      c = (P3.row(key[0]) - P3.row(key[1])).norm();
    } else {
      const Eigen::Vector3d a = (P3.row(key[1]) - P3.row(key[0])).transpose();
      const Eigen::Vector3d b = (P3.row(key[2]) - P3.row(key[0])).transpose();
      c = 0.5 * a.cross(b).norm();
    }
    // Every pair of elements on the facet (exactly one pair on a manifold mesh).
    for (size_t a = i; a < j; ++a)
      for (size_t b = a + 1; b < j; ++b) {
        Facet f;
        f.k = facetRecords[a].element;
        f.l = facetRecords[b].element;
        f.c = c;
        f.size = facetSize;
        for (int v = 0; v < facetSize; ++v) f.vertices[v] = key[v];
        facets_.push_back(f);
      }
    i = j;
  }

  // Referenced vertices, components and the bounding box of the referenced vertices.
  active_.assign(n, false);
  DisjointSets sets(n);
  for (int e = 0; e < m; ++e)
    for (int i = 0; i < k; ++i) {
      active_[elements(e, i)] = true;
      sets.unite(elements(e, 0), elements(e, i));
    }
  component_.assign(n, -1);
  std::vector<int> rootId(n, -1);
  numComponents_ = 0;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(INFINITY), hi = -lo;
  for (int v = 0; v < n; ++v) {
    if (!active_[v]) continue;
    const int r = sets.find(v);
    if (rootId[r] < 0) rootId[r] = numComponents_++;
    component_[v] = rootId[r];
    lo = lo.cwiseMin(P3.row(v).transpose());
    hi = hi.cwiseMax(P3.row(v).transpose());
  }
  diagonal_ = (hi - lo).norm();
}

}  // namespace diffreg
