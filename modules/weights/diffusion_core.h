// The diffused weights' machinery (not part of the public API): the partition into handle
// and free vertices, the matrices, the factorization and the conjugate gradients.
// DiffusionWeights (diffusion.h) owns one and forwards to it.
#pragma once

#include <diffreg/solver/solver.h>
#include <diffreg/weights/diffusion.h>

#include <optional>
#include <string>
#include <vector>

namespace diffreg {

class DiffusionCore {
 public:
  // The operations of DiffusionWeights, documented there.
  explicit DiffusionCore(const Discretization& disc,
                         SolverBackend backend = defaultSolverBackend());

  void setHandles(const std::vector<std::vector<int>>& vertexSets,
                  const std::vector<double>& ranges, const std::vector<double>& magnitudes);
  void setHandles(const HandleSet& handles);
  void setMagnitude(int handle, double m);
  void setRange(int handle, double r);
  void setParams(const DiffusionParams& params);
  const DiffusionParams& params() const { return params_; }

  double absoluteTime() const;
  Eigen::VectorXd solve();
  void setHandleBasis(bool on);
  const SolverStats& stats() const { return solver_.stats(); }
  const DiffusionSolveInfo& lastSolve() const { return lastSolve_; }
  Eigen::VectorXd rangeField() const;

 private:
  void preparePartition();
  void prepareMatrix(bool analyzeAgain);
  bool usesPcg() const {
    return params_.order == DiffusionOrder::Second && params_.solve == DiffusionSolve::Pcg;
  }
  // B X = rhs by one CG per column, sharing the preconditioner's block back-substitutions.
  Eigen::MatrixXd solvePcg(const Eigen::MatrixXd& rhs, double t);
  // Every handle's own weights into basis_ (one block solve); returns their combination by
  // the magnitudes.
  Eigen::VectorXd solveBasis();
  // Dirichlet values of the fixed vertices: values[j] on handle j, 0 on unreferenced vertices.
  Eigen::VectorXd dirichlet(const std::vector<double>& values) const;
  // The unclipped weights of the free vertices for Dirichlet values g (one full solve).
  Eigen::VectorXd solveFor(const Eigen::VectorXd& g);
  // The same for several columns of Dirichlet values at once.
  Eigen::MatrixXd solveForColumns(const Eigen::MatrixXd& G);
  // pcg: the weights are linear in the magnitudes, so while the matrix is unchanged the new
  // weights are the previous ones plus (m_j - previous m_j) times handle j's own weights,
  // solved on the first change of m_j and kept: dragging a magnitude costs one CG, then none.
  Eigen::VectorXd superposed();

  const Discretization& disc_;
  DiffusionParams params_;
  std::vector<std::vector<int>> sets_;
  std::vector<double> ranges_, magnitudes_;
  // The nearest handle of every vertex (-1 when unreachable), found when a range field needs it.
  mutable std::optional<std::vector<int>> owner_;
  Partition partition_;     // fixed: handle and unreferenced vertices
  SparseMatrix KFF_, KFJ_;
  Eigen::VectorXd N_;       // diag(M_FF R_FF^-1)
  SparseMatrix KNK_;        // K_FF N^-1 K_FF (direct second order), reused while r is unchanged
  SpdSolver solver_;
  DiffusionSolveInfo lastSolve_;
  Eigen::VectorXd previous_;                // pcg: last unclipped free weights (empty: none)
  std::vector<double> previousMagnitudes_;  // ... and the magnitudes they were solved for
  DiffusionSolveInfo previousInfo_;         // ... and how accurate they are
  struct HandleSolution {
    Eigen::VectorXd x;  // empty until solved
    DiffusionSolveInfo info;
  };
  std::vector<HandleSolution> basis_;  // pcg: handle j's own weights, solved on demand
  bool partitionDirty_ = true, matrixDirty_ = true, productDirty_ = true;
  bool handleBasis_ = false;
};

}  // namespace diffreg
