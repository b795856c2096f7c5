#include <diffreg/mesh/mesh.h>

#include <diffreg/core/error.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>

namespace diffreg {
namespace {

using VProp = OpenMesh::VPropHandleT<double>;
using FProp = OpenMesh::FPropHandleT<double>;

void addName(std::vector<std::string>& names, const std::string& name) {
  if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
}

/// Names of the double properties in an OpenMesh property range (skipping unnamed ones).
template <class It>
void collectDoubleProps(It begin, It end, std::vector<std::string>& names) {
  for (It it = begin; it != end; ++it) {
    if (*it == nullptr || dynamic_cast<const OpenMesh::PropertyT<double>*>(*it) == nullptr)
      continue;
    const std::string& name = (*it)->name();
    if (!name.empty() && name[0] != '<') addName(names, name);
  }
}

void checkSize(const Eigen::VectorXd& values, int expected, const char* what,
               const std::string& name) {
  if (values.size() != expected) {
    throw InvalidParameter(std::string(what) + " property '" + name + "' has " +
                           std::to_string(values.size()) + " values, the mesh has " +
                           std::to_string(expected));
  }
}

}  // namespace

const char* toString(MeshKind kind) {
  switch (kind) {
    case MeshKind::Planar:
      return "planar";
    case MeshKind::Surface:
      return "surface";
    case MeshKind::Tet:
      return "tet";
  }
  return "unknown";
}

const TriMesh& TriMeshBox::empty() {
  static const TriMesh mesh;
  return mesh;
}

static_assert(std::is_nothrow_move_constructible_v<Mesh> && std::is_nothrow_move_assignable_v<Mesh>,
              "a Mesh moves without copying its OpenMesh mesh, also inside std::vector");

Mesh::Mesh(TriMesh tri) : Mesh(std::make_unique<TriMesh>(tri)) {}

Mesh::Mesh(std::unique_ptr<TriMesh> tri) : tri_(std::move(tri)) {
  // Planar when the referenced vertices share their z; a mesh without faces by all its vertices.
  Eigen::AlignedBox3d used, all;
  for (auto v : tri_->vertices()) {
    const auto& p = tri_->point(v);
    const Eigen::Vector3d q(p[0], p[1], p[2]);
    all.extend(q);
    if (!tri_->is_isolated(v)) used.extend(q);
  }
  kind_ = tri_->n_vertices() > 0 && planarBox(used.isEmpty() ? all : used) ? MeshKind::Planar
                                                                           : MeshKind::Surface;
  collectDoubleProps(tri_->vprops_begin(), tri_->vprops_end(), vertexNames_);
  collectDoubleProps(tri_->fprops_begin(), tri_->fprops_end(), elementNames_);
}

Mesh::Mesh(TetMesh tet) : kind_(MeshKind::Tet), tet_(std::move(tet)) {}

int Mesh::numVertices() const {
  return isTet() ? static_cast<int>(tet_.points.size()) : static_cast<int>(tri_->n_vertices());
}

int Mesh::numElements() const {
  return isTet() ? static_cast<int>(tet_.tets.size()) : static_cast<int>(tri_->n_faces());
}

// Both point types are three doubles in a row, so the points are one n x 3 row-major array.
static_assert(sizeof(TriMesh::Point) == 3 * sizeof(double));
static_assert(sizeof(Eigen::Vector3d) == 3 * sizeof(double));

Mesh::PointRows Mesh::points() const {
  const int n = numVertices();
  if (n == 0) return PointRows(nullptr, 0, 3);
  const double* first = isTet() ? tet_.points.front().data() : tri_->points()->data();
  return PointRows(first, n, 3);
}

Eigen::MatrixXd Mesh::positions() const {
  const int n = numVertices();
  Eigen::MatrixXd p(n, 3);
  for (int i = 0; i < n; ++i) {
    if (isTet()) {
      p.row(i) = tet_.points[i].transpose();
    } else {
      const auto& q = tri_->point(tri_->vertex_handle(i));
      p.row(i) << q[0], q[1], q[2];
    }
  }
  return p;
}

void Mesh::setPositions(const Eigen::MatrixXd& positions) {
  const int n = numVertices();
  const bool planarXY = kind_ == MeshKind::Planar && positions.cols() == 2;
  if (positions.rows() != n || (positions.cols() != 3 && !planarXY)) {
    throw InvalidParameter("setPositions: expected " + std::to_string(n) + " x 3" +
                           (kind_ == MeshKind::Planar ? " (or x 2)" : "") + " positions, got " +
                           std::to_string(positions.rows()) + " x " +
                           std::to_string(positions.cols()));
  }
  if (!positions.allFinite()) throw InvalidParameter("setPositions: non-finite position");
  for (int i = 0; i < n; ++i) {
    if (isTet()) {
      tet_.points[i] = positions.row(i).transpose();
    } else {
      auto& q = tri_->point(tri_->vertex_handle(i));
      q[0] = positions(i, 0);
      q[1] = positions(i, 1);
      if (!planarXY) q[2] = positions(i, 2);
    }
  }
}

Eigen::MatrixXi Mesh::elements() const {
  const int m = numElements();
  Eigen::MatrixXi e(m, elementSize());
  if (isTet()) {
    for (int k = 0; k < m; ++k)
      for (int j = 0; j < 4; ++j) e(k, j) = tet_.tets[k][j];
  } else {
    // As fv_range(f): the ends of the face's half-edge and of the two after it (directly: the
    // circulator costs several times more on every call over a large mesh).
    const TriMesh& t = *tri_;
    for (auto f : t.faces()) {
      OpenMesh::HalfedgeHandle h = t.halfedge_handle(f);
      for (int j = 0; j < 3; ++j, h = t.next_halfedge_handle(h))
        e(f.idx(), j) = t.to_vertex_handle(h).idx();
    }
  }
  return e;
}

std::vector<bool> Mesh::referenced() const {
  std::vector<bool> used(numVertices(), false);
  if (isTet()) {
    for (const auto& t : tet_.tets)
      for (int v : t)
        if (v >= 0 && v < numVertices()) used[v] = true;
  } else {
    for (auto v : tri_->vertices()) used[v.idx()] = !tri_->is_isolated(v);
  }
  return used;
}

Eigen::AlignedBox3d meshBounds(const Mesh& mesh) { return meshBounds(mesh, mesh.positions()); }

Eigen::AlignedBox3d meshBounds(const Mesh& mesh, const Eigen::MatrixXd& p) {
  return meshBounds(p, mesh.referenced());
}

Eigen::AlignedBox3d meshBounds(const Eigen::MatrixXd& p, const std::vector<bool>& used) {
  Eigen::AlignedBox3d box;
  for (Eigen::Index i = 0; i < p.rows(); ++i)
    if (used[static_cast<size_t>(i)] && p.row(i).allFinite())
      box.extend(Eigen::Vector3d(p.row(i).transpose()));
  return box;
}

bool Mesh::hasVertexScalar(const std::string& name) const {
  if (isTet()) return tetVertexProps_.count(name) > 0;
  VProp h;
  return tri_->get_property_handle(h, name);
}

Eigen::VectorXd Mesh::vertexScalar(const std::string& name) const {
  if (isTet()) {
    auto it = tetVertexProps_.find(name);
    if (it == tetVertexProps_.end()) throw MissingProperty("no vertex property '" + name + "'");
    return it->second;
  }
  VProp h;
  if (!tri_->get_property_handle(h, name)) {
    throw MissingProperty("no vertex property '" + name + "'");
  }
  Eigen::VectorXd values(numVertices());
  for (auto v : tri_->vertices()) values[v.idx()] = tri_->property(h, v);
  return values;
}

void Mesh::setVertexScalar(const std::string& name, const Eigen::VectorXd& values) {
  checkSize(values, numVertices(), "vertex", name);
  addName(vertexNames_, name);
  if (isTet()) {
    tetVertexProps_[name] = values;
    return;
  }
  VProp h;
  if (!tri_->get_property_handle(h, name)) {
    tri_->add_property(h, name);
    tri_->property(h).set_persistent(true);
  }
  for (auto v : tri_->vertices()) tri_->property(h, v) = values[v.idx()];
}

bool Mesh::hasElementScalar(const std::string& name) const {
  if (isTet()) return tetElementProps_.count(name) > 0;
  FProp h;
  return tri_->get_property_handle(h, name);
}

Eigen::VectorXd Mesh::elementScalar(const std::string& name) const {
  if (isTet()) {
    auto it = tetElementProps_.find(name);
    if (it == tetElementProps_.end()) throw MissingProperty("no element property '" + name + "'");
    return it->second;
  }
  FProp h;
  if (!tri_->get_property_handle(h, name)) {
    throw MissingProperty("no element property '" + name + "'");
  }
  Eigen::VectorXd values(numElements());
  for (auto f : tri_->faces()) values[f.idx()] = tri_->property(h, f);
  return values;
}

void Mesh::setElementScalar(const std::string& name, const Eigen::VectorXd& values) {
  checkSize(values, numElements(), "element", name);
  addName(elementNames_, name);
  if (isTet()) {
    tetElementProps_[name] = values;
    return;
  }
  FProp h;
  if (!tri_->get_property_handle(h, name)) {
    tri_->add_property(h, name);
    tri_->property(h).set_persistent(true);
  }
  for (auto f : tri_->faces()) tri_->property(h, f) = values[f.idx()];
}

std::vector<std::string> Mesh::vertexScalarNames() const { return vertexNames_; }
std::vector<std::string> Mesh::elementScalarNames() const { return elementNames_; }

}  // namespace diffreg
