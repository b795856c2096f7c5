// The first global step of a handle move as a superposition. With the rest shape's targets the
// global step is x = A_FF^-1 (b_F - A_FH x_H): affine in the handle positions x_H. The handle
// vertices fall into groups (connected along mesh edges); when every group moves affinely,
// x_H = [p 1] M_g on group g (a drag, a rotation, a scaling of its rest points p), the step is
//
//     x = x_0 + sum_g Phi_g M_g,
//
// with x_0 the step for all handles at the origin and Phi_g (n x (d+1)) the response to the
// group's rest coordinates [p 1], computed once with the factorization (one back-substitution
// of d+1 columns per group). A move then costs a small dense product instead of a solve; any
// other move is solved as usual. Separable energy layouts only (ARAP, Dirichlet, 3D ASAP).
#pragma once

#include <diffreg/deformation/system.h>

#include <Eigen/Core>
#include <Eigen/QR>
#include <vector>

namespace diffreg {

class HandleBasis {
 public:
  /// The most columns (d+1 per group) the basis holds; with more groups it is not used.
  static constexpr int kMaxColumns = 24;

  /// Groups the handle vertices (rows of the targets, in this order) by the elements they
  /// share.
  HandleBasis(const Discretization& disc, const std::vector<int>& handles);

  int groups() const { return groups_; }
  /// Whether the basis fits (at most kMaxColumns columns).
  bool usable() const;
  bool built() const { return built_; }
  /// Computes x_0 for the right-hand side `restRhs` (= C t of the rest targets) and the
  /// responses Phi_g on `system` (handles set as here, separable layout).
  void build(RegularizedSystem& system, const Eigen::MatrixXd& restRhs);
  /// The global step for these handle targets (handles x d) into X when every group moves
  /// affinely (its least-squares affine map misses no target by more than 1e-12 of the mesh's
  /// bounding-box diagonal plus the round-off of the coordinates), with the handles exactly at
  /// their targets; false otherwise (X untouched). \pre built().
  bool solve(const Eigen::MatrixXd& targets, Eigen::MatrixXd& X) const;

 private:
  const Discretization& disc_;
  std::vector<int> handles_;
  // Group g's rest points [p 1], one row per member.
  Eigen::MatrixXd restCoordinates(int g) const;

  std::vector<std::vector<int>> members_;  // rows of each group
  // Per group: the decomposition of restCoordinates(g), for the moves' affine fits.
  std::vector<Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd>> fits_;
  int groups_ = 0;
  bool built_ = false;
  Eigen::MatrixXd x0_;   // n x d
  Eigen::MatrixXd phi_;  // n x (d+1) groups
};

}  // namespace diffreg
