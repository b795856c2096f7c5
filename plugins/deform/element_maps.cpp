#include "deform/element_maps.h"

#include <diffreg/deformation/metrics.h>

namespace diffreg {

Eigen::MatrixXd toMeshPositions(const Document& doc, const Eigen::MatrixXd& positions) {
  Eigen::MatrixXd out = doc.rest;
  out.leftCols(positions.cols()) = positions;
  return out;
}

Eigen::MatrixXd currentPositions(const Document& doc, const Discretization& disc) {
  return doc.mesh.positions().leftCols(disc.dim());
}

void writeElementMaps(Document& doc, const ElementMaps& maps) {
  doc.mesh.setElementScalar(prop::distortion, maps.distortion);
  doc.mesh.setElementScalar(prop::smoothness, maps.smoothness);
}

}  // namespace diffreg
