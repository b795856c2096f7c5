// The editing sessions of the paper's Fig. 5 for Python: DiffusionWeights and
// DeformationSession own their discretization and keep their factorizations between calls;
// `stats` counts the work (symbolic analyses, numeric factorizations, solves).
#include "convert.h"
#include "progress.h"

#include <diffreg/core/error.h>
#include "deform/deform.h"
#include "weights/diffuse_weights.h"
#include <diffreg/deformation/deformer.h>
#include <diffreg/discretization/discretization.h>
#include <diffreg/weights/diffusion.h>

#include <atomic>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <thread>

namespace diffreg::python {

namespace {

// A filter's table with `values` (validated, defaults filled in).
ParamMap paramsOf(const std::string& filter, const std::map<std::string, std::string>& values) {
  return ParamMap(filter, Registry::builtin().get(filter).params(), values);
}

// A session's methods run one at a time: a solve releases the GIL, so another Python thread
// could otherwise change the session under it. The lock is awaited without the GIL, so a
// thread waiting for it never blocks the one that holds it. A call made from within one of the
// session's own calls (Python code run while its arguments are converted, e.g. an __array__)
// is an error, not a wait on itself.
struct SessionMutex {
  std::mutex mutex;
  std::atomic<std::thread::id> owner{};
};

class SessionLock {
 public:
  explicit SessionLock(SessionMutex& m) : m_(m) {
    if (m.owner.load() == std::this_thread::get_id())
      throw std::runtime_error("session: called from within one of its own calls");
    {
      py::gil_scoped_release release;
      m.mutex.lock();
    }
    m.owner.store(std::this_thread::get_id());
  }
  ~SessionLock() {
    m_.owner.store(std::thread::id());
    m_.mutex.unlock();
  }
  SessionLock(const SessionLock&) = delete;
  SessionLock& operator=(const SessionLock&) = delete;

 private:
  SessionMutex& m_;
};

// The rest mesh and its discretization, which the C++ sessions refer to.
struct Shape {
  Shape(const py::object& V, const py::object& E) : mesh(toMesh(V, E)), disc(mesh) {}
  Mesh mesh;
  Discretization disc;
};

class PyDiffusionWeights {
 public:
  PyDiffusionWeights(const py::object& V, const py::object& E, const py::kwargs& kwargs)
      : shape_(std::make_unique<Shape>(V, E)), session_(shape_->disc) {
    values_ = paramsOf("diffuse_weights", toParamText(kwargs)).text();
    session_.setParams(diffusionParamsOf(paramsOf("diffuse_weights", values_)));
  }
  void setHandles(const py::object& handles, const py::object& ranges,
                  const py::object& magnitudes) {
    const SessionLock lock(mutex_);
    const HandleSet set = toHandles(shape_->mesh, handles, py::none(), ranges, magnitudes);
    session_.setHandles(set);
    count_ = static_cast<int>(set.handles.size());
  }
  void setRange(const py::object& handle, const py::object& r) {
    const SessionLock lock(mutex_);
    session_.setRange(checked(handle), toReal(r, "r"));
  }
  void setMagnitude(const py::object& handle, const py::object& m) {
    const SessionLock lock(mutex_);
    session_.setMagnitude(checked(handle), toReal(m, "m"));
  }
  void setParams(const py::kwargs& kwargs) {
    const SessionLock lock(mutex_);
    std::map<std::string, std::string> values = values_;
    for (const auto& [key, value] : toParamText(kwargs)) values[key] = value;
    const ParamMap params = paramsOf("diffuse_weights", values);
    session_.setParams(diffusionParamsOf(params));
    values_ = params.text();
  }
  py::array solve() {
    const SessionLock lock(mutex_);
    if (count_ == 0) throw InvalidParameter("DiffusionWeights.solve: call set_handles first");
    Eigen::VectorXd w;
    {
      py::gil_scoped_release release;
      w = session_.solve();
    }
    return fromVector(std::move(w));
  }
  py::dict params() const {
    const SessionLock lock(mutex_);
    py::dict d;
    for (const auto& [key, value] : values_) d[py::str(key)] = value;
    return d;
  }
  double absoluteTime() const {
    const SessionLock lock(mutex_);
    return session_.absoluteTime();
  }
  py::dict stats() const {
    const SessionLock lock(mutex_);
    return fromStats(session_.stats());
  }

 private:
  int checked(const py::object& value) const {
    const long long handle = toInteger(value, "handle");
    if (handle < 0 || handle >= count_)
      throw InvalidParameter("handle " + std::to_string(handle) + " out of range (" +
                             std::to_string(count_) + " handles)");
    return static_cast<int>(handle);
  }
  std::unique_ptr<Shape> shape_;  // before session_, which refers to it
  DiffusionWeights session_;
  mutable SessionMutex mutex_;
  std::map<std::string, std::string> values_;
  int count_ = 0;
};

py::dict resultInfo(const DeformationResult& r, const SolverStats& stats) {
  py::dict info;
  info["energies"] = r.energies;
  info["iterations"] = r.iterations;
  info["converged"] = r.converged;
  info["criterion"] = r.criterion;
  info["accelerated_iterations"] = r.accelerated;
  info["initial_guess"] = r.initialGuess;
  info["seconds"] = r.seconds;
  for (const auto& [key, value] : fromStats(stats)) info[key] = value;
  return info;
}

class PyDeformationSession {
 public:
  PyDeformationSession(const py::object& V, const py::object& E, const py::object& weights,
                       const py::kwargs& kwargs)
      : shape_(std::make_unique<Shape>(V, E)) {
    const ParamMap params = paramsOf("deform", toParamText(kwargs));
    warnInapplicable(params, shape_->mesh.kind());
    DeformationOptions options = deformationOptionsOf(params);
    checkWeightsFor("DeformationSession", toString(options.regularization), weights);
    if (!weights.is_none())
      options.weights = toVector(weights, "weights", shape_->mesh.numVertices());
    session_ = std::make_unique<DeformationSession>(shape_->disc, options);
  }
  void setHandles(const py::object& handles) {
    const SessionLock lock(mutex_);
    const HandleSet set = toHandles(shape_->mesh, handles, py::none(), py::none(), py::none());
    vertices_ = set.allVertices();
    session_->setHandles(vertices_);
    perHandle_.clear();
    for (const Handle& h : set.handles) perHandle_.push_back(static_cast<int>(h.vertices.size()));
  }
  void setTargets(const py::object& targets) {
    const SessionLock lock(mutex_);
    if (vertices_.empty()) throw InvalidParameter("DeformationSession: call set_handles first");
    // The same per-handle or stacked forms as deform(); reuse the handle conversion.
    py::list handles;
    std::size_t row = 0;
    for (int k : perHandle_) {
      py::list ids;
      for (int i = 0; i < k; ++i) ids.append(vertices_[row + static_cast<std::size_t>(i)]);
      handles.append(ids);
      row += static_cast<std::size_t>(k);
    }
    const HandleSet set = toHandles(shape_->mesh, handles, targets, py::none(), py::none());
    Eigen::MatrixXd t(static_cast<Eigen::Index>(vertices_.size()), 3);
    Eigen::Index r = 0;
    for (const Handle& h : set.handles) {
      t.middleRows(r, h.targets.rows()) = h.targets;
      r += h.targets.rows();
    }
    session_->setTargets(t);
  }
  void setRegularization(const std::string& mode, const py::object& beta,
                         const py::object& weights) {
    const SessionLock lock(mutex_);
    std::map<std::string, std::string> values{{"regularization", mode}};
    if (!beta.is_none()) values["beta"] = formatNumber(toReal(beta, "beta"));
    const ParamMap params = paramsOf("deform", values);
    warnInapplicable(params, shape_->mesh.kind());  // a beta the mode does not use
    Eigen::VectorXd w;
    if (!weights.is_none()) w = toVector(weights, "weights", shape_->mesh.numVertices());
    session_->setRegularization(parseEnum<Regularization>(params.getString("regularization")),
                                params.getFloat("beta"), w);
  }
  void setBeta(const py::object& beta) {
    const SessionLock lock(mutex_);
    session_->setBeta(toReal(beta, "beta"));
  }
  void setTimeBudget(const py::object& seconds) {
    const SessionLock lock(mutex_);
    session_->setTimeBudget(toReal(seconds, "seconds"));
  }
  py::object lastTargets() const {
    const SessionLock lock(mutex_);
    const ElementTargets t = session_->lastTargets();
    if (t.size() == 0) return py::none();
    return fromMatrix(Eigen::MatrixXd(t));
  }
  void setWeights(const py::object& weights) {
    const SessionLock lock(mutex_);
    session_->setWeights(toVector(weights, "weights", shape_->mesh.numVertices()));
  }
  py::tuple solve(const py::object& iterations, const py::object& tolerance,
                  const py::object& progress) {
    const SessionLock lock(mutex_);
    return run(iterations, tolerance, progress,
               [&](int cap, double tol) { return session_->solve(cap, tol); });
  }
  py::tuple solveFrom(const py::object& initial, const py::object& iterations,
                      const py::object& tolerance, const py::object& progress) {
    const SessionLock lock(mutex_);
    const Eigen::MatrixXd X0 =
        toMatrix(initial, "initial", shape_->mesh.numVertices(), 3).leftCols(shape_->disc.dim());
    return run(iterations, tolerance, progress,
               [&](int cap, double tol) { return session_->solveFrom(X0, cap, tol); });
  }
  py::tuple resume(const py::object& iterations, const py::object& tolerance,
                   const py::object& progress) {
    const SessionLock lock(mutex_);
    return run(iterations, tolerance, progress,
               [&](int cap, double tol) { return session_->resume(cap, tol); });
  }
  py::dict stats() const {
    const SessionLock lock(mutex_);
    return fromStats(session_->stats());
  }

 private:
  /// `solve(cap, tolerance)` with the limits checked, the GIL released while it runs and its
  /// iterations reported to `progress` (PyProgress; the hook is removed however the run ends).
  template <class Solve>
  py::tuple run(const py::object& iterations, const py::object& tolerance,
                const py::object& progress, Solve&& solve) {
    const auto [cap, tol] = limits(iterations, tolerance);
    PyProgress reporter(progress);
    struct Hooked {
      DeformationSession& session;
      ~Hooked() { session.setProgress(nullptr); }
    } hooked{*session_};
    session_->setProgress(reporter.hook());
    DeformationResult r;
    {
      py::gil_scoped_release release;
      r = solve(cap, tol);
    }
    return finish(r);
  }
  std::pair<int, double> limits(const py::object& iterations, const py::object& tolerance) const {
    py::dict kwargs;
    kwargs["iterations"] = iterations;
    kwargs["tolerance"] = tolerance;
    const DeformationOptions& o = session_->options();
    kwargs["energy"] = toString(o.energy);  // an energy solved in one step uses neither
    const ParamMap params = paramsOf("deform", toParamText(kwargs));
    warnInapplicable(params, shape_->mesh.kind());
    return {iterations.is_none() ? o.maxIterations : params.getInt("iterations"),
            tolerance.is_none() ? o.relTolerance : params.getFloat("tolerance")};
  }
  py::tuple finish(const DeformationResult& r) {
    Mesh deformed = shape_->mesh;
    deformed.setPositions(r.positions);  // planar: n x 2, z kept
    return py::make_tuple(fromMatrix(deformed.positions()), resultInfo(r, session_->stats()));
  }
  std::unique_ptr<Shape> shape_;
  std::unique_ptr<DeformationSession> session_;
  mutable SessionMutex mutex_;
  std::vector<int> vertices_;
  std::vector<int> perHandle_;
};

// A method of `Class` that refuses an object whose __init__ never ran (Class.__new__(Class)):
// pybind11 would run the method on unbuilt memory. Self is taken as a handle, checked for its
// type and for a built holder, and only then used as a Class.
template <class Class>
struct Built {
  const char* name;
  template <class R, class... A>
  auto operator()(R (Class::*method)(A...)) const {
    return [method, name = name](py::handle self, A... args) -> R {
      return (built(self, name)->*method)(std::forward<A>(args)...);
    };
  }
  template <class R, class... A>
  auto operator()(R (Class::*method)(A...) const) const {
    return [method, name = name](py::handle self, A... args) -> R {
      return (built(self, name)->*method)(std::forward<A>(args)...);
    };
  }
  static Class* built(py::handle self, const char* name) {
    if (!py::isinstance<Class>(self))
      throw py::type_error(std::string(name) + " method called on a " +
                           std::string(py::str(py::type::of(self).attr("__name__"))));
    auto* instance = reinterpret_cast<py::detail::instance*>(self.ptr());
    const auto holder = instance->get_value_and_holder(py::detail::get_type_info(typeid(Class)));
    if (!holder || !holder.holder_constructed())
      throw py::type_error(std::string(name) +
                           ": the object was made without __init__; make it "
                           "as " +
                           name + "(...)");
    return holder.template value_ptr<Class>();
  }
};

// The docstring of both sessions' `stats`.
const char* const kStatsDoc = "Solver counters: symbolic, numeric, solves and their seconds.";

// DiffusionWeights: the diffused weights that keep their factorization between solves.
void bindDiffusionWeights(py::module_& m) {
  const Built<PyDiffusionWeights> built{"DiffusionWeights"};
  py::class_<PyDiffusionWeights>(
      m, "DiffusionWeights",
      ("DiffusionWeights(V, E" + paramSignature("diffuse_weights") +
       ")\n\nAn editing session for the diffused weights that keeps its factorization (paper "
       "Fig. 5): set_handles -> symbolic analysis and numeric factorization at the next solve; "
       "a new t (set_params) or set_range -> numeric factorization only; set_magnitude -> one "
       "solve only (the default second order by pcg: one conjugate gradient run for that "
       "handle the first time, none after). `stats` counts them.\n\n" +
       paramDoc("diffuse_weights"))
          .c_str())
      .def(py::init([](const py::object& V, const py::object& E, const py::kwargs& kwargs) {
             PyWarnings warnings;
             auto made = std::make_unique<PyDiffusionWeights>(V, E, kwargs);
             warnings.issue();  // a warning made an error drops `made` with it
             return made;
           }),
           py::arg("V"), py::arg("E"))
      .def("set_handles", built(&PyDiffusionWeights::setHandles), py::call_guard<PyWarnings>(),
           py::arg("handles"), py::arg("ranges") = py::none(), py::arg("magnitudes") = py::none(),
           "set_handles(handles, ranges=None, magnitudes=None)\n\nHandle vertex sets (a list "
           "of vertex-id arrays) with ranges r_j in [1e-6, 1e6] and magnitudes m_j in [0, 1] "
           "(default 1).")
      .def("set_range", built(&PyDiffusionWeights::setRange), py::call_guard<PyWarnings>(),
           py::arg("handle"), py::arg("r"),
           "set_range(handle, r)\n\nThe range r_j of handle j (0-based).")
      .def("set_magnitude", built(&PyDiffusionWeights::setMagnitude), py::call_guard<PyWarnings>(),
           py::arg("handle"), py::arg("m"),
           "set_magnitude(handle, m)\n\nThe magnitude m_j of handle j (0-based).")
      .def("set_params", built(&PyDiffusionWeights::setParams), py::call_guard<PyWarnings>(),
           ("set_params(**params)\n\nChanges any of the diffuse_weights parameters (the others "
            "keep their values).\n\n" +
            paramDoc("diffuse_weights"))
               .c_str())
      .def("solve", built(&PyDiffusionWeights::solve), py::call_guard<PyWarnings>(),
           "solve() -> weights (n,)")
      .def_property_readonly("params", built(&PyDiffusionWeights::params),
                             "The current parameters as the tool's text values.")
      .def_property_readonly("absolute_time", built(&PyDiffusionWeights::absoluteTime),
                             "t in length^2 after applying t_unit.")
      .def_property_readonly("stats", built(&PyDiffusionWeights::stats), kStatsDoc);
}

// DeformationSession: the regularized deformation that keeps its factorization between solves.
void bindDeformationSession(py::module_& m) {
  const Built<PyDeformationSession> built{"DeformationSession"};
  const std::string limitsDoc =
      "iterations, tolerance: None = the session's (from the constructor's parameters). " +
      std::string(kProgressDoc);
  py::class_<PyDeformationSession>(
      m, "DeformationSession",
      ("DeformationSession(V, E, weights=None" + paramSignature("deform") +
       ")\n\nA deformation editing session (paper Fig. 5) on the rest shape (V, E): "
       "set_handles -> symbolic analysis and numeric factorization at the next solve; "
       "set_regularization / set_beta / set_weights -> numeric factorization only; "
       "set_targets -> new right-hand sides only. `stats` counts them (summed over the "
       "session's factorizations).\n\n" +
       paramDoc("deform"))
          .c_str())
      .def(py::init([](const py::object& V, const py::object& E, const py::object& weights,
                       const py::kwargs& kwargs) {
             PyWarnings warnings;
             auto made = std::make_unique<PyDeformationSession>(V, E, weights, kwargs);
             warnings.issue();  // a warning made an error drops `made` with it
             return made;
           }),
           py::arg("V"), py::arg("E"), py::arg("weights") = py::none())
      .def("set_handles", built(&PyDeformationSession::setHandles), py::call_guard<PyWarnings>(),
           py::arg("handles"),
           "set_handles(handles)\n\nConstrained vertices, a list of vertex-id arrays (one per "
           "handle); their targets reset to the rest positions.")
      .def("set_targets", built(&PyDeformationSession::setTargets), py::call_guard<PyWarnings>(),
           py::arg("targets"),
           "set_targets(targets)\n\nOne (k_j, 3) array per handle, or one array stacked handle "
           "by handle.")
      .def("set_regularization", built(&PyDeformationSession::setRegularization),
           py::call_guard<PyWarnings>(), py::arg("regularization"), py::arg("beta") = py::none(),
           py::arg("weights") = py::none(),
           "set_regularization(regularization, beta=None, weights=None)\n\n'none', 'uniform' "
           "(with beta, default the deform filter's) or 'nonuniform' (with weights, one per "
           "vertex).")
      .def("set_beta", built(&PyDeformationSession::setBeta), py::call_guard<PyWarnings>(),
           py::arg("beta"), "set_beta(beta)\n\nUniform regularization with this beta.")
      .def("set_weights", built(&PyDeformationSession::setWeights), py::call_guard<PyWarnings>(),
           py::arg("weights"),
           "set_weights(weights)\n\nNon-uniform regularization with these vertex weights.")
      .def("set_time_budget", built(&PyDeformationSession::setTimeBudget),
           py::call_guard<PyWarnings>(), py::arg("seconds"),
           "set_time_budget(seconds)\n\nSeconds each solve, solve_from or resume may iterate "
           "(0: no limit, the default): the run stops unconverged after the first iteration "
           "that leaves less time than it took itself, and resume() continues it with the "
           "steps of one run. For interactive "
           "use; where it stops depends on the machine.")
      .def("solve", built(&PyDeformationSession::solve), py::call_guard<PyWarnings>(),
           py::arg("iterations") = py::none(), py::arg("tolerance") = py::none(),
           py::arg("progress") = py::none(),
           ("solve(iterations=None, tolerance=None, progress=None) -> (X, info)\n\nFrom the rest "
            "shape. X "
            "(n, 3); info: energies, iterations, converged, criterion, accelerated_iterations, "
            "initial_guess, seconds and the session's counters. " +
            limitsDoc)
               .c_str())
      .def("solve_from", built(&PyDeformationSession::solveFrom), py::call_guard<PyWarnings>(),
           py::arg("initial"), py::arg("iterations") = py::none(),
           py::arg("tolerance") = py::none(), py::arg("progress") = py::none(),
           ("solve_from(initial, iterations=None, tolerance=None, progress=None) -> (X, "
            "info)\n\nLike solve(), "
            "starting from the positions `initial` (n, 3), e.g. the previous result while "
            "dragging. " +
            limitsDoc)
               .c_str())
      .def("resume", built(&PyDeformationSession::resume), py::call_guard<PyWarnings>(),
           py::arg("iterations") = py::none(), py::arg("tolerance") = py::none(),
           py::arg("progress") = py::none(),
           ("resume(iterations=None, tolerance=None, progress=None) -> (X, info)\n\nContinues the "
            "last solve "
            "where it stopped (as one long run); solves afresh when nothing can be continued. " +
            limitsDoc)
               .c_str())
      .def("last_targets", built(&PyDeformationSession::lastTargets), py::call_guard<PyWarnings>(),
           "last_targets() -> array or None\n\nThe targets of the shape the last run stopped "
           "at: (m d, d), the d x d block T_k^T of each element in its d rows, d the mesh's "
           "dimension (2 planar, 3 otherwise). measure(..., start_targets=...) relaxes the "
           "energy of that shape from them (a step or two instead of many). None when nothing "
           "can be continued (as resume(): no run yet, a linear energy, or new handles, targets "
           "or regularization since).")
      .def_property_readonly("stats", built(&PyDeformationSession::stats), kStatsDoc);
}

}  // namespace

void bindSessions(py::module_& m) {
  bindDiffusionWeights(m);
  bindDeformationSession(m);
}

}  // namespace diffreg::python
