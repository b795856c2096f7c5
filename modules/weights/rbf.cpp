#include <diffreg/weights/rbf.h>

#include <diffreg/core/error.h>
#include <diffreg/weights/geodesic.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

namespace diffreg {

double rbfSigmaFromDiagonal(const Discretization& disc, double fraction) {
  if (!(fraction > 0.0) || !std::isfinite(fraction))
    throw InvalidParameter("rbf: sigma fraction must be > 0 (got " + std::to_string(fraction) +
                           ")");
  // The discretization's diagonal, over the vertices of its elements: a stray unreferenced
  // vertex is left out of every system and must not widen every Gaussian.
  return fraction * disc.boundingBoxDiagonal();
}

Eigen::VectorXd rbfWeights(const Mesh& mesh, const HandleSet& handles, double sigma,
                           RbfDistance distance, bool clamp) {
  const int n = mesh.numVertices();
  if (!(sigma > 0.0) || !std::isfinite(sigma))
    throw InvalidParameter("rbf: sigma must be > 0 (got " + std::to_string(sigma) + ")");
  if (handles.empty()) throw InvalidParameter("rbf: no handles given");
  for (std::size_t j = 0; j < handles.handles.size(); ++j) {
    const Handle& h = handles.handles[j];
    const std::string what = "rbf: handle " + std::to_string(j) +
                             (h.name.empty() ? std::string() : " ('" + h.name + "')");
    if (h.vertices.empty()) throw InvalidParameter(what + " selects no vertex");
    if (!(h.range > 0.0) || !std::isfinite(h.range))
      throw InvalidParameter(what + ": range must be > 0 (got " + std::to_string(h.range) + ")");
    if (!(h.magnitude >= 0.0) || !std::isfinite(h.magnitude))
      throw InvalidParameter(what + ": magnitude must be >= 0 (got " + std::to_string(h.magnitude) +
                             ")");
    for (int v : h.vertices)
      if (v < 0 || v >= n)
        throw InvalidParameter(what + ": vertex " + std::to_string(v) + " out of range [0, " +
                               std::to_string(n) + ")");
  }

  const Eigen::MatrixXd positions = mesh.positions();
  std::vector<Eigen::Vector3d> p(n);
  for (int v = 0; v < n; ++v) p[v] = positions.row(v).transpose();
  std::optional<GeodesicDistance> geodesic;
  if (distance == RbfDistance::Geodesic) geodesic.emplace(mesh);

  Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
  for (const Handle& h : handles.handles) {
    Eigen::VectorXd d;
    if (geodesic) {
      d = geodesic->distances(h.vertices);  // one multi-source solve per handle
    } else {
      d = Eigen::VectorXd::Constant(n, std::numeric_limits<double>::infinity());
      for (int v = 0; v < n; ++v)
        for (int s : h.vertices) d[v] = std::min(d[v], (p[v] - p[s]).squaredNorm());
      d = d.cwiseSqrt();
    }
    const double width = h.range * sigma;
    for (int v = 0; v < n; ++v) {
      const double s = d[v] / width;
      x[v] += h.magnitude * std::exp(-s * s);  // d = +infinity (unreachable) adds 0
    }
  }
  const std::vector<bool> used = mesh.referenced();
  for (int v = 0; v < n; ++v) {
    if (!used[v]) x[v] = 0.0;
    if (clamp) x[v] = std::clamp(x[v], 0.0, 1.0);
  }
  return x;
}

}  // namespace diffreg
