// CGAL stays in this file: its headers are heavy and no other header needs them.
#ifndef CGAL_EIGEN3_ENABLED
#define CGAL_EIGEN3_ENABLED 1  // CGAL's default linear algebra for the heat method is Eigen
#endif
#include <diffreg/weights/geodesic.h>

#include <diffreg/core/disjoint_sets.h>
#include <diffreg/core/error.h>
#include <diffreg/discretization/discretization.h>
#include <diffreg/solver/solver.h>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Heat_method_3/Surface_mesh_geodesic_distances_3.h>
#include <CGAL/boost/graph/graph_traits_TriMesh_ArrayKernelT.h>
#include <CGAL/exceptions.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <string>

namespace diffreg {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using VertexDescriptor = boost::graph_traits<TriMesh>::vertex_descriptor;

/// Reads OpenMesh's double points as CGAL points without narrowing (CGAL's own OpenMesh point
/// map converts through float when writing, and CGAL::OM_pmap would add a property).
struct DoublePointMap {
  using key_type = VertexDescriptor;
  using value_type = Kernel::Point_3;
  using reference = value_type;
  using category = boost::readable_property_map_tag;
  const TriMesh* mesh = nullptr;
  friend value_type get(const DoublePointMap& map, key_type v) {
    const TriMesh::Point& p = map.mesh->point(v);
    return value_type(p[0], p[1], p[2]);
  }
};

/// Writes CGAL's per-vertex distances into a vector indexed by local vertex id.
struct DistanceMap {
  using key_type = VertexDescriptor;
  using value_type = double;
  using reference = double&;
  using category = boost::writable_property_map_tag;
  std::vector<double>* values = nullptr;
  friend void put(const DistanceMap& map, key_type v, double d) {
    (*map.values)[static_cast<std::size_t>(v.idx())] = d;
  }
};

using HeatMethod =
    CGAL::Heat_method_3::Surface_mesh_geodesic_distances_3<TriMesh, CGAL::Heat_method_3::Direct,
                                                           DoublePointMap>;

void checkSources(const std::vector<int>& sources, int n) {
  if (sources.empty()) throw InvalidParameter("geodesic distances: no source vertex given");
  for (int s : sources) {
    if (s < 0 || s >= n) {
      throw InvalidParameter("geodesic distances: source vertex " + std::to_string(s) +
                             " out of range [0, " + std::to_string(n) + ")");
    }
  }
}

/// Triangle meshes: CGAL's heat method, one compact copy per connected component (a
/// component without a source has no heat and CGAL would normalize a zero gradient).
class TriangleHeat {
 public:
  explicit TriangleHeat(const Mesh& mesh) {
    const TriMesh& tri = mesh.tri();
    const int n = static_cast<int>(tri.n_vertices());
    DisjointSets sets(n);
    for (auto f : tri.faces()) {
      std::array<int, 3> ids{};
      std::array<TriMesh::Point, 3> p;
      int j = 0;
      for (auto v : tri.fv_range(f)) {
        ids[j] = v.idx();
        p[j++] = tri.point(v);
      }
      const double twiceArea = OpenMesh::cross(p[1] - p[0], p[2] - p[0]).norm();
      const double longest2 =
          std::max({(p[1] - p[0]).sqrnorm(), (p[2] - p[1]).sqrnorm(), (p[0] - p[2]).sqrnorm()});
      if (!(twiceArea > 1e-12 * longest2)) {
        throw InvalidMesh("geodesic distances: face " + std::to_string(f.idx()) +
                          " is degenerate (zero area)");
      }
      sets.unite(ids[0], ids[1]);
      sets.unite(ids[0], ids[2]);
    }
    if (tri.n_faces() == 0) throw InvalidMesh("geodesic distances: the mesh has no face");

    // Components in order of their smallest vertex id; local ids follow global order.
    const std::vector<bool> used = mesh.referenced();
    component_.assign(n, -1);
    local_.assign(n, -1);
    std::vector<int> rootComponent(n, -1);
    for (int v = 0; v < n; ++v) {
      if (!used[v]) continue;
      const int r = sets.find(v);
      if (rootComponent[r] < 0) {
        rootComponent[r] = static_cast<int>(parts_.size());
        parts_.push_back(std::make_unique<Part>());
      }
      Part& part = *parts_[rootComponent[r]];
      component_[v] = rootComponent[r];
      local_[v] = static_cast<int>(part.global.size());
      part.global.push_back(v);
      part.mesh.add_vertex(tri.point(tri.vertex_handle(v)));
    }
    for (auto f : tri.faces()) {
      std::vector<TriMesh::VertexHandle> corners;
      int c = -1;
      for (auto v : tri.fv_range(f)) {
        c = component_[v.idx()];
        corners.push_back(parts_[c]->mesh.vertex_handle(local_[v.idx()]));
      }
      parts_[c]->mesh.add_face(corners);
    }
  }

  Eigen::VectorXd distances(const std::vector<int>& sources) {
    Eigen::VectorXd d = Eigen::VectorXd::Constant(component_.size(), kInf);
    std::vector<std::vector<VertexDescriptor>> partSources(parts_.size());
    for (int s : sources) {
      if (component_[s] < 0) {
        d[s] = 0.0;  // an unreferenced source reaches only itself
        continue;
      }
      partSources[component_[s]].push_back(parts_[component_[s]]->mesh.vertex_handle(local_[s]));
    }
    for (std::size_t c = 0; c < parts_.size(); ++c) {
      if (partSources[c].empty()) continue;
      Part& part = *parts_[c];
      std::vector<double> local(part.global.size(), kInf);
      try {
        if (!part.heat)
          part.heat = std::make_unique<HeatMethod>(part.mesh, DoublePointMap{&part.mesh});
        part.heat->clear_sources();
        part.heat->add_sources(partSources[c]);
        part.heat->estimate_geodesic_distances(DistanceMap{&local});
      } catch (const CGAL::Failure_exception& e) {
        throw SingularSystem("geodesic distances: CGAL's heat method failed on component " +
                             std::to_string(c) + " (" + e.message() + ")");
      }
      for (std::size_t i = 0; i < local.size(); ++i) {
        if (!std::isfinite(local[i])) {
          throw SingularSystem("geodesic distances: non-finite distance at vertex " +
                               std::to_string(part.global[i]));
        }
        d[part.global[i]] = std::max(0.0, local[i]);
      }
      for (const VertexDescriptor& v : partSources[c]) d[part.global[v.idx()]] = 0.0;
    }
    return d;
  }

 private:
  struct Part {
    TriMesh mesh;             // compact copy; CGAL keeps a reference, so it never moves
    std::vector<int> global;  // local vertex -> mesh vertex
    std::unique_ptr<HeatMethod> heat;
  };
  std::vector<std::unique_ptr<Part>> parts_;
  std::vector<int> component_, local_;  // per mesh vertex; -1 when unreferenced
};

/// Tet meshes: the heat method on diffreg's own Discretization (see the header).
class TetHeat {
 public:
  explicit TetHeat(const Mesh& mesh) : disc_(mesh) {
    const int n = disc_.numVertices();
    if (disc_.numElements() == 0) throw InvalidMesh("geodesic distances: the mesh has no tet");
    const std::vector<bool>& active = disc_.active();
    const std::vector<int>& comp = disc_.component();
    std::vector<bool> heatFixed(n), poissonFixed(n);
    std::vector<bool> rooted(disc_.numComponents(), false);
    for (int v = 0; v < n; ++v) {
      heatFixed[v] = poissonFixed[v] = !active[v];
      // phi is defined up to a constant per component: hold one vertex of each at 0.
      if (active[v] && !rooted[comp[v]]) rooted[comp[v]] = poissonFixed[v] = true;
    }
    const double h = disc_.meanEdgeLength() * disc_.meanEdgeLength();
    SparseMatrix heat = h * disc_.stiffness();
    SparseMatrix mass(n, n);
    std::vector<Eigen::Triplet<double>> diag;
    for (int v = 0; v < n; ++v) diag.emplace_back(v, v, disc_.lumpedMass()[v]);
    mass.setFromTriplets(diag.begin(), diag.end());
    heat += mass;
    heatSolver_.setPartition(Partition(heatFixed));
    heatSolver_.setMatrix(heat);
    poissonSolver_.setPartition(Partition(poissonFixed));
    poissonSolver_.setMatrix(disc_.stiffness());
  }

  Eigen::VectorXd distances(const std::vector<int>& sources) {
    const std::vector<int>& comp = disc_.component();
    const int n = disc_.numVertices();
    Eigen::VectorXd delta = Eigen::VectorXd::Zero(n);
    for (int s : sources) delta[s] = 1.0;
    const Partition& hp = heatSolver_.partition();
    const Eigen::VectorXd u = heatSolver_.solve(delta, Eigen::MatrixXd::Zero(hp.numFixed(), 1));

    // Divergence of the normalized field X = -grad u / |grad u|.
    Eigen::VectorXd b = Eigen::VectorXd::Zero(n);
    const Eigen::MatrixXi& elements = disc_.elements();
    for (int e = 0; e < disc_.numElements(); ++e) {
      const auto G = disc_.gradient(e);
      Eigen::VectorXd ue(G.rows());
      for (int i = 0; i < G.rows(); ++i) ue[i] = u[elements(e, i)];
      Eigen::VectorXd X = -(G.transpose() * ue);
      const double norm = X.norm();
      if (!(norm > 0.0) || !std::isfinite(norm)) continue;  // no heat here: X = 0
      X /= norm;
      for (int i = 0; i < G.rows(); ++i) b[elements(e, i)] += disc_.measures()[e] * G.row(i).dot(X);
    }
    const Partition& pp = poissonSolver_.partition();
    const Eigen::VectorXd phi = poissonSolver_.solve(b, Eigen::MatrixXd::Zero(pp.numFixed(), 1));

    std::vector<double> offset(disc_.numComponents(), kInf);
    for (int s : sources)
      if (comp[s] >= 0) offset[comp[s]] = std::min(offset[comp[s]], phi[s]);
    Eigen::VectorXd d = Eigen::VectorXd::Constant(n, kInf);
    for (int v = 0; v < n; ++v) {
      if (comp[v] < 0 || offset[comp[v]] == kInf) continue;
      d[v] = std::max(0.0, phi[v] - offset[comp[v]]);
      if (!std::isfinite(d[v])) {
        throw SingularSystem("geodesic distances: non-finite distance at vertex " +
                             std::to_string(v));
      }
    }
    for (int s : sources) d[s] = 0.0;
    return d;
  }

 private:
  Discretization disc_;
  EliminatedSolver heatSolver_, poissonSolver_;
};

}  // namespace

struct GeodesicDistance::Impl {
  int n = 0;
  std::unique_ptr<TriangleHeat> triangles;  // planar and surface meshes
  std::unique_ptr<TetHeat> tets;
};

GeodesicDistance::GeodesicDistance(const Mesh& mesh) : impl_(std::make_unique<Impl>()) {
  if (mesh.numVertices() == 0) throw InvalidMesh("geodesic distances: the mesh is empty");
  impl_->n = mesh.numVertices();
  if (mesh.isTet()) {
    impl_->tets = std::make_unique<TetHeat>(mesh);
  } else {
    impl_->triangles = std::make_unique<TriangleHeat>(mesh);
  }
}

GeodesicDistance::~GeodesicDistance() = default;
GeodesicDistance::GeodesicDistance(GeodesicDistance&&) noexcept = default;
GeodesicDistance& GeodesicDistance::operator=(GeodesicDistance&&) noexcept = default;

Eigen::VectorXd GeodesicDistance::distances(const std::vector<int>& sources) {
  checkSources(sources, impl_->n);
  return impl_->tets ? impl_->tets->distances(sources) : impl_->triangles->distances(sources);
}

Eigen::VectorXd geodesicDistances(const Mesh& mesh, const std::vector<int>& sources) {
  checkSources(sources, mesh.numVertices());
  return GeodesicDistance(mesh).distances(sources);
}

}  // namespace diffreg
