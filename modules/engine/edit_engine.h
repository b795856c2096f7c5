// The edit engine (the paper's Fig. 5): one rest mesh, its handles and the editing parameters,
// with the regularization weights, the deformation, the same edit without regularization (for
// Dist), the per-element maps and the Table-1 metrics kept up to date at the least cost. Every
// front end drives it: the filters (through Document::engine()), compare and resolution
// (through the filters), the OpenMesh API and `diffreg serve`. Edits only describe the wanted
// state (cheap, validated once, here); update() then brings the results in line with it, and
// reuses every factorization it can:
//   handles added or removed (vertex sets changed), energy changed -> symbolic analysis
//   t, order, r_j, beta, weights field, regularization mode changed -> numeric factorization
//   a handle moved (targets), m_j changed (for the weights)        -> right-hand side only
//     (weights by pcg: m_j changed -> "superpose", no solve; interactive engines solve every
//     handle's own weights together at the first solve, one-shot ones on a first change)
// Several edits between two updates cost one update (coalescing).
#pragma once

#include <diffreg/deformation/deformer.h>
#include <diffreg/deformation/metrics.h>
#include <diffreg/discretization/discretization.h>
#include <diffreg/handles/handles.h>
#include <diffreg/mesh/mesh.h>
#include <diffreg/solver/backend.h>
#include <diffreg/weights/diffusion.h>
#include <diffreg/weights/rbf.h>

#include <Eigen/Core>
#include <exception>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace diffreg {

/// How the regularization weights are made.
enum class WeightScheme {
  Diffusion,  ///< heat diffusion from the handles (weights/diffusion.h)
  Rbf,        ///< Gaussian RBF per handle (weights/rbf.h), the paper's baseline
  Given,      ///< EditParams::givenWeights, made elsewhere (e.g. the mesh's diffreg:weight)
};
template <>
struct EnumTable<WeightScheme> {
  static constexpr const char* parameter = "weights";
  static constexpr const char* noun = "weight scheme";
  static constexpr EnumName<WeightScheme> names[] = {
      {WeightScheme::Diffusion, "diffusion"},
      {WeightScheme::Rbf, "rbf"},
      {WeightScheme::Given, "given"},
  };
};

struct RbfSettings {
  RbfDistance distance = RbfDistance::Geodesic;
  double sigma = 0.1;          ///< kernel width as a fraction of the bounding-box diagonal
  bool sigmaAbsolute = false;  ///< sigma is a length, not a fraction of the diagonal
  /// Clamp to [0, 1]: unclamped RBF sums may exceed 1 between nearby handles, and such weights
  /// cannot serve as beta for the non-uniform regularization.
  bool clamp = true;
};

/// The editor's time budget per update (EditParams::seconds): a drag's iterations take at most
/// about a quarter of a second on any mesh (a run stops before an iteration predicted, from the
/// last one, to overrun it; one iteration at least, plus one iteration of the reference and the
/// maps; a new factorization or weights solve, and relaxing the energy of a shape that has just
/// converged, come on top), and the shape is refined while idle.
constexpr double kEditorSeconds = 0.25;
/// The editor's iterations per update (EditParams::iterations as `diffreg serve` sets it): with
/// kEditorSeconds, what one update may take before the idle refinement continues.
constexpr int kEditorIterations = 50;

/// Everything about an edit that is not a handle.
struct EditParams {
  Energy energy = Energy::Arap;
  Regularization regularization = Regularization::Nonuniform;
  double beta = kDefaultUniformBeta;  ///< uniform regularization only
  WeightScheme scheme = WeightScheme::Diffusion;
  DiffusionParams diffusion;
  RbfSettings rbf;
  /// The weights per vertex for scheme Given, in [0, 1] (empty: zero everywhere).
  Eigen::VectorXd givenWeights;
  /// Solve the deformation. Off: the weights only (and the reference when asked for); the
  /// shape stays at rest and the maps at zero. The weight filters use this.
  bool deform = true;
  /// Also compute the Table-1 metrics with the maps (off: metrics() keeps zeros).
  bool metrics = true;
  /// Local/global iterations per update (ARAP; ASAP on surfaces and solids): a cap, as the deform
  /// filter's (converged runs stay below it). A run that stops here unconverged reports so
  /// (UpdateReport::converged) and continues with refine(); the editor sets kEditorIterations.
  int iterations = kDefaultIterations;
  /// Seconds the deformation of each update (and refine()) may take
  /// (DeformationSession::setTimeBudget: its start, e.g. a factorization, included, and one
  /// iteration at least); the reference gets what the deformation leaves of them, one
  /// iteration at least. A run that stops here unconverged continues with refine(). 0: no
  /// limit, the iterations alone cap the run. The editor's default is kEditorSeconds.
  double seconds = 0.0;
  /// Stationarity tolerance (DeformationOptions::relTolerance).
  double tolerance = kDefaultTolerance;
  LocalStep localStep = LocalStep::Exact;
  Acceleration acceleration = Acceleration::Lbfgs;
  /// Also solve the edit without regularization, for the Dist metric (paper Table 1).
  bool reference = true;
  /// While only handle targets move (a drag), continue the iterations from the current shape
  /// (DeformationSession::solveFrom): a few iterations instead of a full solve, but the shape
  /// then depends on the path of the drag as long as the iterations have not converged. Off:
  /// every update solves from the rest shape, as the diffreg tool does (in an interactive
  /// engine a new iteration cap or tolerance alone keeps the shape: a run within the new
  /// tolerance stays, one short of it continues).
  bool continueDrags = false;
  /// L-BFGS pairs, or earlier iterates Anderson combines (DeformationOptions::history).
  int history = 8;
};

/// How an engine is used, fixed for its life.
struct EngineSettings {
  SolverBackend backend = defaultSolverBackend();
  /// Interactive (the editor): the regularization may change between updates, so the
  /// deformation's system reserves the facet couplings even without regularization (a switch
  /// then costs a numeric factorization, not an analysis). Off (a filter, a one-shot call):
  /// reserved only while regularized, so an unregularized solve keeps the smaller pattern.
  /// Interactive diffused weights also keep every handle's own weights from their first solve
  /// (DiffusionWeights::setHandleBasis), so that any change of a magnitude costs no solve.
  bool interactive = true;
};

/// One handle: constrained vertices, their target positions, and its range r_j and magnitude
/// m_j for the weights.
struct EditHandle {
  int id = 0;  ///< stable identifier, never reused within a session
  std::string name;
  std::vector<int> vertices;
  Eigen::MatrixXd targets;  ///< |vertices| x 3 (planar meshes: z = rest z)
  double range = 1.0;       ///< r_j in [1e-6, 1e6] (kMinHandleRange, kMaxHandleRange)
  double magnitude = 1.0;   ///< m_j in [0, 1]
};

struct EditState {
  std::vector<EditHandle> handles;
  EditParams params;
  int nextId = 0;  ///< id of the next handle added
};

/// The names the handles of `state` are exported with: their own (EditEngine refuses two
/// handles of one name), or handle-<id> for one without, with a suffix -2, -3, ... where a
/// handle already has that name: the handle file of any state reads back.
std::vector<std::string> handleNames(const EditState& state);

/// What one update() did.
struct UpdateReport {
  /// Per system, the costliest phase run: "none", "solve" (right-hand side only), "numeric"
  /// (numeric factorization) or "analysis" (symbolic analysis and factorization). The weights
  /// may also say "evaluate" (RBF weights) or "superpose" (a magnitude applied without a solve).
  std::string weightsWork = "none", deformationWork = "none", referenceWork = "none";
  SolverStats weights, deformation, reference;  ///< counters of this update only
  double weightsSeconds = 0.0, deformationSeconds = 0.0, referenceSeconds = 0.0;
  double metricsSeconds = 0.0, seconds = 0.0;
  int iterations = 0;  ///< global steps of the deformation
  /// The deformation (and the unregularized reference, when solved) met the stationarity
  /// tolerance; false: refine() continues them (false too when nothing solved, `solved`).
  bool converged = true;
  /// The deformation's stopping criterion at the end (DeformationResult::criterion): how far
  /// from converged the shape is; NaN after a first global step alone, which nothing measures.
  double criterion = 0.0;
  std::string initialGuess;
  /// False when the weights or the deformation could not be computed for this state (e.g. a
  /// component without handles, or weights outside [0, 1]); `message` says why. The previous
  /// results are kept.
  bool solved = true;
  std::string message;
  /// The exception behind solved = false (null otherwise), for callers that rethrow it.
  std::exception_ptr failure;
  /// What the weights' last computation did: the diffusion's absolute t (length^2) and its
  /// conjugate gradients, or the RBF kernel's absolute sigma.
  double absoluteTime = 0.0, absoluteSigma = 0.0;
  DiffusionSolveInfo diffusionSolve;
};

/// The edit parameters of a one-shot deformation with `options`: the weights given
/// (options.weights), no reference, no metrics.
EditParams editParamsOf(const DeformationOptions& options);

/// The handles of a state as a HandleSet (unnamed handles named by handleNames).
HandleSet toHandleSet(const EditState& state);

class EditEngine {
 public:
  /// Takes the rest mesh.
  /// \throw InvalidMesh for a mesh the discretization rejects (degenerate elements).
  explicit EditEngine(Mesh mesh, EngineSettings settings = {});
  /// The same on a discretization of `mesh` built elsewhere (shared, e.g. a Document's).
  EditEngine(Mesh mesh, std::shared_ptr<const Discretization> disc, EngineSettings settings = {});
  ~EditEngine();
  EditEngine(const EditEngine&) = delete;
  EditEngine& operator=(const EditEngine&) = delete;

  const Mesh& restMesh() const { return mesh_; }
  const Discretization& discretization() const { return *disc_; }
  const std::shared_ptr<const Discretization>& sharedDiscretization() const { return disc_; }
  int numVertices() const { return disc_->numVertices(); }

  /// The wanted state: the last one accepted by setState().
  const EditState& state() const { return state_; }
  /// Checks a state against the mesh: handle ids unique and below nextId, vertex ids in range,
  /// referenced and in one handle only, targets |vertices| x 3 and finite and within 1000
  /// bounding-box diagonals of the mesh, r_j in [1e-6, 1e6], m_j in [0, 1], names unique,
  /// parameters in their ranges (t in [1e-12, 1e6], steps in [1, 1e5], beta in [0, 1], iterations
  /// in [1, 100000], tolerance in [0, 1], sigma in [1e-12, 1e6], history in [1, 100]; given weights
  /// n values in [0, 1], or none). \throw InvalidParameter naming the handle, vertex or parameter
  /// at fault.
  void validate(const EditState& state) const;
  /// Validates and records the wanted state; the results follow at the next update().
  /// \throw InvalidParameter as validate(); the session is then unchanged.
  void setState(EditState state);
  /// Handles from a handle file's HandleSet (new ids), keeping the parameters.
  /// \throw InvalidParameter as validate().
  void setHandles(const HandleSet& handles);
  /// Handles from a HandleSet (new ids) and the parameters, in one validation.
  /// \throw InvalidParameter as validate(); the session is then unchanged.
  void setEdit(const HandleSet& handles, EditParams params);
  /// Increases with every accepted setState().
  long version() const { return version_; }
  /// The version the results belong to (equal to version() after update()).
  long computedVersion() const { return computedVersion_; }

  /// Recomputes what the edits since the last update require, and only that. Never throws
  /// for a state that validate() accepted: failures are reported (solved = false) and the
  /// previous results are kept.
  UpdateReport update();
  const UpdateReport& lastUpdate() const { return last_; }
  /// update() for one-shot callers: a failure is thrown (its own exception: InvalidParameter,
  /// SingularSystem, ...) instead of reported.
  UpdateReport updateOrThrow();
  /// Asks the next update() to continue an unconverged deformation (and reference) from the
  /// current shapes for another `iterations`. Returns false when there is nothing to continue
  /// (the last update converged or failed, and no edit is pending).
  bool refine();

  /// Progress of the deformation's iterations (not the reference's): iteration, energy,
  /// criterion. Exceptions thrown here end the update (reported as solved = false).
  void setProgress(std::function<void(int iteration, double energy, double criterion)> progress) {
    progress_ = std::move(progress);
  }

  /// The last deformation run (energies, iterations, convergence; its positions are
  /// positions()). Unchanged by an update that did not solve the deformation.
  const DeformationResult& lastRun() const { return lastRun_; }
  /// The same edit without regularization, n x d, when params.reference asked for it and the
  /// edit is regularized (empty otherwise).
  const Eigen::MatrixXd& referencePositions() const;

  /// Current positions, n x 3 (the rest shape before any deformation or without handles).
  const Eigen::MatrixXd& positions() const { return positions_; }
  /// Regularization weights per vertex (zeros without handles).
  const Eigen::VectorXd& weights() const { return weights_; }
  /// D_k and the largest ||e_k - e_l||^2 over each element's facets, per element.
  const Eigen::VectorXd& distortion() const { return distortion_; }
  const Eigen::VectorXd& smoothness() const { return smoothness_; }
  /// Table-1 metrics of the current deformation (dist: against the unregularized edit when
  /// params.reference, 0 without regularization).
  const DeformationMetrics& metrics() const { return metrics_; }
  /// Counters summed over the session's life, per system (systems rebuilt for a new energy
  /// or weight scheme keep adding to the same totals).
  const SolverStats& weightStats() const { return weightTotals_; }
  const SolverStats& deformationStats() const { return deformTotals_; }
  const SolverStats& referenceStats() const { return referenceTotals_; }

  /// The handles as a HandleSet (for handlesToJson).
  HandleSet handleSet() const;
  /// The deformed mesh with diffreg:weight, diffreg:distortion and diffreg:smoothness.
  Mesh resultMesh() const;

 private:
  struct Systems;
  // update()'s work: the weights, the deformation and its reference, the maps and metrics.
  void compute(const EditState& want, UpdateReport& report);
  // The weights for `want` into `weights` (left as they are when nothing they depend on
  // changed); returns whether they changed.
  bool computeWeights(const EditState& want, Eigen::VectorXd& weights, UpdateReport& report);
  // Brings the diffusion's handles, ranges, magnitudes and parameters in line with `want`;
  // returns whether the weights must be solved again.
  bool syncDiffusion(const EditState& want);
  // Whether the maps depend on a parameter that changed since the last computed state.
  bool mapsParamsChanged(const EditState& want) const;
  // computeMaps for a deformation (or the rest shape without handles), zeros without one.
  void refreshMaps(const EditState& want, const Eigen::MatrixXd& positions);
  // Dist alone, when only the reference moved: the rest of the maps and metrics (the relaxed
  // energy: a second on a 43K surface) belong to the unchanged shape.
  void refreshDist(const EditState& want, const Eigen::MatrixXd& positions);
  // Whether `want` asks for the unregularized reference (a regularized edit with handles).
  static bool wantsReference(const EditState& want);
  // distortion_, smoothness_ and metrics_ for the shape `positions` (n x 3).
  void computeMaps(const EditState& want, const Eigen::MatrixXd& positions);

  // The state of a new engine from mesh_ and disc_ (both constructors).
  void initialize();

  Mesh mesh_;  // before disc_: the one-argument constructor discretizes it
  std::shared_ptr<const Discretization> disc_;
  EngineSettings settings_;
  std::function<void(int, double, double)> progress_;
  DeformationResult lastRun_;
  EditState state_;
  std::optional<EditState> computed_;  // the state the systems and results belong to
  std::unique_ptr<Systems> systems_;
  long version_ = 0, computedVersion_ = -1;
  bool refine_ = false;
  UpdateReport last_;
  Eigen::MatrixXd positions_;
  Eigen::Vector3d restCenter_;  // of the rest shape's bounding box: targets' reach
  Eigen::VectorXd weights_, distortion_, smoothness_;
  DeformationMetrics metrics_;
  SolverStats weightTotals_, deformTotals_, referenceTotals_;
};

}  // namespace diffreg
