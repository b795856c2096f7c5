#include <diffreg/mesh/halfedges.h>

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
  if (m == 0 || 3 * m > (Index(1) << 30)) return nullptr;
  // The wedges' ends, flat (no division by 3 in the loops below).
  const size_t wedges = static_cast<size_t>(3 * m);
  std::vector<int> tail(wedges), head(wedges);
  for (size_t f = 0, w = 0; f < triangles.size(); ++f, w += 3) {
    const auto& t = triangles[f];
    tail[w] = head[w + 2] = t[0];
    tail[w + 1] = head[w] = t[1];
    tail[w + 2] = head[w + 1] = t[2];
  }

  // The wedges leaving each vertex, by vertex (counting sort), with their end vertices beside.
  std::vector<int> first(size_t(n) + 1, 0);
  for (int v : tail) ++first[size_t(v) + 1];
  for (Index v = 0; v < n; ++v) first[size_t(v) + 1] += first[size_t(v)];
  std::vector<int> leaving(wedges), leavingTo(wedges);
  {
    std::vector<int> fill(first.begin(), first.end() - 1);
    for (size_t w = 0; w < wedges; ++w) {
      const int k = fill[size_t(tail[w])]++;
      leaving[size_t(k)] = int(w);
      leavingTo[size_t(k)] = head[w];
    }
  }
  // No directed edge twice: at most two triangles on an edge, and those two in opposite
  // directions.
  for (Index v = 0; v < n; ++v)
    for (int a = first[size_t(v)]; a < first[size_t(v) + 1]; ++a)
      for (int b = a + 1; b < first[size_t(v) + 1]; ++b)
        if (leavingTo[size_t(a)] == leavingTo[size_t(b)]) return nullptr;
  // The wedge running the other way along each wedge's edge, if any.
  std::vector<int> twin(wedges, -1);
  for (size_t w = 0; w < wedges; ++w) {
    const int a = tail[w], b = head[w];
    for (int k = first[size_t(b)]; k < first[size_t(b) + 1]; ++k)
      if (leavingTo[size_t(k)] == a) {
        twin[w] = leaving[size_t(k)];
        break;
      }
  }

  // Edges in the order triangles name them, half-edge 2e along the first one, 2e + 1 against it
  // (along the twin, or on the boundary).
  std::vector<int> halfedge(size_t(3 * m), -1);
  Index edges = 0;
  for (Index w = 0; w < 3 * m; ++w) {
    if (halfedge[size_t(w)] >= 0) continue;
    halfedge[size_t(w)] = int(2 * edges);
    if (twin[size_t(w)] >= 0) halfedge[size_t(twin[size_t(w)])] = int(2 * edges + 1);
    ++edges;
  }
  const Index halfedges = 2 * edges;
  const size_t numHalfedges = static_cast<size_t>(halfedges);
  std::vector<int> target(numHalfedges), face(numHalfedges, -1), next(numHalfedges, -1),
      creator(static_cast<size_t>(edges), -1);
  for (size_t f = 0, w = 0; f < triangles.size(); ++f) {
    for (size_t j = 0; j < 3; ++j, ++w) {
      const int h = halfedge[w];
      target[size_t(h)] = head[w];
      face[size_t(h)] = int(f);
      next[size_t(h)] = halfedge[j == 2 ? w - 2 : w + 1];
      if (!(h & 1)) creator[size_t(h / 2)] = int(w);
    }
  }
  // Boundary half-edges: one leaving any vertex at most (a vertex with two gaps in its fan is
  // not a manifold vertex); each continues with the one leaving its end.
  std::vector<int> boundaryLeaving(size_t(n), -1);
  for (Index e = 0; e < edges; ++e) {
    const Index h = 2 * e + 1;
    if (face[size_t(h)] >= 0) continue;
    const int w = creator[size_t(e)];
    target[size_t(h)] = tail[size_t(w)];
    int& out = boundaryLeaving[size_t(head[size_t(w)])];
    if (out >= 0) return nullptr;
    out = int(h);
  }
  for (Index e = 0; e < edges; ++e) {
    const Index h = 2 * e + 1;
    if (face[size_t(h)] < 0) next[size_t(h)] = boundaryLeaving[size_t(target[size_t(h)])];
  }

  // Every vertex's triangles one fan: turning from one half-edge leaving the vertex to the next
  // (next of the opposite) visits all of them before it comes back.
  std::vector<int> outgoing(size_t(n), -1);
  for (Index v = 0; v < n; ++v) {
    const int count = first[size_t(v) + 1] - first[size_t(v)];
    if (count == 0) continue;  // isolated: no half-edge, as OpenMesh leaves it
    int last = -1;             // the wedge of the vertex's last triangle
    for (int k = first[size_t(v)]; k < first[size_t(v) + 1]; ++k)
      last = std::max(last, leaving[size_t(k)]);
    const int start =
        boundaryLeaving[size_t(v)] >= 0 ? boundaryLeaving[size_t(v)] : halfedge[size_t(last)];
    int seen = 0, h = start;
    for (int step = 0; step <= count; ++step) {
      if (face[size_t(h)] >= 0) ++seen;
      h = next[size_t(h ^ 1)];
      if (h == start) break;
    }
    if (h != start || seen != count) return nullptr;
    outgoing[size_t(v)] = start;
  }

  auto mesh = std::make_unique<TriMesh>();
  TriMesh& tri = *mesh;
  tri.resize(size_t(n), size_t(edges), size_t(m));
  for (Index v = 0; v < n; ++v) {
    const Eigen::Vector3d& p = points[size_t(v)];
    const OpenMesh::VertexHandle vh{static_cast<int>(v)};
    tri.set_point(vh, TriMesh::Point(p[0], p[1], p[2]));
    if (outgoing[size_t(v)] >= 0)
      tri.set_halfedge_handle(vh, OpenMesh::HalfedgeHandle(outgoing[size_t(v)]));
  }
  for (Index h = 0; h < halfedges; ++h) {
    const OpenMesh::HalfedgeHandle hh{static_cast<int>(h)};
    tri.set_vertex_handle(hh, OpenMesh::VertexHandle(target[size_t(h)]));
    if (face[size_t(h)] >= 0) tri.set_face_handle(hh, OpenMesh::FaceHandle(face[size_t(h)]));
    tri.set_next_halfedge_handle(hh, OpenMesh::HalfedgeHandle(next[size_t(h)]));
  }
  for (Index f = 0; f < m; ++f)  // a face keeps the half-edge of its last corner
    tri.set_halfedge_handle(OpenMesh::FaceHandle(int(f)),
                            OpenMesh::HalfedgeHandle(halfedge[size_t(3 * f + 2)]));
  return mesh;
}

}  // namespace diffreg
