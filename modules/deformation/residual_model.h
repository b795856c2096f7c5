// The stacked residual operators of one energy on one discretization (energy.h explains the
// two layouts): L_k per element, the constant targets of the linear energies, the deformation
// gradients and the fit of the targets to them, the residuals and the total energy.
#pragma once

#include <diffreg/deformation/energy.h>
#include <diffreg/deformation/options.h>
#include <diffreg/deformation/regularizer.h>

#include <Eigen/Core>

namespace diffreg {

/// Per-element blocks stacked in rows ((m rows()) x columns()): F, the targets t and the
/// residuals e. Row-major, so each element's block is contiguous (separable layout: the d x d
/// block F_k^T in d^2 consecutive values; coupled: one column, the same either way); the local
/// step's sweeps read an element and its neighbours a few cache lines each, in place.
using Stacked = ElementTargets;

/// Elements per ResidualModel::fitElements call.
constexpr int kFitBatch = 16;

class ResidualModel {
 public:
  /// Precomputes L_k for every element (O(m) small dense blocks) and, for the linear energies,
  /// the constant targets.
  ResidualModel(const Discretization& disc, Energy energy);

  const Discretization& discretization() const { return disc_; }
  Energy energy() const { return energy_.id(); }
  const EnergyModel& energyModel() const { return energy_; }
  bool coupled() const { return coupled_; }
  bool iterative() const { return iterative_; }
  /// Unknowns per vertex (1 separable, d coupled) and right-hand-side columns (d or 1).
  int dofsPerVertex() const { return dofsPerVertex_; }
  int columns() const { return columns_; }
  /// Number of unknowns: n (separable) or d n (coupled).
  int numUnknowns() const { return disc_.numVertices() * dofsPerVertex_; }
  /// Residual rows per element (d separable, d^2 coupled) and local unknowns per element.
  int rows() const { return rows_; }
  int localSize() const { return localSize_; }
  /// Where the L_k live: L_k(row, j) = data[k kStride + row rowStride + j columnStride]. The
  /// separable layout reads them from the discretization's gradients (L_k = G_k^T), so only
  /// the coupled layout keeps operators of its own.
  struct Operators {
    const double* data;
    Eigen::Index kStride, rowStride, columnStride;
    double operator()(int k, int row, int j) const {
      return data[k * kStride + row * rowStride + j * columnStride];
    }
  };
  Operators operators() const;
  /// L_k (rows() x localSize()).
  Eigen::MatrixXd local(int k) const;
  /// Global unknown index of element k's local unknown j (inline: the right-hand side's scatter
  /// calls it for every element and local unknown).
  int unknown(int k, int j) const {
    if (dofsPerVertex_ == 1) return disc_.elements()(k, j);  // separable: no division
    const int v = disc_.elements()(k, j / dofsPerVertex_);
    return v * dofsPerVertex_ + j % dofsPerVertex_;
  }

  /// Positions (n x d) in the unknown layout (numUnknowns() x columns()) and back.
  Eigen::MatrixXd toUnknowns(const Eigen::MatrixXd& positions) const;
  Eigen::MatrixXd toPositions(const Eigen::MatrixXd& unknowns) const;

  /// Stacked L_k x_k for positions n x d, in the layout of the targets ((m rows()) x
  /// columns(); separable: the blocks F_k^T). `F` is resized only when its shape is wrong.
  void gradients(const Eigen::MatrixXd& positions, Stacked& F) const;
  /// Element k's target for its block C^T (d x d, separable layout, row-major) and total
  /// weight (EnergyModel::fit), written row-major into `Tt` (d x d: block k of the stacked
  /// targets). Iterative energies only.
  void fitElement(const double* Ct, double weight, int k, double* Tt) const;
  /// fitElement for the elements ids[0..count) of a 3D mesh at once (count <= kFitBatch), from
  /// their C_k (d x d) into their blocks of the stacked targets `t` (EnergyModel::fitBatch).
  void fitElements(int count, const int* ids, const Eigen::Matrix3d* C, const double* weight,
                   Stacked& t) const;
  /// Every element's target fitted to its own F_k alone (weight 1, in parallel): the local step
  /// of plain local/global and of `local_step=reference`; the constant targets of the linear
  /// energies. `t` is resized only when its shape is wrong.
  void fitTargets(const Stacked& F, Stacked& t) const;
  /// gradients() and fitTargets() for positions.
  void targets(const Eigen::MatrixXd& positions, Stacked& t) const;
  /// Stacked residuals e_k = L_k x_k - t_k for positions and their targets.
  void residuals(const Eigen::MatrixXd& positions, const Stacked& t, Stacked& e) const;
  /// Residuals at `positions` with the targets fitted to each F_k alone.
  Stacked residuals(const Eigen::MatrixXd& positions) const;

  /// D_k = ||e_k||_F^2 per element from stacked residuals.
  Eigen::VectorXd distortion(const Stacked& e) const;
  /// ||e_k - e_l||_F^2 per facet from stacked residuals.
  Eigen::VectorXd facetDifference(const Stacked& e) const;
  /// Total regularized energy E = sum (1-beta_k) a'_k D_k + sum beta_kl c'_kl ||e_k - e_l||^2
  /// with a', c' measured on the rest mesh scaled to unit mean edge length, so E does not
  /// change when the mesh and its motion are scaled together.
  double energy(const Stacked& e, const RegularizationWeights& weights) const;
  /// energy(F - t, weights) without forming the residuals.
  double energy(const Stacked& F, const Stacked& t, const RegularizationWeights& weights) const;
  /// The factor ell^-md of that rescaling: E = energyScale() x (the sum with physical a_k and
  /// ell c_kl), the scale of the system matrix A in the energy (E = energyScale() |J x - t|^2).
  double energyScale() const;

 private:
  // EnergyModel::fit for element k in 3D, with its rest normal on surfaces.
  Eigen::Matrix3d fit3(const Eigen::Matrix3d& C, double weight, int k) const;

  const Discretization& disc_;
  const EnergyModel& energy_;
  bool coupled_, iterative_;
  int dim_, elementSize_, dofsPerVertex_, columns_, rows_, localSize_;
  Eigen::MatrixXd operators_;  // stacked L_k, coupled layout only
  Stacked fixedTargets_;       // constant targets of the linear energies
};

}  // namespace diffreg
