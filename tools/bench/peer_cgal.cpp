// The peer: CGAL's Surface_mesh_deformation (ARAP) with its default sparse solver. CGAL stays in
// this file: its headers are heavy and nothing else needs them.
#define CGAL_EIGEN3_ENABLED 1  // CGAL's default solver for the deformation is Eigen's SparseLU
#include "bench.h"
#include <diffreg/core/error.h>
#include <diffreg/core/timer.h>

#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_deformation.h>
#include <CGAL/Polygon_mesh_processing/IO/polygon_mesh_io.h>
#include <CGAL/version.h>

#include <string>
#include <vector>

namespace diffreg::bench {
namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using Point = Kernel::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;
using VertexIndex = SurfaceMesh::Vertex_index;
using Deformation = CGAL::Surface_mesh_deformation<SurfaceMesh>;  // spokes and rims

}  // namespace

std::string cgalDescription() {
  return std::string("CGAL ") + CGAL_VERSION_STR +
         " Surface_mesh_deformation<Surface_mesh>, SPOKES_AND_RIMS (default), "
         "Eigen::SparseLU<COLAMDOrdering> (default solver)";
}

namespace {

SurfaceMesh toSurfaceMesh(const Eigen::MatrixXd& positions, const Eigen::MatrixXi& triangles,
                          std::vector<VertexIndex>& vertex) {
  SurfaceMesh mesh;
  vertex.reserve(static_cast<size_t>(positions.rows()));
  for (Eigen::Index i = 0; i < positions.rows(); ++i)
    vertex.push_back(mesh.add_vertex(Point(positions(i, 0), positions(i, 1), positions(i, 2))));
  for (Eigen::Index f = 0; f < triangles.rows(); ++f)
    if (mesh.add_face(vertex[triangles(f, 0)], vertex[triangles(f, 1)], vertex[triangles(f, 2)]) ==
        SurfaceMesh::null_face())
      throw InvalidMesh("CGAL peer: face " + std::to_string(f) + " is not manifold");
  return mesh;
}

void setTargets(Deformation& deformation, const std::vector<VertexIndex>& vertex,
                const std::vector<int>& handles, const Eigen::MatrixXd& targets) {
  for (size_t i = 0; i < handles.size(); ++i) {
    const Eigen::Index r = static_cast<Eigen::Index>(i);
    deformation.set_target_position(vertex[handles[i]],
                                    Point(targets(r, 0), targets(r, 1), targets(r, 2)));
  }
}

}  // namespace

PeerTimes runCgalArap(const Eigen::MatrixXd& positions, const Eigen::MatrixXi& triangles,
                      const std::vector<int>& handles, const Eigen::MatrixXd& targets,
                      int extraIterations) {
  std::vector<VertexIndex> vertex;
  SurfaceMesh mesh = toSurfaceMesh(positions, triangles, vertex);

  PeerTimes times;
  Timer timer;
  Deformation deformation(mesh);
  deformation.insert_roi_vertices(mesh.vertices().begin(), mesh.vertices().end());
  for (int v : handles) deformation.insert_control_vertex(vertex[v]);
  if (!deformation.preprocess()) throw SingularSystem("CGAL peer: preprocess() failed");
  times.preprocess = timer.seconds();

  auto move = [&](double scale, unsigned iterations) {
    Timer t;
    for (size_t i = 0; i < handles.size(); ++i) {
      const Eigen::Index r = static_cast<Eigen::Index>(i);
      const Eigen::RowVector3d rest = positions.row(handles[i]);
      const Eigen::RowVector3d target = rest + scale * (targets.row(r) - rest);
      deformation.set_target_position(vertex[handles[i]], Point(target(0), target(1), target(2)));
    }
    deformation.deform(iterations, 0.0);
    return t.seconds();
  };
  move(0.5, 1);  // the first deform after preprocess, as in ours
  times.latency1 = move(1.0, 1);
  times.latencyMore = move(1.5, 1 + static_cast<unsigned>(extraIterations));
  return times;
}

void traceCgalArap(const Eigen::MatrixXd& positions, const Eigen::MatrixXi& triangles,
                   const std::vector<int>& handles, const Eigen::MatrixXd& targets,
                   int iterations,
                   const std::function<void(int, const Eigen::MatrixXd&, double)>& step) {
  std::vector<VertexIndex> vertex;
  SurfaceMesh mesh = toSurfaceMesh(positions, triangles, vertex);
  Deformation deformation(mesh);
  deformation.insert_roi_vertices(mesh.vertices().begin(), mesh.vertices().end());
  for (int v : handles) deformation.insert_control_vertex(vertex[v]);
  if (!deformation.preprocess()) throw SingularSystem("CGAL peer: preprocess() failed");
  setTargets(deformation, vertex, handles, targets);
  Eigen::MatrixXd X(positions.rows(), 3);
  double seconds = 0.0;
  for (int it = 1; it <= iterations; ++it) {
    Timer timer;
    deformation.deform(1, 0.0);
    seconds += timer.seconds();
    for (Eigen::Index i = 0; i < X.rows(); ++i) {
      const Point& p = mesh.point(vertex[static_cast<size_t>(i)]);
      X.row(i) << p.x(), p.y(), p.z();
    }
    step(it, X, seconds);
  }
}

double cgalOneShot(const std::string& path, const std::vector<int>& handles,
                   const Eigen::MatrixXd& targets, int iterations) {
  Timer timer;
  SurfaceMesh mesh;
  if (!CGAL::IO::read_polygon_mesh(path, mesh)) throw IoError("CGAL peer: cannot read " + path);
  std::vector<VertexIndex> vertex(mesh.vertices().begin(), mesh.vertices().end());
  Deformation deformation(mesh);
  deformation.insert_roi_vertices(mesh.vertices().begin(), mesh.vertices().end());
  for (int v : handles) deformation.insert_control_vertex(vertex[static_cast<size_t>(v)]);
  if (!deformation.preprocess()) throw SingularSystem("CGAL peer: preprocess() failed");
  setTargets(deformation, vertex, handles, targets);
  deformation.deform(static_cast<unsigned>(iterations), 0.0);
  return timer.seconds();
}

}  // namespace diffreg::bench
