// Deformation energies as per-element residuals (METHOD.md §2) and the regularization weights
// of the blend (METHOD.md §3). Every energy is written as e_k = L_k x_k - t_k: a fixed local
// operator L_k applied to the element's unknowns x_k minus a target t_k, which is constant for
// the linear energies and refitted from the current positions (the local step) for ARAP and
// the 3D ASAP. One layout serves all energies:
//  - separable (ARAP, Dirichlet, 3D ASAP): the unknowns are the n x d positions themselves, one
//    right-hand-side column per coordinate, L_k = G_k^T (d x s) and e_k = F_k^T - T_k^T;
//  - coupled (2D ASAP, lARAP): the unknowns are the d n coordinates (vertex-major, one column),
//    L_k = P_k B_k (d^2 x d s) with B_k x_k = vec(F_k) and P_k a Frobenius-orthogonal projector.
#pragma once

#include "discretization/discretization.h"

#include <Eigen/Core>
#include <string>
#include <vector>

namespace diffreg {

enum class Energy {
  Arap,       ///< as-rigid-as-possible, F - R (local/global)
  Asap,       ///< as-similar-as-possible, F - closest similarity (linear in 2D)
  Larap,      ///< linearized ARAP, sym(F) - I (linear, coordinates coupled)
  Dirichlet,  ///< F - I
};

enum class Regularization {
  None,        ///< plain energy
  Uniform,     ///< (1 - beta) sum a_k D_k + beta S                          (paper eq. 2)
  Nonuniform,  ///< per-element and per-facet beta from vertex weights       (paper eq. 3)
};

const char* toString(Energy energy);
const char* toString(Regularization regularization);
/// "arap", "asap", "larap" or "dirichlet".
/// \throw InvalidParameter for any other name, listing the valid ones.
Energy parseEnergy(const std::string& name);
/// "none", "uniform" or "nonuniform".
/// \throw InvalidParameter for any other name, listing the valid ones.
Regularization parseRegularization(const std::string& name);

/// True when the energy needs local/global iterations on this kind of mesh (ARAP; ASAP in 3D).
bool isIterative(Energy energy, MeshKind kind);
/// True when the energy couples the coordinates (ASAP in 2D, lARAP).
bool isCoupled(Energy energy, MeshKind kind);

/// beta_k per element and beta_kl per facet (in the order of Discretization::facets()).
struct RegularizationWeights {
  Eigen::VectorXd element;
  Eigen::VectorXd facet;
};

/// Regularization weights for a mode: none -> all 0; uniform -> all `beta`; nonuniform ->
/// beta_k = mean of `vertexWeights` over the element's vertices and beta_kl = mean over the
/// facet's vertices (METHOD.md §3). `beta` is used only by uniform, `vertexWeights` only by
/// nonuniform. \throw InvalidParameter for beta outside [0, 1], or vertex weights of the wrong
/// size, not finite or outside [0, 1] (naming the first bad vertex).
RegularizationWeights makeRegularizationWeights(const Discretization& disc, Regularization mode,
                                                double beta,
                                                const Eigen::VectorXd& vertexWeights = {});

/// The residual operators of one energy on one discretization.
class ResidualModel {
 public:
  /// Precomputes L_k for every element (O(m) small dense blocks) and, for the linear energies,
  /// the constant targets.
  ResidualModel(const Discretization& disc, Energy energy);

  const Discretization& discretization() const { return disc_; }
  Energy energy() const { return energy_; }
  bool coupled() const { return coupled_; }
  bool iterative() const { return iterative_; }
  /// Unknowns per vertex (1 separable, d coupled) and right-hand-side columns (d or 1).
  int dofsPerVertex() const { return q_; }
  int columns() const { return c_; }
  /// Number of unknowns: n (separable) or d n (coupled).
  int numUnknowns() const { return disc_.numVertices() * q_; }
  /// Residual rows per element (d separable, d^2 coupled) and local unknowns per element.
  int rows() const { return r_; }
  int localSize() const { return u_; }
  /// L_k (rows() x localSize()).
  Eigen::Block<const Eigen::MatrixXd> local(int k) const {
    return L_.block(static_cast<Eigen::Index>(k) * r_, 0, r_, u_);
  }
  /// All L_k stacked: (m rows()) x localSize().
  const Eigen::MatrixXd& locals() const { return L_; }
  /// Global unknown index of element k's local unknown j.
  int unknown(int k, int j) const;

  /// Positions (n x d) in the unknown layout (numUnknowns() x columns()) and back.
  Eigen::MatrixXd toUnknowns(const Eigen::MatrixXd& positions) const;
  Eigen::MatrixXd toPositions(const Eigen::MatrixXd& unknowns) const;

  /// Stacked targets t_k ((m rows()) x columns()) for positions n x d: the local step for the
  /// iterative energies (closest rotation with det > 0, scaled for ASAP), constant otherwise.
  /// `t` is resized only when its shape is wrong.
  void targets(const Eigen::MatrixXd& positions, Eigen::MatrixXd& t) const;
  /// Stacked residuals e_k = L_k x_k - t_k for positions and their targets.
  void residuals(const Eigen::MatrixXd& positions, const Eigen::MatrixXd& t,
                 Eigen::MatrixXd& e) const;
  /// Residuals at `positions` with the targets fitted to them.
  Eigen::MatrixXd residuals(const Eigen::MatrixXd& positions) const;
  /// The local step, the residuals and the energy in one pass over the elements (in parallel):
  /// fits `t` to `positions` as targets() does, sets `e` as residuals() does and returns
  /// energy(e, weights). `t` and `e` are resized only when their shape is wrong.
  double fit(const Eigen::MatrixXd& positions, const RegularizationWeights& weights,
             Eigen::MatrixXd& t, Eigen::MatrixXd& e) const;

  /// D_k = ||e_k||_F^2 per element from stacked residuals.
  Eigen::VectorXd distortion(const Eigen::MatrixXd& e) const;
  /// ||e_k - e_l||_F^2 per facet from stacked residuals.
  Eigen::VectorXd facetDifference(const Eigen::MatrixXd& e) const;
  /// Total regularized energy E = sum (1-beta_k) a'_k D_k + sum beta_kl c'_kl ||e_k - e_l||^2
  /// with a', c' measured on the rest mesh scaled to unit mean edge length (METHOD.md §3), so
  /// E does not change when the mesh and its motion are scaled together.
  double energy(const Eigen::MatrixXd& e, const RegularizationWeights& weights) const;

 private:
  // sum_f beta_kl c_kl ||e_k - e_l||^2 (0 without facet weights) and the unit rescaling.
  double facetEnergy(const Eigen::MatrixXd& e, const RegularizationWeights& weights) const;
  double scaledEnergy(double elementSum, double facetSum) const;

  const Discretization& disc_;
  Energy energy_;
  bool coupled_, iterative_;
  int d_, s_, q_, c_, r_, u_;
  Eigen::MatrixXd L_;       // stacked local operators
  Eigen::MatrixXd fixedT_;  // constant targets of the linear energies
};

}  // namespace diffreg
