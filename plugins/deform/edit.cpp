#include "deform/edit.h"

#include "deformation/metrics.h"

namespace diffreg {

Edit editOf(const HandleSet& handles) {
  Edit edit;
  edit.vertices = handles.allVertices();
  edit.targets.resize(static_cast<Eigen::Index>(edit.vertices.size()), 3);
  Eigen::Index row = 0;
  for (const Handle& h : handles.handles) {
    edit.targets.middleRows(row, h.targets.rows()) = h.targets;
    row += h.targets.rows();
  }
  return edit;
}

Eigen::MatrixXd toMeshPositions(const Document& doc, const Eigen::MatrixXd& positions) {
  Eigen::MatrixXd out = doc.rest;
  out.leftCols(positions.cols()) = positions;
  return out;
}

Eigen::MatrixXd currentPositions(const Document& doc, const Discretization& disc) {
  return doc.mesh.positions().leftCols(disc.dim());
}

void writeElementMaps(Document& doc, const Discretization& disc, Energy energy,
                      const Eigen::MatrixXd& positions) {
  doc.mesh.setElementScalar(prop::distortion, elementDistortion(disc, energy, positions));
  doc.mesh.setElementScalar(prop::smoothness,
                            elementSmoothness(disc, facetSmoothness(disc, energy, positions)));
}

}  // namespace diffreg
