#include <diffreg/mesh/remesh.h>

#include <OpenMesh/Tools/Subdivider/Uniform/LoopT.hh>

#include <diffreg/core/error.h>
#include <diffreg/core/log.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

namespace diffreg {
namespace {

/// Largest angle between face normals that a flip may touch: 30 degrees.
const double kFlipCos = std::cos(30.0 * 3.14159265358979323846 / 180.0);
/// A new triangle must have |cross| >= kMinShape x (longest edge)^2: its height over the
/// longest edge at least 1/50 of that edge.
constexpr double kMinShape = 0.02;

using Point = TriMesh::Point;

/// Unit normal of triangle (a, b, c), or zero when it is too thin.
Point shapeNormal(const Point& a, const Point& b, const Point& c) {
  const Point n = OpenMesh::cross(b - a, c - a);
  const double longest2 = std::max({(b - a).sqrnorm(), (c - b).sqrnorm(), (a - c).sqrnorm()});
  const double norm = n.norm();
  if (!(norm >= kMinShape * longest2) || norm == 0.0) return Point(0, 0, 0);
  return n / norm;
}

/// Whether flipping interior edge e keeps both triangles well shaped and the surface unfolded.
bool flipKeepsShape(const TriMesh& tri, TriMesh::EdgeHandle e) {
  // Faces (a, b, c) and (b, a, d) become (a, d, c) and (d, b, c).
  const auto h0 = tri.halfedge_handle(e, 0), h1 = tri.halfedge_handle(e, 1);
  const Point& a = tri.point(tri.from_vertex_handle(h0));
  const Point& b = tri.point(tri.to_vertex_handle(h0));
  const Point& c = tri.point(tri.to_vertex_handle(tri.next_halfedge_handle(h0)));
  const Point& d = tri.point(tri.to_vertex_handle(tri.next_halfedge_handle(h1)));
  const Point n0 = OpenMesh::cross(b - a, c - a).normalized();
  const Point n1 = OpenMesh::cross(a - b, d - b).normalized();
  if (!(OpenMesh::dot(n0, n1) >= kFlipCos)) return false;
  const Point mean = (n0 + n1).normalized();
  const Point na = shapeNormal(a, d, c), nb = shapeNormal(d, b, c);
  return OpenMesh::dot(na, mean) >= kFlipCos && OpenMesh::dot(nb, mean) >= kFlipCos;
}

/// Removes the element scalar properties (they describe faces that no longer exist) and
/// rebuilds `mesh` so that its kind and property names match the edited OpenMesh mesh.
void dropElementPropertiesAndRebuild(Mesh& mesh) {
  TriMesh& tri = mesh.tri();
  for (const std::string& name : mesh.elementScalarNames()) {
    OpenMesh::FPropHandleT<double> h;
    if (tri.get_property_handle(h, name)) tri.remove_property(h);
  }
  mesh = Mesh(std::move(tri));
}

void requireTriangles(const Mesh& mesh, const char* what) {
  if (mesh.isTet()) {
    throw InvalidParameter(std::string(what) +
                           ": needs a planar or surface triangle mesh, got a tet mesh");
  }
}

}  // namespace

int flipEdges(Mesh& mesh, double fraction, unsigned seed) {
  requireTriangles(mesh, "flip_edges");
  if (!(fraction >= 0.0 && fraction <= 1.0)) {
    throw InvalidParameter("flip_edges: fraction must be in [0, 1] (got " +
                           std::to_string(fraction) + ")");
  }
  TriMesh& tri = mesh.tri();
  std::vector<TriMesh::EdgeHandle> interior;
  for (auto e : tri.edges())
    if (!tri.is_boundary(e)) interior.push_back(e);
  const auto target = static_cast<std::size_t>(std::lround(fraction * interior.size()));

  // Fisher-Yates with raw mt19937 output: std::shuffle and the std distributions are
  // implementation-defined, the mt19937 sequence is not.
  std::mt19937 random(seed);
  for (std::size_t i = interior.size(); i > 1; --i) {
    const std::size_t j = static_cast<std::size_t>(random()) % i;
    std::swap(interior[i - 1], interior[j]);
  }

  std::size_t flipped = 0;
  for (std::size_t i = 0; i < interior.size() && flipped < target; ++i) {
    const auto e = interior[i];
    if (!tri.is_flip_ok(e) || !flipKeepsShape(tri, e)) continue;
    tri.flip(e);
    ++flipped;
  }
  if (flipped < target) {
    warn("flip_edges: only " + std::to_string(flipped) + " of the requested " +
         std::to_string(target) + " edges could be flipped without degrading the mesh");
  }
  dropElementPropertiesAndRebuild(mesh);
  return static_cast<int>(flipped);
}

void subdivide(Mesh& mesh, int iterations, const std::string& scheme) {
  requireTriangles(mesh, "subdivide");
  if (scheme != "midpoint" && scheme != "loop") {
    throw InvalidParameter("subdivide: scheme '" + scheme + "' is not one of: midpoint, loop");
  }
  if (iterations < 0) {
    throw InvalidParameter("subdivide: iterations must be >= 0 (got " + std::to_string(iterations) +
                           ")");
  }
  const bool smooth = scheme == "loop";
  std::vector<std::string> names;
  std::vector<Eigen::VectorXd> values;
  for (const std::string& name : mesh.vertexScalarNames()) {
    if (!mesh.hasVertexScalar(name)) continue;
    names.push_back(name);
    values.push_back(mesh.vertexScalar(name));
  }

  TriMesh& tri = mesh.tri();
  for (int it = 0; it < iterations; ++it) {
    const int oldCount = static_cast<int>(tri.n_vertices());
    std::vector<std::pair<int, Point>> isolated;  // Loop's smoothing would move them
    std::size_t maxValence = 0;
    for (auto v : tri.vertices()) {
      if (tri.is_isolated(v)) isolated.emplace_back(v.idx(), tri.point(v));
      maxValence = std::max<std::size_t>(maxValence, tri.valence(v));
    }
    OpenMesh::Subdivider::Uniform::LoopT<TriMesh, double> loop;
    loop.init_weights(maxValence + 1);
    // LoopT splits every edge (new vertex appended), then every face 1-to-4; without
    // `smooth` the new vertices stay at the edge midpoints and old vertices do not move.
    loop(tri, 1, smooth);
    for (const auto& [id, p] : isolated) tri.set_point(tri.vertex_handle(id), p);

    // Each new vertex is adjacent to exactly the two old vertices of the edge it split.
    const int newCount = static_cast<int>(tri.n_vertices());
    for (Eigen::VectorXd& x : values) {
      x.conservativeResize(newCount);
      for (int v = oldCount; v < newCount; ++v) {
        double sum = 0.0;
        int count = 0;
        for (auto w : tri.vv_range(tri.vertex_handle(v))) {
          if (w.idx() < oldCount) {
            sum += x[w.idx()];
            ++count;
          }
        }
        x[v] = count > 0 ? sum / count : 0.0;
      }
    }
  }
  for (std::size_t k = 0; k < names.size(); ++k) mesh.setVertexScalar(names[k], values[k]);
  dropElementPropertiesAndRebuild(mesh);
}

}  // namespace diffreg
