// Deformation quality measures (docs/method.md, "Metrics", the paper's Table 1 and Fig. 2). Plain
// functions of a discretization, an energy and positions, usable outside any pipeline.
#pragma once

#include <diffreg/deformation/options.h>

#include <Eigen/Core>
#include <optional>

namespace diffreg {

/// D_k = ||e_k||_F^2 per element for `energy` at `positions` (n x d); ARAP and the 3D ASAP
/// use the rotations fitted to the final F_k.
Eigen::VectorXd elementDistortion(const Discretization& disc, Energy energy,
                                  const Eigen::MatrixXd& positions);

/// ||e_k - e_l||_F^2 per facet (order of Discretization::facets()), the paper's Fig. 2 map.
Eigen::VectorXd facetSmoothness(const Discretization& disc, Energy energy,
                                const Eigen::MatrixXd& positions);

/// Per element, the largest facetSmoothness over its facets (0 for an element without
/// neighbours): the element property diffreg:smoothness.
Eigen::VectorXd elementSmoothness(const Discretization& disc, const Eigen::VectorXd& perFacet);

/// The two per-element maps a deformation writes, from one evaluation of the residuals.
struct ElementMaps {
  Eigen::VectorXd distortion;  ///< elementDistortion: diffreg:distortion
  Eigen::VectorXd smoothness;  ///< elementSmoothness of facetSmoothness: diffreg:smoothness
};
ElementMaps elementMaps(const Discretization& disc, Energy energy,
                        const Eigen::MatrixXd& positions);
/// The same maps from a shape's residuals (ResidualModel::residuals: element k's block in rows
/// k r to k r + r - 1, r = ResidualModel::rows()), e.g. DeformationSession::ownResiduals.
/// \throw InvalidParameter for residuals of another shape than the discretization's.
ElementMaps elementMapsFromResiduals(const Discretization& disc, Energy energy,
                                     const ElementTargets& residuals);

/// Elements with det F_k <= 0 (planar, tets). Surfaces: deformed normal . (R_k n_k) <= 0 with
/// R_k the closest rotation to F_k; a triangle cannot invert within its own plane, so on
/// surfaces this counts collapsed (zero-area) triangles.
int countInverted(const Discretization& disc, const Eigen::MatrixXd& positions);

/// Root mean square of the per-vertex distance between two position sets of equal shape.
/// \throw InvalidParameter when the shapes differ or are empty.
double rmsDistance(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b);
/// The same over the vertices marked in `active` (Discretization::active(): those of the
/// elements), the Dist of Table 1: unreferenced vertices, left out of every system, would pull
/// the mean towards 0. \throw InvalidParameter also when `active` has another size or no vertex.
double rmsDistance(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b,
                   const std::vector<bool>& active);

struct DeformationMetrics {
  double dMax = 0.0;           ///< max_k D_k
  double dAve = 0.0;           ///< area- (volume-) weighted mean of D_k: sum a_k D_k / sum a_k
  double dDev = 0.0;           ///< area- (volume-) weighted standard deviation of D_k
  int inverted = 0;            ///< countInverted
  /// Eq. 3 at these positions: the total regularized energy with the targets relaxed by exact
  /// local steps (relaxedEnergy), the value the deformation minimizes; or, when `relaxed` is
  /// false, the energy an unconverged run reported with its own targets (an upper bound).
  double energy = 0.0;
  bool relaxed = true;
  std::optional<double> dist;  ///< rmsDistance to the reference, when one is given
};

/// All of the above for a deformation. `reference` (n x d), when given, is the same edit
/// without regularization (or any other positions to compare with). `runEnergy`, when given,
/// is the energy an unconverged run reached at these positions with its targets: reported as
/// it is (relaxed = false) instead of relaxing the targets, which costs as much as several
/// iterations (about 1 s on a 43K surface), so that an interactive update stays within its time.
/// `startTargets`, when given, are targets at these positions (DeformationSession::lastTargets
/// of the run that ended there): the relaxation starts from them when their total energy is
/// lower than that of the per-element fit, and then takes a step or two instead of many;
/// ignored with `runEnergy`. `distortion`, when given, is D_k of these positions (the
/// ElementMaps of them, which the callers also write): not computed a second time.
/// \throw InvalidParameter when `startTargets` is not (m d) x d or `distortion` has not m values.
DeformationMetrics measureDeformation(const Discretization& disc, Energy energy,
                                      const Eigen::MatrixXd& positions,
                                      const RegularizationWeights& weights,
                                      const Eigen::MatrixXd* reference = nullptr,
                                      const double* runEnergy = nullptr,
                                      const ElementTargets* startTargets = nullptr,
                                      const Eigen::VectorXd* distortion = nullptr);

}  // namespace diffreg
