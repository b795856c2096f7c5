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

void writeElementMaps(Document& doc, const Discretization& disc, Energy energy,
                      const Eigen::MatrixXd& positions) {
  doc.mesh.setElementScalar(prop::distortion, elementDistortion(disc, energy, positions));
  doc.mesh.setElementScalar(prop::smoothness,
                            elementSmoothness(disc, facetSmoothness(disc, energy, positions)));
}

}  // namespace diffreg
