// What the deform and measure filters share: the document's positions in the discretization's
// layout and back, and the per-element maps written back to the mesh.
#pragma once

#include <diffreg/deformation/energy.h>
#include <diffreg/deformation/metrics.h>
#include <diffreg/deformation/residual_model.h>
#include <diffreg/discretization/discretization.h>
#include <diffreg/pipeline/document.h>

#include <Eigen/Core>
#include <vector>

namespace diffreg {

/// The mesh positions (n x 3) for deformed positions n x d: planar meshes keep their rest z.
Eigen::MatrixXd toMeshPositions(const Document& doc, const Eigen::MatrixXd& positions);

/// The document's current positions as the discretization's n x d.
Eigen::MatrixXd currentPositions(const Document& doc, const Discretization& disc);

/// Writes diffreg:distortion (D_k) and diffreg:smoothness (largest ||e_k - e_l||^2 over the
/// element's facets) from `maps` (elementMaps of the document's positions).
void writeElementMaps(Document& doc, const ElementMaps& maps);

}  // namespace diffreg
