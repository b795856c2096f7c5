// Diffused regularization weights (paper §3.2-3.3, docs/method.md, "Diffused weights"): heat flow
// from the handles with Dirichlet values m_j, global time t and per-handle range r_j.
#pragma once

#include <diffreg/core/names.h>
#include <diffreg/discretization/discretization.h>
#include <diffreg/handles/handles.h>
#include <diffreg/solver/backend.h>

#include <memory>
#include <string>
#include <vector>

namespace diffreg {

enum class DiffusionOrder {
  First,          ///< (N + t K_FF) x = t b                      (paper eq. 7)
  Second,         ///< Dirichlet-consistent second order          (paper eq. 8; docs/method.md)
  ImplicitEuler,  ///< n backward-Euler steps of h = t / n        (paper eq. 6, the reference)
};
enum class TimeUnit {
  Absolute,   ///< t in length^2
  Diagonal,   ///< t x squared bounding-box diagonal (the default)
  MeanEdge2,  ///< t x squared mean edge length (the paper's behaviour)
};
/// How the second-order system B x = rhs, B = N + t K + t^2/2 K N^-1 K, is solved
/// (docs/method.md, "Diffused weights").
enum class DiffusionSolve {
  Pcg,     ///< conjugate gradients preconditioned by (N + gK) N^-1 (N + gK), g = t / sqrt(2):
           ///< one factorization with K's own 1-ring pattern (the default)
  Direct,  ///< Cholesky of B itself, whose pattern has K N^-1 K's 2-ring fill (for comparison)
};

template <>
struct EnumTable<DiffusionOrder> {
  static constexpr const char* parameter = "order";
  static constexpr const char* noun = "diffusion order";
  static constexpr EnumName<DiffusionOrder> names[] = {
      {DiffusionOrder::First, "first"},
      {DiffusionOrder::Second, "second"},
      {DiffusionOrder::ImplicitEuler, "implicit_euler"},
  };
};

template <>
struct EnumTable<TimeUnit> {
  static constexpr const char* parameter = "t_unit";
  static constexpr const char* noun = "time unit";
  static constexpr EnumName<TimeUnit> names[] = {
      {TimeUnit::Absolute, "absolute"},
      {TimeUnit::Diagonal, "diagonal"},
      {TimeUnit::MeanEdge2, "mean_edge2"},
  };
};

template <>
struct EnumTable<DiffusionSolve> {
  static constexpr const char* parameter = "solve";
  static constexpr const char* noun = "second-order solve";
  static constexpr EnumName<DiffusionSolve> names[] = {
      {DiffusionSolve::Pcg, "pcg"},
      {DiffusionSolve::Direct, "direct"},
  };
};

/// The range of t (in any unit) and of the implicit Euler steps every front end accepts.
constexpr double kMinDiffusionTime = 1e-12, kMaxDiffusionTime = 1e6;
constexpr int kMaxDiffusionSteps = 100000;

struct DiffusionParams {
  double t = 0.01;
  TimeUnit unit = TimeUnit::Diagonal;
  DiffusionOrder order = DiffusionOrder::Second;
  int steps = 100;  ///< implicit Euler only
  DiffusionSolve solve = DiffusionSolve::Pcg;  ///< second order only
  /// Clip the result to [0, max m_j]. The first-order scheme already stays there (maximum
  /// principle); the second-order matrix is not an M-matrix and over/undershoots by up to ~1e-3
  /// (docs/method.md, "Diffused weights"), which would otherwise reach the regularization as a
  /// weight outside [0, 1].
  bool clip = true;
};

/// What the last solve() did beyond the factorizations SolverStats counts: the conjugate
/// gradient iterations of the second order solved by `pcg` (zero otherwise).
struct DiffusionSolveInfo {
  int cgIterations = 0;
  /// ||rhs - B x|| / ||rhs|| of the returned x, as CG's recurrence tracks it (0 for an exact
  /// solve). A new magnitude applied by superposition (DiffusionWeights) reports the largest
  /// relative residual of the solutions it combines; cgIterations and cgSeconds then count only
  /// the CG runs of that call (0 when every handle's own weights were already known).
  double cgResidual = 0.0;
  /// false when a CG combined into the result stopped at its iteration cap (a warning says so)
  bool converged = true;
  double cgSeconds = 0.0;  ///< the whole CG, including its back-substitutions
};

/// Relative residual at which the second order's CG stops, and its iteration cap. The
/// preconditioned matrix has its eigenvalues in [(2 + sqrt 2) / 4, 1] (condition number below
/// 1.18), so 1e-12 takes 4-9 iterations on planar, surface and tet meshes for any t.
constexpr double kDiffusionCgTolerance = 1e-12;
constexpr int kDiffusionCgMaxIterations = 100;
/// The most rounds of that CG: a round ends when the recursive residual meets the tolerance,
/// and where the true residual rhs - B x does not, the next starts from the last iterate
/// (DiffusionCore::solvePcg).
constexpr int kDiffusionCgRounds = 3;

/// An editing session for the weights that reuses factorizations as the paper's Fig. 5 says:
/// setHandles -> symbolic analysis + numeric factorization at the next solve; a new t,
/// setRange -> numeric factorization only; setMagnitude -> right-hand side only. The second
/// order solved by `pcg` factors N + t/sqrt(2) K_FF (the first order's pattern) and runs CG
/// against it: the same counts hold, except that a new m_j runs one CG for handle j's own
/// weights the first time it changes under this matrix and adds them in, and costs no solve
/// after that (the weights are linear in the magnitudes). Switching to or from the direct
/// second order changes the pattern, so it analyzes again.
class DiffusionCore;

class DiffusionWeights {
 public:
  /// The session refers to `disc`, which must outlive it (a temporary does not compile).
  explicit DiffusionWeights(const Discretization& disc,
                            SolverBackend backend = defaultSolverBackend());
  explicit DiffusionWeights(Discretization&&, SolverBackend = defaultSolverBackend()) = delete;
  ~DiffusionWeights();
  DiffusionWeights(DiffusionWeights&&) noexcept;
  DiffusionWeights& operator=(DiffusionWeights&&) noexcept;

  /// Handle vertex sets with their ranges r_j in [1e-6, 1e6] and magnitudes m_j in [0, 1].
  /// \throw InvalidParameter for an empty set, an out-of-range id, a vertex listed twice or in
  /// two sets, or r_j or m_j outside its interval (also for setRange and setMagnitude).
  void setHandles(const std::vector<std::vector<int>>& vertexSets,
                  const std::vector<double>& ranges, const std::vector<double>& magnitudes);
  void setHandles(const HandleSet& handles);
  void setMagnitude(int handle, double m);
  void setRange(int handle, double r);
  /// \throw InvalidParameter for t <= 0 or steps < 1 (implicit Euler).
  void setParams(const DiffusionParams& params);
  const DiffusionParams& params() const;

  /// t in length^2 after applying the unit.
  double absoluteTime() const;
  /// Per-vertex weights x (size n): m_j at handle vertices, 0 at unreferenced vertices,
  /// clipped to [0, max m_j] unless params().clip is off.
  Eigen::VectorXd solve();
  /// Keep every handle's own weights from the start (second order by `pcg` only): the first
  /// solve under a new matrix runs one block CG for all handles together (m_j = 1, the others
  /// 0, sharing each back-substitution), and every magnitude change after it, the first
  /// included, is a superposition without a solve. For an editor; off (the default), the first
  /// solve is one CG for the weights themselves and the first change of each m_j runs one more.
  void setHandleBasis(bool on);
  /// Factorizations and back-substitutions (a `pcg` solve makes two per CG iteration; a block
  /// of right-hand sides counts as one).
  const SolverStats& stats() const;
  /// CG iterations and residual of the last solve().
  const DiffusionSolveInfo& lastSolve() const;
  /// Per-vertex range factor r_i actually used: each vertex takes the r_j of the handle nearest
  /// to it along mesh edges (the paper leaves open how a handle's r_j reaches the free vertices
  /// whose diffusion speed it scales; docs/method.md, "Diffused weights"). Known from
  /// setHandles() on; the search along the edges runs only when some r_j is not 1, and is kept
  /// (so this const method writes a cache: one thread at a time, like the rest of the class).
  Eigen::VectorXd rangeField() const;

 private:
  std::unique_ptr<DiffusionCore> core_;
};

/// One-shot: diffused weights for `handles` on `disc`.
Eigen::VectorXd diffuseWeights(const Discretization& disc, const HandleSet& handles,
                               const DiffusionParams& params = {});

}  // namespace diffreg
