#include <diffreg/mesh/halfedges.h>

#include <diffreg/mesh/parse.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>

namespace diffreg {

std::unique_ptr<TriMesh> buildOrientedManifold(const std::vector<Eigen::Vector3d>& points,
                                               const std::vector<std::array<int, 3>>& triangles) {
  using Index = std::int64_t;
  const Index n = static_cast<Index>(points.size());
  const Index m = static_cast<Index>(triangles.size());
  // 3m corners, each the start of one directed edge ("wedge" w = 3 f + j: from corner j of
  // triangle f to corner j + 1), and up to 3m edges: 2^31 half-edges would overflow OpenMesh's
  // int handles.
  if (m == 0 || 3 * m >= (Index(1) << 30)) return nullptr;
  const size_t wedges = static_cast<size_t>(3 * m);
  const auto nextCorner = [](size_t j) { return j == 2 ? size_t(0) : j + 1; };

  // The wedges leaving each vertex (counting sort), each vertex's sorted by their end vertex:
  // (end << 32 | wedge). Sorted, a directed edge twice is two equal ends side by side, and the
  // twin of a wedge a -> b is found by bisection among b's (a fan around one vertex of high
  // valence stays n log n).
  std::vector<int> first(size_t(n) + 1, 0);
  for (const auto& t : triangles)
    for (int v : t) ++first[size_t(v) + 1];
  for (Index v = 0; v < n; ++v) first[size_t(v) + 1] += first[size_t(v)];
  std::vector<std::uint64_t> leaving(wedges);
  {
    std::vector<int> fill(first.begin(), first.end() - 1);
    for (size_t f = 0, w = 0; f < triangles.size(); ++f)
      for (size_t j = 0; j < 3; ++j, ++w) {
        const auto& t = triangles[f];
        leaving[size_t(fill[size_t(t[j])]++)] =
            std::uint64_t(std::uint32_t(t[nextCorner(j)])) << 32 | std::uint64_t(w);
      }
  }
  const auto endOf = [](std::uint64_t key) { return int(key >> 32); };
  const auto wedgeOf = [](std::uint64_t key) { return int(key & 0xffffffffu); };
  // Per vertex: its wedge of its last triangle (an interior vertex's outgoing half-edge).
  std::vector<int> last(size_t(n), -1);
  for (Index v = 0; v < n; ++v) {
    const auto begin = leaving.begin() + first[size_t(v)],
               end = leaving.begin() + first[size_t(v) + 1];
    std::sort(begin, end);
    // No directed edge twice: at most two triangles on an edge, in opposite directions.
    for (auto it = begin; it != end; ++it) {
      if (it + 1 != end && endOf(*it) == endOf(*(it + 1))) return nullptr;
      last[size_t(v)] = std::max(last[size_t(v)], wedgeOf(*it));
    }
  }
  // The wedge running the other way along each wedge's edge, if any.
  const auto twinOf = [&](int a, int b) {
    const auto begin = leaving.begin() + first[size_t(b)],
               end = leaving.begin() + first[size_t(b) + 1];
    const auto it = std::lower_bound(begin, end, std::uint64_t(std::uint32_t(a)) << 32);
    return it != end && endOf(*it) == a ? wedgeOf(*it) : -1;
  };

  // Edges in the order triangles name them, half-edge 2e along the first one, 2e + 1 against it
  // (along the twin, or on the boundary: from the wedge's end back to its start). A vertex with
  // more than one boundary half-edge leaving it has two gaps in its fan: not a manifold vertex.
  std::vector<int> halfedge(wedges, -1), boundaryLeaving(size_t(n), -1);
  std::vector<std::pair<int, int>> boundary;  // (half-edge, its end vertex)
  int edges = 0;
  for (size_t f = 0, w = 0; f < triangles.size(); ++f)
    for (size_t j = 0; j < 3; ++j, ++w) {
      if (halfedge[w] >= 0) continue;
      const int a = triangles[f][j], b = triangles[f][nextCorner(j)];
      halfedge[w] = 2 * edges;
      const int twin = twinOf(a, b);
      if (twin >= 0) {
        halfedge[size_t(twin)] = 2 * edges + 1;
      } else {
        int& out = boundaryLeaving[size_t(b)];
        if (out >= 0) return nullptr;
        out = 2 * edges + 1;
        boundary.emplace_back(2 * edges + 1, a);
      }
      ++edges;
    }
  std::vector<std::uint64_t>().swap(leaving);

  auto mesh = std::make_unique<TriMesh>();
  TriMesh& tri = *mesh;
  tri.resize(size_t(n), size_t(edges), size_t(m));
  using HH = OpenMesh::HalfedgeHandle;
  for (size_t f = 0, w = 0; f < triangles.size(); ++f) {
    const OpenMesh::FaceHandle fh{int(f)};
    for (size_t j = 0; j < 3; ++j, ++w) {
      const HH h{halfedge[w]};
      tri.set_vertex_handle(h, OpenMesh::VertexHandle(triangles[f][nextCorner(j)]));
      tri.set_face_handle(h, fh);
      tri.set_next_halfedge_handle(h, HH(halfedge[j == 2 ? w - 2 : w + 1]));
    }
    tri.set_halfedge_handle(fh, HH(halfedge[3 * f + 2]));  // a face keeps its last corner's
  }
  for (const auto& [h, to] : boundary) {  // continues with the one leaving its end
    tri.set_vertex_handle(HH(h), OpenMesh::VertexHandle(to));
    tri.set_next_halfedge_handle(HH(h), HH(boundaryLeaving[size_t(to)]));
  }
  for (Index v = 0; v < n; ++v) {
    const Eigen::Vector3d& p = points[size_t(v)];
    const OpenMesh::VertexHandle vh{static_cast<int>(v)};
    tri.set_point(vh, TriMesh::Point(p[0], p[1], p[2]));
    if (last[size_t(v)] < 0) continue;  // isolated: no half-edge, as OpenMesh leaves it
    const int leavingBoundary = boundaryLeaving[size_t(v)];
    tri.set_halfedge_handle(
        vh, HH(leavingBoundary >= 0 ? leavingBoundary : halfedge[size_t(last[size_t(v)])]));
  }

  // Every vertex's triangles one fan: turning from one half-edge leaving the vertex to the next
  // (next of the opposite) visits all of them before it comes back.
  for (Index v = 0; v < n; ++v) {
    const int count = first[size_t(v) + 1] - first[size_t(v)];
    if (count == 0) continue;
    const HH start = tri.halfedge_handle(OpenMesh::VertexHandle(static_cast<int>(v)));
    HH h = start;
    int seen = 0;
    for (int step = 0; step <= count; ++step) {
      if (!tri.is_boundary(h)) ++seen;
      h = tri.next_halfedge_handle(tri.opposite_halfedge_handle(h));
      if (h == start) break;
    }
    if (h != start || seen != count) return nullptr;
  }
  return mesh;
}

std::unique_ptr<TriMesh> buildTriangleMesh(const std::vector<Eigen::Vector3d>& points,
                                           const std::vector<std::array<int, 3>>& triangles,
                                           std::ptrdiff_t& refused) {
  refused = -1;
  const auto distinct = [](const std::array<int, 3>& t) {
    return t[0] != t[1] && t[1] != t[2] && t[0] != t[2];
  };
  // buildOrientedManifold wants three distinct corners; the loop below names the triangle.
  if (std::all_of(triangles.begin(), triangles.end(), distinct))
    if (auto built = buildOrientedManifold(points, triangles)) return built;
  auto mesh = std::make_unique<TriMesh>();
  TriMesh& tri = *mesh;
  OpenMeshQuiet quiet;
  tri.reserve(points.size(), triangles.size() * 3 / 2, triangles.size());
  for (const Eigen::Vector3d& p : points) tri.add_vertex(TriMesh::Point(p[0], p[1], p[2]));
  for (size_t f = 0; f < triangles.size(); ++f) {
    const auto& t = triangles[f];
    if (!distinct(t) || !tri.add_face(OpenMesh::VertexHandle(t[0]), OpenMesh::VertexHandle(t[1]),
                                      OpenMesh::VertexHandle(t[2]))
                             .is_valid()) {
      refused = static_cast<std::ptrdiff_t>(f);
      return nullptr;
    }
  }
  return mesh;
}

}  // namespace diffreg
