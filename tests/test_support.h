// Small helpers the tests share: the shipped meshes, documents built in code, nearest vertices.
#pragma once

#include "handles/handles.h"
#include "mesh/mesh.h"
#include "pipeline/document.h"

#include <Eigen/Core>
#include <string>
#include <utility>

namespace diffreg::testing {

/// A mesh or handle file the project ships in meshes/.
inline std::string shipped(const std::string& name) {
  return std::string(DIFFREG_SOURCE_DIR) + "/meshes/" + name;
}

/// A document of `mesh` (its positions as the rest shape) with handles parsed from JSON text.
inline Document inCode(Mesh mesh, const std::string& handleJson) {
  Document doc;
  doc.mesh = std::move(mesh);
  doc.rest = doc.mesh.positions();
  doc.handles = parseHandles(handleJson, doc.mesh, "test handles");
  return doc;
}

/// The vertex of `mesh` nearest to `p` (the first of equals).
inline int nearest(const Mesh& mesh, const Eigen::Vector3d& p) {
  const Eigen::MatrixXd x = mesh.positions();
  int best = 0;
  for (int v = 1; v < x.rows(); ++v)
    if ((x.row(v).transpose() - p).norm() < (x.row(best).transpose() - p).norm()) best = v;
  return best;
}

}  // namespace diffreg::testing
