// Deformation energies as per-element residuals e_k (docs/method.md, "Energies"). Each energy
// is one EnergyModel in a file of its own (energy_arap.cpp, energy_asap.cpp, energy_larap.cpp,
// energy_dirichlet.cpp); everything else (the residual operators, the system, the local step,
// the metrics) asks the model instead of switching on the energy. Adding an energy is one such
// file, one enumerator and one line in energy.cpp's table.
//
// Every residual has the form e_k = L_k x_k - t_k: a fixed local operator L_k on the element's
// unknowns x_k minus a target t_k, constant for the linear energies and refitted from the
// current positions (the local step) for the iterative ones. Two layouts:
//  - separable (ARAP, Dirichlet, 3D ASAP): the unknowns are the n x d positions, one column per
//    coordinate, L_k = G_k^T and e_k = F_k^T - T_k^T;
//  - coupled (2D ASAP, lARAP): the d n coordinates in one column, L_k = P_k B_k with
//    B_k x_k = vec(F_k) and P_k the Frobenius-orthogonal projector that removes the modes the
//    energy does not penalize.
#pragma once

#include <diffreg/deformation/options.h>
#include <diffreg/discretization/discretization.h>

#include <Eigen/Core>
#include <string>
#include <vector>

namespace diffreg {

/// One energy: what its residual removes from F_k and how it fits its targets.
class EnergyModel {
 public:
  virtual ~EnergyModel() = default;
  virtual Energy id() const = 0;
  /// Needs local/global iterations on this kind of mesh (a target refitted to F_k).
  virtual bool iterative(MeshKind kind) const = 0;
  /// Couples the coordinates (coupled layout).
  virtual bool coupled(MeshKind kind) const = 0;
  /// The motions the energy alone does not penalize, as the affine rank of the handle points a
  /// component needs to pin them: 0 (one point pins the translations), 1 (two distinct points:
  /// 2D similarities or infinitesimal rotations) or 2 (three non-collinear points).
  virtual int kernelRank(MeshKind kind) const = 0;

  /// Coupled layout: the vec(F)-space modes (length d^2, row-major vec) removed from the
  /// residual of an element with rest frame `frame` (I, or the tangent projector on surfaces).
  virtual std::vector<Eigen::VectorXd> removedModes(const Eigen::MatrixXd& frame,
                                                    MeshKind kind) const;
  /// The constant target T_k of a linear energy (d x d; coupled layout: vec'ed and projected by
  /// the caller). Zero for the iterative energies, whose targets come from fit().
  virtual Eigen::MatrixXd constantTarget(const Eigen::MatrixXd& frame, MeshKind kind) const;

  /// The local fit of an iterative energy: the admissible target T closest to C / weight, i.e.
  /// the minimizer over admissible T of weight ||T||^2 - 2 tr(T^T C). With C = F_k and
  /// weight = 1 it is the fit to F_k alone; with the regularizer's coupled C_k and weight
  /// (docs/method.md, "The local step") it is the exact block minimizer of eq. 3 in T_k.
  /// `normal`: the rest normal of a surface element (the target acts on its tangent plane),
  /// else null. The 2D overload serves planar meshes.
  virtual Eigen::Matrix2d fit(const Eigen::Matrix2d& C, double weight) const;
  virtual Eigen::Matrix3d fit(const Eigen::Matrix3d& C, double weight,
                              const Eigen::Vector3d* normal) const;
  /// The 3D fit of `count` elements at once: T_i = fit(C[i], weight[i], normal[i]), written
  /// column-major to the 9 doubles at T[i] (the stored block T_i^T, row-major). The exact local
  /// step fits a few elements per call, so that the square roots and divisions of a closed
  /// form overlap from one element to the next. The default calls fit() for each.
  virtual void fitBatch(int count, const Eigen::Matrix3d* C, const double* weight,
                        const Eigen::Vector3d* const* normal, double* const* T) const;
};

/// The model of an energy (a static instance).
const EnergyModel& energyModel(Energy energy);

/// True when the energy needs local/global iterations on this kind of mesh (ARAP; ASAP in 3D).
bool isIterative(Energy energy, MeshKind kind);
/// True when the energy couples the coordinates (ASAP in 2D, lARAP).
bool isCoupled(Energy energy, MeshKind kind);

}  // namespace diffreg
