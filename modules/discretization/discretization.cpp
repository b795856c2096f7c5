#include <diffreg/discretization/discretization.h>

#include <diffreg/core/disjoint_sets.h>
#include <diffreg/core/error.h>
#include <diffreg/core/incidence.h>
#include <diffreg/mesh/halfedges.h>
#include <diffreg/mesh/tet_facets.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

namespace diffreg {

Eigen::MatrixXd Discretization::restFrame(int e) const {
  if (kind_ != MeshKind::Surface) return Eigen::MatrixXd::Identity(dim_, dim_);
  const Eigen::Vector3d n = normals_.row(e).transpose();
  return Eigen::Matrix3d::Identity() - n * n.transpose();
}

namespace {

// Which of the n vertices the elements use (indices checked), a byte each: the bounding box
// and the components take them from here.
std::vector<unsigned char> usedVertices(const Eigen::MatrixXi& elements, Eigen::Index n) {
  std::vector<unsigned char> used(static_cast<size_t>(n), 0);
  for (Eigen::Index j = 0; j < elements.cols(); ++j)
    for (Eigen::Index e = 0; e < elements.rows(); ++e)
      used[static_cast<size_t>(elements(e, j))] = 1;
  return used;
}

// The extent of the bounding box of the used rows of P3, each taken once (min and max do not
// depend on the order).
Eigen::Vector3d usedExtent(const Eigen::MatrixXd& P3, const std::vector<unsigned char>& used) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(INFINITY), hi = -lo;
  for (Eigen::Index v = 0; v < P3.rows(); ++v) {
    if (!used[static_cast<size_t>(v)]) continue;
    for (int c = 0; c < 3; ++c) {
      lo(c) = std::min(lo(c), P3(v, c));
      hi(c) = std::max(hi(c), P3(v, c));
    }
  }
  return hi - lo;
}

// Throws unless the diagonal of `extent` lies in [kMinMeshSize, kMaxMeshSize] (or is 0: the
// elements are then degenerate, and say so).
void checkSize(const Eigen::Vector3d& extent) {
  const double size = extent.stableNorm();  // no over- or underflow of the squares
  if (size > 0.0 && !(size >= kMinMeshSize && size <= kMaxMeshSize)) {
    char text[32];
    std::snprintf(text, sizeof text, "%.3g", size);
    throw InvalidMesh(std::string("discretization: the mesh's size (bounding-box diagonal ") +
                      text +
                      ") is outside [1e-30, 1e30], where its areas and volumes stay within "
                      "double precision; scale it");
  }
}

void checkElements(MeshKind kind, const Eigen::MatrixXd& positions, const Eigen::MatrixXi& elements,
                   int k) {
  const Eigen::Index n = positions.rows(), m = elements.rows();
  if (positions.cols() < 3 && kind != MeshKind::Planar)
    throw InvalidMesh("discretization: positions need 3 columns");
  if (elements.cols() != k)
    throw InvalidMesh("discretization: " + std::string(toString(kind)) + " elements need " +
                      std::to_string(k) + " vertices each");
  if (m == 0) throw InvalidMesh("discretization: the mesh has no elements");
  for (Eigen::Index e = 0; e < m; ++e)
    for (int i = 0; i < k; ++i)
      if (elements(e, i) < 0 || elements(e, i) >= n)
        throw InvalidMesh("discretization: element " + std::to_string(e) + " has vertex index " +
                          std::to_string(elements(e, i)) + " out of range [0, " +
                          std::to_string(n) + ")");
}

// The elements around each vertex of `elements` (n vertices), in element order: entries
// e * k + j for vertex elements(e, j).
Incidence elementsAround(const Eigen::MatrixXi& elements, int n) {
  const int k = static_cast<int>(elements.cols());
  return incidenceOf(
      n, static_cast<int>(elements.rows()), k, [&elements](int e, int j) { return elements(e, j); },
      [k](int e, int j) { return e * k + j; });
}

// The vertices that share an element with each vertex, itself included, as compressed rows:
// vertex v's are adjacency[start[v] .. start[v + 1]), sorted. From the elements `around` each
// vertex, each neighbour taken once (a stamp per vertex) in the order met; then the lists are
// transposed: the relation is symmetric, so transposing gives every vertex the same neighbours,
// now in increasing order (v is appended to the lists of its neighbours, v = 0, 1, ...), and
// the same counts. Two linear passes instead of a small sort per vertex.
template <int K>
void vertexAdjacencyOf(const Eigen::MatrixXi& elements, const Incidence& around,
                       std::vector<int>& start, std::vector<int>& adjacency) {
  const int n = static_cast<int>(around.start.size()) - 1;
  std::vector<int> stamp(static_cast<size_t>(n), -1), met;
  start.assign(static_cast<size_t>(n) + 1, 0);
  met.reserve(static_cast<size_t>(n) * (K == 4 ? 16 : 8));
  for (int v = 0; v < n; ++v) {
    for (int at = around.begin(v); at < around.end(v); ++at) {
      const int e = around.entries[static_cast<size_t>(at)] / K;
      for (int j = 0; j < K; ++j) {
        const int u = elements(e, j);
        if (stamp[static_cast<size_t>(u)] == v) continue;
        stamp[static_cast<size_t>(u)] = v;
        met.push_back(u);
      }
    }
    start[static_cast<size_t>(v) + 1] = static_cast<int>(met.size());
  }
  adjacency.resize(met.size());
  std::vector<int>& next = stamp;  // where each list's next entry goes
  std::copy(start.begin(), start.end() - 1, next.begin());
  for (int v = 0; v < n; ++v)
    for (int at = start[static_cast<size_t>(v)]; at < start[static_cast<size_t>(v) + 1]; ++at)
      adjacency[static_cast<size_t>(next[static_cast<size_t>(met[static_cast<size_t>(at)])]++)] = v;
}

void vertexAdjacency(const Eigen::MatrixXi& elements, const Incidence& around,
                     std::vector<int>& start, std::vector<int>& adjacency) {
  if (elements.cols() == 4)
    vertexAdjacencyOf<4>(elements, around, start, adjacency);
  else
    vertexAdjacencyOf<3>(elements, around, start, adjacency);
}

// Tets: the facets of every tet (for adjacency), sorted (mesh/tet_facets.h), and the mean
// length of the unique edges: the vertex adjacency's pairs a < b, summed in the order of (a, b).
double tetFacetsAndMeanEdge(const Eigen::MatrixXd& P3, const Eigen::MatrixXi& elements,
                            TetFacets& records, Incidence& around, std::vector<int>& start,
                            std::vector<int>& adjacency) {
  const int m = static_cast<int>(elements.rows()), n = static_cast<int>(P3.rows());
  records = sortedTetFacets(m, n, [&elements](int e, int j) { return elements(e, j); });
  around = elementsAround(elements, n);
  vertexAdjacency(elements, around, start, adjacency);
  double edgeSum = 0.0;
  std::size_t edges = 0;
  for (int a = 0; a < n; ++a)
    for (int at = start[a]; at < start[a + 1]; ++at) {
      const int b = adjacency[static_cast<size_t>(at)];
      if (b <= a) continue;
      edgeSum += (P3.row(a) - P3.row(b)).norm();
      ++edges;
    }
  return edgeSum / static_cast<double>(edges);
}

// Triangles: the interior edges of the OpenMesh mesh, each with its two faces (the smaller
// index first) and its sorted vertices, in the mesh's edge order; returns the mean length of
// all edges.
double edgeFacets(const Eigen::MatrixXd& P3, const TriMesh& tri, std::vector<Facet>& facets) {
  facets.clear();
  facets.reserve(tri.n_edges());
  double edgeSum = 0.0;
  for (const auto eh : tri.edges()) {
    const auto h0 = tri.halfedge_handle(eh, 0), h1 = tri.halfedge_handle(eh, 1);
    const int a = tri.from_vertex_handle(h0).idx(), b = tri.to_vertex_handle(h0).idx();
    const double length = (P3.row(a) - P3.row(b)).norm();
    edgeSum += length;
    const int f0 = tri.face_handle(h0).idx(), f1 = tri.face_handle(h1).idx();
    if (f0 < 0 || f1 < 0) continue;  // a boundary edge
    Facet f;
    f.k = std::min(f0, f1);
    f.l = std::max(f0, f1);
    f.c = length;
    f.size = 2;
    f.vertices = {std::min(a, b), std::max(a, b), 0};
    facets.push_back(f);
  }
  return edgeSum / static_cast<double>(tri.n_edges());
}

// Tets: interior facets from the sorted records: records with equal keys belong to
// neighbouring tets; every pair of tets on a facet (exactly one pair on a manifold mesh).
void interiorTetFacets(const Eigen::MatrixXd& P3, const TetFacets& records,
                       std::vector<Facet>& facets) {
  facets.clear();
  facets.reserve(records.facets.size() / 2);  // two records per interior facet
  forEachFacet(records, [&](const std::array<int, 3>& key, const TetFacet* first, int count) {
    if (count < 2) return;
    const Eigen::Vector3d a = (P3.row(key[1]) - P3.row(key[0])).transpose();
    const Eigen::Vector3d b = (P3.row(key[2]) - P3.row(key[0])).transpose();
    const double c = 0.5 * a.cross(b).norm();
    for (int i = 0; i < count; ++i)
      for (int j = i + 1; j < count; ++j) {
        Facet f;
        f.k = first[i].tet;
        f.l = first[j].tet;
        f.c = c;
        f.size = 3;
        f.vertices = key;
        facets.push_back(f);
      }
  });
}

}  // namespace

// Per-element hat gradients, measures, normals, the lumped mass and the stiffness K for
// elements of K vertices. Edge vectors E = [p1-p0, p2-p0 (, p3-p0)]; the gradients g_1..g_{K-1}
// are the columns of E (E^T E)^-1 (the dual basis in the element's span), g_0 = -sum of the
// others. For tets E is square and this is E^-T. Fixed sizes: no allocation per element.
template <int K>
void Discretization::buildElements(const Eigen::MatrixXd& P3, double tinyMeasure) {
  const int n = static_cast<int>(P3.rows()), m = static_cast<int>(elements_.rows());
  measures_.resize(m);
  grads_.resize(static_cast<Eigen::Index>(m) * K, dim_);
  if (kind_ == MeshKind::Surface) normals_.resize(m, 3);
  mass_ = Eigen::VectorXd::Zero(n);
  Eigen::Matrix<double, 3, K - 1> E;
  Eigen::Matrix<double, K, 3> g;
  for (int e = 0; e < m; ++e) {
    for (int j = 1; j < K; ++j)
      E.col(j - 1) = (P3.row(elements_(e, j)) - P3.row(elements_(e, 0))).transpose();
    double measure;
    if constexpr (K == 4) {
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
      if (kind_ == MeshKind::Surface) normals_.row(e) = cr.normalized().transpose();
    }
    const Eigen::Matrix<double, K - 1, K - 1> gram = E.transpose() * E;
    g.template bottomRows<K - 1>() = (E * gram.inverse()).transpose();
    g.row(0) = -g.template bottomRows<K - 1>().colwise().sum();
    grads_.block(static_cast<Eigen::Index>(e) * K, 0, K, dim_) = g.leftCols(dim_);
    measures_(e) = measure;
    for (int i = 0; i < K; ++i) mass_(elements_(e, i)) += measure / K;
  }
}

// K from the stored gradients. The products are those of the gradients' computation: a planar
// element's third column (not stored) is zero on an exactly flat mesh; on one flat only to within
// the planar test's 1e-12 of the diagonal, K leaves out those columns' negligible terms.
template <int K>
SparseMatrix Discretization::assembleStiffness(Stiffness& s) const {
  // Straight into the pattern of the vertex adjacency (every pair of vertices of an element),
  // without the m K^2 triplets (288 MB on a 2M-face surface), column by column: column v sums
  // the terms of the elements around v in element order from -0.0 (which adds no term's sign
  // of zero), as setFromTriplets would, and finds each row's entry in a table filled from the
  // column's pattern rather than by a search.
  const int n = numVertices();
  if (s.around.start.empty()) s.around = elementsAround(elements_, n);
  const Incidence& around = s.around;
  std::vector<int>& start = s.start;
  std::vector<int>& adjacency = s.adjacency;
  if (start.empty()) vertexAdjacency(elements_, around, start, adjacency);
  SparseMatrix stiffness(n, n);
  stiffness.resizeNonZeros(static_cast<Eigen::Index>(adjacency.size()));
  std::copy(start.begin(), start.end(), stiffness.outerIndexPtr());
  std::copy(adjacency.begin(), adjacency.end(), stiffness.innerIndexPtr());
  double* values = stiffness.valuePtr();
  std::fill_n(values, adjacency.size(), -0.0);
  std::vector<int> entryOfRow(static_cast<size_t>(n));
  Eigen::Matrix<double, K, 3> g = Eigen::Matrix<double, K, 3>::Zero();
  for (int v = 0; v < n; ++v) {
    for (int at = start[static_cast<size_t>(v)]; at < start[static_cast<size_t>(v) + 1]; ++at)
      entryOfRow[static_cast<size_t>(adjacency[static_cast<size_t>(at)])] = at;
    for (int at = around.begin(v); at < around.end(v); ++at) {
      const int e = around.entries[static_cast<size_t>(at)] / K;
      const int j = around.entries[static_cast<size_t>(at)] % K;  // v = elements_(e, j)
      g.leftCols(dim_) = grads_.block(static_cast<Eigen::Index>(e) * K, 0, K, dim_);
      // Column j of the element's matrix measure g g^T (the same bits as the whole product).
      const Eigen::Matrix<double, K, 1> Kej = measures_(e) * g * g.row(j).transpose();
      for (int i = 0; i < K; ++i)
        values[entryOfRow[static_cast<size_t>(elements_(e, i))]] += Kej(i);
    }
  }
  std::vector<int>().swap(start);  // the pattern lives on in K
  std::vector<int>().swap(adjacency);
  s.around = Incidence();
  return stiffness;
}

const SparseMatrix& Discretization::stiffness() const {
  if (!stiffness_) {  // moved from: nothing left to assemble
    static const SparseMatrix empty;
    return empty;
  }
  Stiffness& s = *stiffness_;
  std::call_once(s.once, [&] {
    s.K = elementSize() == 4 ? assembleStiffness<4>(s) : assembleStiffness<3>(s);
  });
  return s.K;
}

// Referenced vertices and components.
void Discretization::buildComponents(const std::vector<unsigned char>& used) {
  const int n = static_cast<int>(used.size());
  const int m = static_cast<int>(elements_.rows());
  const int k = static_cast<int>(elements_.cols());
  active_.assign(used.begin(), used.end());
  DisjointSets sets(n);
  // Column by column (the elements are stored so): the same sets in any order of unions, and
  // the components below are numbered by their first vertex, not by the sets' roots.
  for (int i = 1; i < k; ++i)
    for (int e = 0; e < m; ++e) sets.unite(elements_(e, 0), elements_(e, i));
  component_.assign(n, -1);
  std::vector<int> rootId(n, -1);
  numComponents_ = 0;
  for (int v = 0; v < n; ++v) {
    if (!used[static_cast<size_t>(v)]) continue;
    const int r = sets.find(v);
    if (rootId[r] < 0) rootId[r] = numComponents_++;
    component_[v] = rootId[r];
  }
}

void Discretization::build(MeshKind kind, const Eigen::MatrixXd& positions,
                           const Eigen::MatrixXi& elements, const TriMesh* topology) {
  kind_ = kind;
  dim_ = kind == MeshKind::Planar ? 2 : 3;
  const int k = kind == MeshKind::Tet ? 4 : 3;
  checkElements(kind, positions, elements, k);
  rest_ = positions.leftCols(dim_);
  elements_ = elements;
  const int cols = std::min<int>(3, static_cast<int>(positions.cols()));
  Eigen::MatrixXd P3 = Eigen::MatrixXd::Zero(positions.rows(), 3);
  P3.leftCols(cols) = positions.leftCols(cols);
  // The bounding box of the referenced vertices, checked before any area or volume.
  const std::vector<unsigned char> used = usedVertices(elements, P3.rows());
  const Eigen::Vector3d extent = usedExtent(P3, used);
  checkSize(extent);
  diagonal_ = extent.norm();
  // A planar discretization keeps x and y only: a z that varies would be dropped in silence.
  // The same test as Mesh's planar kind, on the same points (the referenced vertices).
  if (kind == MeshKind::Planar && extent(2) > 0.0 &&
      !planarSpread(extent(2), extent.stableNorm())) {
    char text[96];
    std::snprintf(text, sizeof text, "%.3g (bounding-box diagonal %.3g)", extent(2),
                  extent.stableNorm());
    throw InvalidMesh(std::string("discretization: a planar mesh lies in a plane z = const, "
                                  "but its z spans ") +
                      text + "; give it as a surface");
  }

  TetFacets records;  // tets: adjacency by sorting their facets
  if (k == 4)
    meanEdge_ = tetFacetsAndMeanEdge(P3, elements, records, stiffness_->around, stiffness_->start,
                                     stiffness_->adjacency);
  else
    meanEdge_ = edgeFacets(P3, *topology, facets_);
  const double tinyMeasure = 1e-14 * std::pow(meanEdge_, kind == MeshKind::Tet ? 3 : 2);
  if (k == 4)
    buildElements<4>(P3, tinyMeasure);
  else
    buildElements<3>(P3, tinyMeasure);
  if (k == 4) interiorTetFacets(P3, records, facets_);
  buildComponents(used);
}

Discretization::Thinnest Discretization::thinnestElement() const {
  Thinnest thinnest;
  const int k = elementSize(), power = k - 1;
  for (Eigen::Index e = 0; e < elements_.rows(); ++e) {
    double longest = 0.0;
    for (int a = 0; a < k; ++a)
      for (int b = a + 1; b < k; ++b)
        longest =
            std::max(longest, (rest_.row(elements_(e, a)) - rest_.row(elements_(e, b))).norm());
    const double ratio = measures_(e) / std::pow(longest, power);
    if (thinnest.element < 0 || ratio < thinnest.ratio) thinnest = {static_cast<int>(e), ratio};
  }
  return thinnest;
}

Discretization Discretization::withElementOrder(const std::vector<int>& order) const {
  const Eigen::Index m = elements_.rows(), size = elements_.cols();
  if (static_cast<Eigen::Index>(order.size()) != m)
    throw InvalidParameter("element order: " + std::to_string(order.size()) + " entries for " +
                           std::to_string(m) + " elements");
  Discretization copy;
  copy.kind_ = kind_;
  copy.dim_ = dim_;
  copy.rest_ = rest_;
  copy.elements_.resize(m, size);
  copy.measures_.resize(m);
  copy.grads_.resize(grads_.rows(), grads_.cols());
  copy.normals_.resize(normals_.rows(), normals_.cols());
  std::vector<int> position(static_cast<size_t>(m));
  for (Eigen::Index i = 0; i < m; ++i) {
    const Eigen::Index e = order[static_cast<size_t>(i)];
    position[static_cast<size_t>(e)] = static_cast<int>(i);
    copy.elements_.row(i) = elements_.row(e);
    copy.measures_(i) = measures_(e);
    copy.grads_.middleRows(i * size, size) = grads_.middleRows(e * size, size);
    if (normals_.rows() > 0) copy.normals_.row(i) = normals_.row(e);
  }
  copy.facets_ = facets_;
  for (Facet& f : copy.facets_) {
    f.k = position[static_cast<size_t>(f.k)];
    f.l = position[static_cast<size_t>(f.l)];
  }
  // Assembled in this order before it is shared: in the copy's order the sums would round
  // differently, and which of the two asked first would decide K's last bits.
  stiffness();
  copy.stiffness_ = stiffness_;
  copy.mass_ = mass_;
  copy.active_ = active_;
  copy.component_ = component_;
  copy.numComponents_ = numComponents_;
  copy.meanEdge_ = meanEdge_;
  copy.diagonal_ = diagonal_;
  return copy;
}

Discretization::Discretization(const Mesh& mesh) : Discretization(mesh, mesh.positions()) {}

Discretization::Discretization(const Mesh& mesh, const Eigen::MatrixXd& positions) {
  build(mesh.kind(), positions, mesh.elements(), mesh.isTet() ? nullptr : &mesh.tri());
}

Discretization::Discretization(MeshKind kind, const Eigen::MatrixXd& positions,
                               const Eigen::MatrixXi& elements) {
  if (kind == MeshKind::Tet) {
    build(kind, positions, elements, nullptr);
    return;
  }
  checkElements(kind, positions, elements, 3);
  // The structure only: the positions are the discretization's.
  const std::vector<Eigen::Vector3d> points(static_cast<size_t>(positions.rows()),
                                            Eigen::Vector3d::Zero());
  std::vector<std::array<int, 3>> triangles(static_cast<size_t>(elements.rows()));
  for (Eigen::Index e = 0; e < elements.rows(); ++e)
    triangles[static_cast<size_t>(e)] = {elements(e, 0), elements(e, 1), elements(e, 2)};
  std::ptrdiff_t refused = -1;
  const auto tri = buildTriangleMesh(points, triangles, refused);
  if (!tri)
    throw InvalidMesh("discretization: triangle " + std::to_string(refused) +
                      " does not fit an oriented edge-manifold mesh (an edge with a third "
                      "triangle, an edge in the same direction twice, or a repeated vertex); "
                      "readMesh splits such triangles");
  build(kind, positions, elements, tri.get());
}

}  // namespace diffreg
