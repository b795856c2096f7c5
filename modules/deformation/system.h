// The regularized quadratic system of one energy (docs/method.md, "The regularizer") with hard
// constraints by elimination. For the stacked residual operator J (e = J x - t), the element
// weights W = diag((1 - beta_k) a_k) and the facet weights Ws = diag(ell beta_kl c_kl) on the facet
// differences D (D e = e_k - e_l):
//
//     A = J^T W J + (D J)^T Ws (D J),      A x = C t,   C = J^T (W + D^T Ws D).
//
// C is never formed: C t = sum_k L_k^T tau_k with tau_k = w_k t_k + sum_(facets kl of k)
// w_kl (t_k - t_l), added into C t colour by colour (no two groups of elements of a scatter
// colour share an unknown; scatterGroups). A is assembled into a sparsity pattern built once per
// session (the elements' and, unless left out, the facets' couplings), so new weights rewrite
// values only.
//
// ell is the mean rest edge length. docs/method.md ("The regularizer") measures a_k and c_kl on the
// rest mesh scaled to unit mean edge length: a' = ell^-md a, c' = ell^-(md-1) c and G' = ell G, so
// its matrix is ell^(2-md) times this A. A constant factor leaves the minimizer unchanged: beta
// means the same on a mesh in any unit, scaling the mesh and its motion by s scales the solution by
// s, and with beta = 0 the separable matrix is exactly the cotangent stiffness K.
#pragma once

#include <diffreg/deformation/regularizer.h>
#include <diffreg/deformation/residual_model.h>
#include <diffreg/solver/solver.h>

#include <string>
#include <vector>

namespace diffreg {

/// Columns of the sparsity pattern each thread builds at least: a pattern of fewer unknowns
/// than twice this is built by one thread.
constexpr int kPatternGrain = 4096;

class RegularizedSystem {
 public:
  /// `reserveCouplings`: keep the regularizer's facet couplings in the sparsity pattern even
  /// while every facet weight is zero, so that any later setWeights() refactorizes numerically
  /// only (paper Fig. 5). When false, the pattern holds only what the current weights need
  /// (plain energies: the elements' couplings, a smaller factorization) and the first nonzero
  /// facet weight adds the couplings, which costs one symbolic analysis.
  explicit RegularizedSystem(const ResidualModel& model,
                             SolverBackend backend = defaultSolverBackend(),
                             bool reserveCouplings = true);

  /// Constrained vertices (all their coordinates): the next solve analyzes the pattern again.
  /// Vertices without elements are always held at their rest positions.
  /// \pre ids valid and distinct (DeformationSession checks them).
  void setHandles(const std::vector<int>& vertices);
  /// New regularization weights: A is reassembled with the same sparsity pattern (zero weights
  /// stay structural), so the next solve refactorizes numerically only (see reserveCouplings).
  void setWeights(const RegularizationWeights& weights);
  const RegularizationWeights& weights() const { return regularizer_.weights(); }
  /// The regularizer's weights, incidence and colouring for these weights (the local step's).
  const Regularizer& regularizer() const { return regularizer_; }

  /// Empty when every connected component has enough handle points for this energy and these
  /// weights; otherwise a one-line reason naming the component and what it needs.
  std::string singularity() const;
  /// Factorizes if needed and solves for the positions (n x d) given stacked targets t and the
  /// handle positions (one row per setHandles() vertex, d columns).
  /// \throw SingularSystem (see singularity()) or when the factorization or solution fails.
  Eigen::MatrixXd solve(const Stacked& t, const Eigen::MatrixXd& handlePositions);
  /// Same as solve() for a right-hand side b = C t already computed by rightHandSide() (e.g.
  /// kept for targets that do not change between solves).
  Eigen::MatrixXd solveRightHandSide(const Eigen::MatrixXd& b,
                                     const Eigen::MatrixXd& handlePositions);

  /// The positions' response to values on the handles alone (separable layouts): x with
  /// A_FF x_F = -A_FH v on the free unknowns, x = v on the handles and 0 on the vertices
  /// without elements, for `v` with one row per setHandles() vertex and any number of columns
  /// (one back-substitution for all of them). Factorizes if needed.
  /// \throw SingularSystem as solve(); InvalidParameter for a coupled layout or a wrong size.
  Eigen::MatrixXd handleResponse(const Eigen::MatrixXd& v);
  /// x with A_FF x_F = r_F on the free unknowns and 0 on the fixed ones (handles, vertices
  /// without elements): the inverse of the system matrix on the free subspace, as the initial
  /// Hessian of the quasi-Newton iteration. Factorizes if needed.
  /// \throw SingularSystem as solve().
  Eigen::MatrixXd applyInverse(const Eigen::MatrixXd& r);
  /// Checks solvability, analyzes and factorizes now what changed (the solves do it on demand):
  /// done before the right-hand side, the factorization's peak memory does not meet its
  /// scratch space. \throw SingularSystem as solve().
  void factorize() { prepare(); }
  /// Sets the rows of the fixed unknowns to zero. Factorizes if needed.
  void zeroFixed(Eigen::MatrixXd& x);

  /// The full system matrix A (numUnknowns() square), assembled for the current weights
  /// (on first use after setWeights()).
  const SparseMatrix& matrix() const {
    if (valuesDirty_) assemble();
    return A_;
  }
  /// The right-hand side C t (numUnknowns() x model().columns()) for stacked targets t.
  void rightHandSide(const Stacked& t, Eigen::MatrixXd& b) const;
  /// The right-hand side for the rest shape's own targets. Every energy's residual vanishes at
  /// the rest shape (its targets there are the rest blocks, t_k = L_k x_rest), so for the
  /// iterative energies C t = C L x_rest = A x_rest: one product with A (about the centroid)
  /// instead of every element's fit and C's scatter, equal to rightHandSide(rest targets) to
  /// rounding (a test checks every energy, mesh kind and regularization, near and far from the
  /// origin). The linear energies' fixed targets go through C, which keeps exact zeros exact
  /// (planar ASAP's).
  void restRightHandSide(Eigen::MatrixXd& b) const;
  /// The energy gradient's direction A x - C t = C (F - t) for F the stacked L_k x_k of the
  /// same x (ResidualModel::gradients), on the free unknowns (0 on the fixed ones): one pass
  /// over the elements instead of a product with A and a right-hand side. Factorizes if needed.
  void residualGradient(const Stacked& F, const Stacked& t, Eigen::MatrixXd& g);
  /// The scatter groups by colour: C t adds a group's shares one element after the other and a
  /// colour's groups in parallel, so no two groups of one colour share an unknown. A group is
  /// 256 consecutive elements when such groups colour with at least 4 groups per colour on
  /// average (compact groups: meshes stored in a spatial order), else a single element.
  /// Consecutive elements keep their neighbours' blocks in cache: on the shared armadillo and
  /// tet-monkey (in locality order) C (F - t) took 14.4 and 22.1 ms by single elements
  /// (docs/benchmarks.md).
  std::vector<std::vector<std::vector<int>>> scatterGroups() const;
  const SolverStats& stats() const { return solver_.stats(); }
  const ResidualModel& model() const { return model_; }

 private:
  void buildTopology();
  void buildPattern(bool couplings);
  // A's values for the current weights: done when first needed (prepare(), matrix()), so that
  // weights set twice before a solve (a session's construction) assemble once.
  void assemble() const;
  // Values of the fixed unknowns (solver partition order) from one row per handle vertex;
  // vertices without elements get their rest positions (`restOffHandles`) or 0.
  Eigen::MatrixXd fixedValues(const Eigen::MatrixXd& handleValues, bool restOffHandles) const;
  // b = C t, or C (F - t) when F is given.
  void applyC(const Stacked& t, const Stacked* F, Eigen::MatrixXd& b) const;
  // Checks solvability, analyzes and factorizes what changed.
  void prepare();

  const ResidualModel& model_;
  Regularizer regularizer_;
  std::vector<int> handles_;
  // Per unknown p: the (element, local unknown) pairs that touch it, CSR.
  std::vector<int> incidenceStart_, incidence_;  // incidence_: k localSize() + j
  // The scatter groups by colour (no two of a colour share an unknown), CSR: group ids, each
  // the elements [id scatterGroup_, (id + 1) scatterGroup_) (single elements when 1).
  std::vector<int> scatterStart_, scatterOrder_;
  int scatterGroup_ = 1;
  bool reserveCouplings_ = true, couplings_ = false;
  mutable SparseMatrix A_;
  mutable bool valuesDirty_ = true;  // A_'s values are not those of the current weights
  Eigen::MatrixXd b_;                // right-hand side, reused
  EliminatedSolver solver_;
  bool partitionDirty_ = true, matrixDirty_ = true;
  bool patternChanged_ = true;  // since the solver last saw A_
};

}  // namespace diffreg
