// The Python module `diffreg`: numpy arrays in and out of the library's one-shot operators,
// which run the same filters (and parameter tables) as the `diffreg` command-line tool, plus
// the editing sessions (sessions.cpp).
#include "convert.h"
#include "progress.h"

#include <diffreg/core/error.h>
#include <diffreg/core/staged_outputs.h>
#include <diffreg/deformation/metrics.h>
#include <diffreg/deformation/regularizer.h>
#include <diffreg/discretization/discretization.h>
#include <diffreg/mesh/io.h>
#include <diffreg/pipeline/document.h>
#include <diffreg/pipeline/mlx.h>
#include <diffreg/pipeline/pipeline.h>

#include <diffreg/version.h>

namespace diffreg::python {

void bindSessions(py::module_& m);

namespace {

Document makeDocument(Mesh mesh, HandleSet handles) {
  Document doc;
  doc.rest = mesh.positions();
  doc.mesh = std::move(mesh);
  doc.handles = std::move(handles);
  return doc;
}

// pipeline.run(doc) with the GIL released, its deformations reporting to `progress` (None or
// a callable (iteration, energy, criterion)) and stopping at Ctrl-C (PyProgress).
nlohmann::json runWithProgress(const Pipeline& pipeline, Document& doc,
                               const py::object& progress) {
  PyProgress reporter(progress);
  const auto hook = reporter.hook();
  struct Hooked {  // the hook goes with the call, however it ends
    Document& doc;
    ~Hooked() { doc.progress = nullptr; }
  } hooked{doc};
  doc.progress = [hook](const std::string&, int iteration, double energy, double criterion) {
    hook(iteration, energy, criterion);
  };
  py::gil_scoped_release release;
  return pipeline.run(doc);
}

// Applies one built-in filter with the keyword arguments as its parameters (validated and
// completed from its table), the GIL released while it works. Returns the filter's result as
// the CLI's report entry (data, params, solver counters).
py::dict applyFilter(Document& doc, const std::string& name, const py::dict& kwargs,
                     const py::object& progress = py::none()) {
  Pipeline pipeline;
  pipeline.add(name, toParamText(kwargs));
  return fromJson(runWithProgress(pipeline, doc, progress)["filters"][0]).cast<py::dict>();
}

py::array weightsOf(const py::object& V, const py::object& E, const py::object& handles,
                    const py::object& ranges, const py::object& magnitudes,
                    const std::string& filter, const py::kwargs& kwargs) {
  Mesh mesh = toMesh(V, E);
  HandleSet set = toHandles(mesh, handles, py::none(), ranges, magnitudes);
  Document doc = makeDocument(std::move(mesh), std::move(set));
  applyFilter(doc, filter, kwargs);
  return fromVector(doc.mesh.vertexScalar(prop::weight));
}

py::tuple deformArrays(const py::object& V, const py::object& E, const py::object& handles,
                       const py::object& targets, const py::object& weights,
                       const py::object& progress, const py::kwargs& kwargs) {
  Mesh mesh = toMesh(V, E);
  HandleSet set = toHandles(mesh, handles, targets, py::none(), py::none());
  const int n = mesh.numVertices();
  if (!weights.is_none()) mesh.setVertexScalar(prop::weight, toVector(weights, "weights", n));
  Document doc = makeDocument(std::move(mesh), std::move(set));
  const std::string regularization =
      kwargs.contains("regularization") && !kwargs["regularization"].is_none()
          ? py::str(kwargs["regularization"]).cast<std::string>()
          : "";
  checkWeightsFor("deform", regularization, weights);
  py::dict info = applyFilter(doc, "deform", kwargs, progress);
  return py::make_tuple(fromMatrix(doc.mesh.positions()), info);
}

py::dict measureArrays(const py::object& V, const py::object& E, const py::object& X,
                       const py::object& weights, const py::object& reference,
                       const py::object& startTargets, const py::kwargs& kwargs) {
  // energy, regularization and beta with the deform filter's names, defaults and checks.
  std::vector<ParamSpec> specs;
  for (const ParamSpec& spec : Registry::builtin().get("deform").params())
    if (spec.name == "energy" || spec.name == "regularization" || spec.name == "beta")
      specs.push_back(spec);
  const ParamMap params("measure", specs, toParamText(kwargs));
  const Mesh mesh = toMesh(V, E);
  const Discretization disc(mesh);
  const Eigen::Index n = mesh.numVertices();
  const Eigen::MatrixXd positions = toMatrix(X, "X", n, -1);
  if (positions.cols() < disc.dim() || positions.cols() > 3)
    throw InvalidParameter("X: expected shape (" + std::to_string(n) + ", 3), got (" +
                           std::to_string(n) + ", " + std::to_string(positions.cols()) + ")");
  const Energy energy = parseEnum<Energy>(params.getString("energy"));
  const Regularization mode = parseEnum<Regularization>(params.getString("regularization"));
  Eigen::VectorXd w;
  if (mode == Regularization::Nonuniform) {
    if (weights.is_none())
      throw InvalidParameter("measure: regularization nonuniform needs weights (one per vertex)");
    w = toVector(weights, "weights", n);
  }
  Eigen::MatrixXd ref;
  if (!reference.is_none())
    ref = toMatrix(reference, "reference", n, positions.cols()).leftCols(disc.dim());
  ElementTargets start;
  if (!startTargets.is_none()) {
    const Eigen::Index d = disc.dim();
    start = toMatrix(startTargets, "start_targets", disc.numElements() * d, d);
  }
  DeformationMetrics metrics;
  Eigen::VectorXd distortion;
  {
    py::gil_scoped_release release;
    const RegularizationWeights rw =
        makeRegularizationWeights(disc, mode, params.getFloat("beta"), w);
    const Eigen::MatrixXd X = positions.leftCols(disc.dim());
    distortion = elementDistortion(disc, energy, X);
    metrics = measureDeformation(disc, energy, X, rw, reference.is_none() ? nullptr : &ref, nullptr,
                                 startTargets.is_none() ? nullptr : &start, &distortion);
  }
  py::dict out;
  out["D_max"] = metrics.dMax;
  out["D_ave"] = metrics.dAve;
  out["D_dev"] = metrics.dDev;
  out["dist"] = metrics.dist ? py::object(py::float_(*metrics.dist)) : py::object(py::none());
  out["inverted"] = metrics.inverted;
  out["energy"] = metrics.energy;
  out["distortion"] = fromVector(distortion);
  return out;
}

// Every double vertex (element) property of a mesh read from a file, e.g. the diffreg:...
// properties an .om file keeps.
py::dict fileProperties(const Mesh& mesh, bool vertex) {
  py::dict out;
  if (mesh.isTet()) {
    for (const auto& name : vertex ? mesh.vertexScalarNames() : mesh.elementScalarNames())
      out[py::str(name)] = fromVector(vertex ? mesh.vertexScalar(name) : mesh.elementScalar(name));
    return out;
  }
  const TriMesh& tri = mesh.tri();
  const auto collect = [&](auto begin, auto end) {
    for (auto it = begin; it != end; ++it) {
      const auto* p = dynamic_cast<const OpenMesh::PropertyT<double>*>(*it);
      if (p == nullptr) continue;
      const auto& data = p->data_vector();
      out[py::str(p->name())] = fromVector(
          Eigen::Map<const Eigen::VectorXd>(data.data(), static_cast<Eigen::Index>(data.size())));
    }
  };
  if (vertex)
    collect(tri.vprops_begin(), tri.vprops_end());
  else
    collect(tri.fprops_begin(), tri.fprops_end());
  return out;
}

py::tuple readArrays(const py::object& file, bool properties) {
  const std::string path = toPath(file, "path");
  Mesh mesh;
  {
    py::gil_scoped_release release;
    mesh = readMesh(path);
  }
  if (!properties) return py::make_tuple(fromMatrix(mesh.positions()), fromMatrix(mesh.elements()));
  return py::make_tuple(fromMatrix(mesh.positions()), fromMatrix(mesh.elements()),
                        fileProperties(mesh, true), fileProperties(mesh, false));
}

py::tuple readHandleFile(const py::object& file, const py::object& V, const py::object& E) {
  const std::string path = toPath(file, "path");
  const Mesh mesh = toMesh(V, E);
  const HandleSet set = readHandles(path, mesh);
  py::list handles, targets, names;
  std::vector<double> ranges, magnitudes;
  for (const Handle& h : set.handles) {
    py::array_t<long long> ids(static_cast<py::ssize_t>(h.vertices.size()));
    for (std::size_t i = 0; i < h.vertices.size(); ++i)
      ids.mutable_at(static_cast<py::ssize_t>(i)) = h.vertices[i];
    handles.append(ids);
    targets.append(fromMatrix(Eigen::MatrixXd(h.targets)));
    ranges.push_back(h.range);
    magnitudes.push_back(h.magnitude);
    names.append(h.name);
  }
  const auto vector = [](std::vector<double>& v) {
    return fromVector(Eigen::Map<Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size())));
  };
  return py::make_tuple(handles, targets, vector(ranges), vector(magnitudes), names);
}

void writeArrays(const py::object& file, const py::object& V, const py::object& E,
                 const py::object& vertexProperties, const py::object& elementProperties,
                 const py::object& vertexQuality, const py::object& faceQuality,
                 const py::object& colors) {
  // Its warnings issued before the file is put in place: one that the filters make an error
  // leaves the file as it was.
  PyWarnings warnings;
  const std::string path = toPath(file, "path");
  Mesh mesh = toMesh(V, E);
  if (!vertexProperties.is_none())
    for (const auto& [key, value] : vertexProperties.cast<py::dict>()) {
      const std::string name = py::str(key);
      mesh.setVertexScalar(
          name, toVector(value, ("vertex property '" + name + "'").c_str(), mesh.numVertices()));
    }
  if (!elementProperties.is_none())
    for (const auto& [key, value] : elementProperties.cast<py::dict>()) {
      const std::string name = py::str(key);
      mesh.setElementScalar(
          name, toVector(value, ("element property '" + name + "'").c_str(), mesh.numElements()));
    }
  WriteOptions options;
  options.vertexQuality = toText(vertexQuality, "vertex_quality");
  options.faceQuality = toText(faceQuality, "face_quality");
  options.colors = toFlag(colors, "colors");
  // Checked on the path given: its temporary has another name.
  checkWritableDir(path);
  checkWritable(path, mesh.kind());
  StagedOutputs staged;
  {
    py::gil_scoped_release release;
    staged.stageWritten(path,
                        [&](const std::string& temporary) { writeMesh(temporary, mesh, options); });
  }
  warnings.issue();
  staged.commit();
}

py::dict propertiesOf(const Mesh& mesh, bool vertex) {
  py::dict out;
  for (const auto& name : vertex ? mesh.vertexScalarNames() : mesh.elementScalarNames())
    out[py::str(name)] = fromVector(vertex ? mesh.vertexScalar(name) : mesh.elementScalar(name));
  return out;
}

py::dict runPipeline(const py::object& meshArg, const py::object& filters,
                     const py::object& handles, const py::object& targets, const py::object& ranges,
                     const py::object& magnitudes, const py::object& script,
                     const py::object& progress) {
  PyWarnings warnings;
  // targets, ranges and magnitudes complete a handle list; a handle file has its own.
  for (const auto& [name, value] : {std::pair<const char*, const py::object*>{"targets", &targets},
                                    {"ranges", &ranges},
                                    {"magnitudes", &magnitudes}})
    if (!value->is_none() && (handles.is_none() || isPath(handles)))
      throw InvalidParameter(
          std::string("run: ") + name + " go with a list of handles, " +
          (handles.is_none() ? "and none is given" : "not with a handle file (it has its own)"));
  Document doc;
  if (isPath(meshArg)) {
    const std::string path = toPath(meshArg, "mesh");
    if (isPath(handles)) {
      doc = Document::load(path, toPath(handles, "handles"));
    } else {
      doc = Document::load(path);
      if (!handles.is_none())
        doc.handles = toHandles(doc.mesh, handles, targets, ranges, magnitudes);
    }
  } else {
    if (!py::isinstance<py::tuple>(meshArg) && !py::isinstance<py::list>(meshArg))
      throw InvalidParameter("run: mesh must be a file path or a tuple (V, E)");
    const py::sequence ve = meshArg.cast<py::sequence>();
    if (ve.size() != 2) throw InvalidParameter("run: mesh must be a file path or a tuple (V, E)");
    Mesh mesh = toMesh(ve[0], ve[1]);
    HandleSet set;
    const std::string handlesPath = isPath(handles) ? toPath(handles, "handles") : "";
    if (isPath(handles))
      set = readHandles(handlesPath, mesh);
    else if (!handles.is_none())
      set = toHandles(mesh, handles, targets, ranges, magnitudes);
    doc = makeDocument(std::move(mesh), std::move(set));
    doc.handlesPath = handlesPath;
  }
  Pipeline pipeline;
  if (!script.is_none())  // a MeshLab .mlx script's steps first, as the tool's -s
    for (const Step& step : readFilterScript(toPath(script, "script"))) pipeline.add(step);
  if (py::isinstance<py::str>(filters))
    throw InvalidParameter(
        "run: filters must be a list of filter strings, e.g. ['diffuse_weights t=0.01']");
  for (const py::handle item : filters) {
    if (!py::isinstance<py::str>(item))
      throw InvalidParameter("run: every filter must be a string such as 'deform energy=arap'");
    const auto [name, values] = parseFilterSpec(item.cast<std::string>());
    pipeline.add(name, values);
  }
  // Files the filters write (render's PNG) appear together when the whole run succeeds, as
  // the tool's outputs do: a step that fails leaves none of them behind, nor clobbers any.
  StagedOutputs staged;
  doc.outputFile = [&staged](const std::string& path) { return staged.stage(path); };
  const nlohmann::json report = runWithProgress(pipeline, doc, progress);
  warnings.issue();  // a warning made an error fails the run before its files appear
  staged.commit();
  py::dict out;
  out["V"] = fromMatrix(doc.mesh.positions());
  out["E"] = fromMatrix(doc.mesh.elements());
  out["vertex_properties"] = propertiesOf(doc.mesh, true);
  out["element_properties"] = propertiesOf(doc.mesh, false);
  out["report"] = fromJson(report);
  return out;
}

py::list filterTables() {
  py::list out;
  const Registry& registry = Registry::builtin();
  for (const auto& name : registry.names()) {
    const Filter& filter = registry.get(name);
    py::list params;
    for (const ParamSpec& spec : filter.params()) {
      py::dict p;
      p["name"] = spec.name;
      p["type"] = toString(spec.type);
      p["default"] = spec.defaultValue;
      p["choices"] = spec.choices;
      if (hasRange(spec)) p["range"] = py::make_tuple(spec.min, spec.max);
      p["help"] = spec.help;
      params.append(p);
    }
    py::dict f;
    f["name"] = name;
    f["description"] = filter.description();
    f["params"] = params;
    out.append(f);
  }
  return out;
}

// diffuse_weights() and rbf_weights(): the weights filter `filter` on arrays; `description`
// opens the docstring, the filter's parameter table follows.
void bindWeights(py::module_& m, const std::string& filter, const std::string& description) {
  m.def(
      filter.c_str(),
      [filter](const py::object& V, const py::object& E, const py::object& handles,
               const py::object& ranges, const py::object& magnitudes, const py::kwargs& kwargs) {
        return weightsOf(V, E, handles, ranges, magnitudes, filter, kwargs);
      },
      py::call_guard<PyWarnings>(), py::arg("V"), py::arg("E"), py::arg("handles"),
      py::arg("ranges") = py::none(), py::arg("magnitudes") = py::none(),
      (filter + "(V, E, handles, ranges=None, magnitudes=None" + paramSignature(filter) +
       ") -> weights (n,)\n\n" + description + "\n\n" + paramDoc(filter))
          .c_str());
}

// deform() and measure(): the deformation of arrays and its metrics.
void bindDeformation(py::module_& m) {
  m.def("deform", &deformArrays, py::call_guard<PyWarnings>(), py::arg("V"), py::arg("E"),
        py::arg("handles"), py::arg("targets"), py::arg("weights") = py::none(),
        py::arg("progress") = py::none(),
        ("deform(V, E, handles, targets, weights=None, progress=None" + paramSignature("deform") +
         ") -> (X, info)\n\n"
         "Deforms the mesh from its rest shape V with the handle vertices moved to their "
         "targets (hard constraints), as the filter deform of the diffreg tool. targets: one "
         "(k_j, 3) array per handle, or one array stacked handle by handle. weights: one per "
         "vertex, for regularization='nonuniform'. X is (n, 3) (planar meshes keep z). info "
         "is the tool's report entry (a criterion it has as null is NaN here): energies (per "
         "iteration), iterations, converged, "
         "criterion, initial_guess, local_step, acceleration, the solver counters symbolic, "
         "numeric, solves and their seconds, params. " +
         kProgressDoc + "\n\n" + paramDoc("deform"))
            .c_str());
  m.def("measure", &measureArrays, py::call_guard<PyWarnings>(), py::arg("V"), py::arg("E"),
        py::arg("X"), py::arg("weights") = py::none(), py::arg("reference") = py::none(),
        py::arg("start_targets") = py::none(),
        ("measure(V, E, X, weights=None, reference=None, start_targets=None" +
         paramSignature("deform", {"local_step", "acceleration", "iterations", "tolerance"}) +
         ") -> dict\n\n"
         "The paper's Table-1 metrics of the deformation X of the rest shape (V, E): D_max, "
         "D_ave, D_dev (distortion per element, max, area-weighted mean and deviation), "
         "inverted (elements), energy (the regularized energy with energy, regularization, "
         "beta, weights) and dist (RMS distance to `reference`, e.g. the same edit with "
         "regularization='none'; None without one), and distortion, the per-element D_k "
         "(the tool's diffreg:distortion). start_targets: DeformationSession.last_targets() "
         "of the run that ended at X, where relaxing the energy may start (the same value, "
         "sooner).\n\n" +
         paramDoc("deform", {"local_step", "acceleration", "iterations", "tolerance"}))
            .c_str());
}

// read_mesh(), read_handles() and write_mesh(): the tool's file formats as arrays.
void bindFiles(py::module_& m) {
  m.def("read_mesh", &readArrays, py::call_guard<PyWarnings>(), py::arg("path"),
        py::arg("properties") = false,
        "read_mesh(path, properties=False) -> (V, E) or (V, E, vertex_properties, "
        "element_properties)\n\nReads OBJ, OFF, PLY, OM, Medit .mesh or TetGen .node/.ele "
        "with the tool's checks (path: str, bytes or os.PathLike such as pathlib.Path, as for "
        "every file this module reads or writes): V (n, 3) float64, E (m, 3) triangles or (m, 4) "
        "tets, int64. "
        "properties=True adds dicts name -> array of the double properties the file keeps (an "
        ".om file written by the tool keeps diffreg:weight, diffreg:distortion, ...). Raises "
        "OSError for an unreadable file, ValueError for an invalid mesh.");
  m.def("read_handles", &readHandleFile, py::call_guard<PyWarnings>(), py::arg("path"),
        py::arg("V"), py::arg("E"),
        "read_handles(path, V, E) -> (handles, targets, ranges, magnitudes, names)\n\nReads "
        "a handle file (the tool's --handles JSON) against the rest shape (V, E): the vertex "
        "ids and (k_j, 3) targets of each handle, ready for deform() and diffuse_weights().");
  m.def("write_mesh", &writeArrays, py::arg("path"), py::arg("V"),  // its own PyWarnings
        py::arg("E"), py::arg("vertex_properties") = py::none(),
        py::arg("element_properties") = py::none(),
        py::arg("vertex_quality") = py::str(prop::weight),
        py::arg("face_quality") = py::str(prop::distortion), py::arg("colors") = py::bool_(true),
        "write_mesh(path, V, E, vertex_properties=None, element_properties=None, "
        "vertex_quality='diffreg:weight', face_quality='diffreg:distortion', colors=True)\n\n"
        "Writes OBJ/OFF/PLY/OM (triangles) or .mesh/PLY boundary (tets), atomically. "
        "vertex_properties / element_properties: dicts name -> (n,) / (m,) arrays. PLY writes "
        "the property `vertex_quality` as vertex quality (with viridis colours when colors) and "
        "`face_quality` as face quality, and every other property under its own name (names "
        "that are one word of printable ASCII); .om keeps all of them.");
}

// run() and filters(): whole pipelines of the tool's filters and their tables.
void bindPipeline(py::module_& m) {
  m.def("run", &runPipeline, py::arg("mesh"),  // its warnings: runPipeline's own PyWarnings
        py::arg("filters") = py::list(), py::arg("handles") = py::none(),
        py::arg("targets") = py::none(), py::arg("ranges") = py::none(),
        py::arg("magnitudes") = py::none(), py::arg("script") = py::none(),
        py::arg("progress") = py::none(),
        ("run(mesh, filters=[], handles=None, targets=None, ranges=None, magnitudes=None, "
         "script=None, progress=None) -> dict\n\n"
         "Runs a pipeline of the diffreg tool's filters, given as its --filter strings (e.g. "
         "['diffuse_weights t=0.01', 'deform energy=arap regularization=nonuniform', "
         "'measure']). mesh: a mesh file path or a tuple (V, E). handles: a handle file path "
         "(the tool's --handles JSON) or a list of vertex-id arrays with targets, ranges, "
         "magnitudes as for deform(). script: a MeshLab .mlx filter script whose steps run "
         "first (the tool's -s). Every step is checked before any runs. Returns V, E, "
         "vertex_properties, element_properties (dicts of arrays, e.g. 'diffreg:weight') and "
         "report (the tool's --report JSON as a dict). " +
         std::string(kProgressDoc))
            .c_str());
  m.def("filters", &filterTables, py::call_guard<PyWarnings>(),
        "filters() -> list\n\nEvery filter of the diffreg tool with its description and "
        "parameter table (name, type, default as text, choices, range, help).");
}

}  // namespace

}  // namespace diffreg::python

PYBIND11_MODULE(diffreg, m) {
  using namespace diffreg::python;
  py::options options;
  options.disable_function_signatures();  // the docstrings carry them, from the filter tables
  registerExceptions();
  registerWarnings(m);

  m.doc() =
      "Regularized variational mesh deformation with diffused non-uniform weights (Zhu, Li, "
      "Zhang, Song, CAD 2016).\n\n"
      "numpy in and out: positions V (n, 3) float64, elements E (m, 3) triangles or (m, 4) "
      "tets, integer. Handles are a list of vertex-id arrays, one per handle. Parameters have "
      "the names, defaults and checks of the `diffreg` tool's filters (see filters()). Errors "
      "raise ValueError (invalid parameter, mesh or system) or OSError (files) with the "
      "tool's one-line message. File paths are str, bytes or os.PathLike (pathlib.Path). "
      "Warnings (a file read with repairs, a run stopped "
      "unconverged, ...) are issued through Python's warnings module as DiffregWarning, a "
      "UserWarning, after the call that gave them.";
  m.attr("__version__") = DIFFREG_VERSION_STRING;

  bindWeights(m, "diffuse_weights",
              "Diffused regularization weights: heat flows from the handles (value m_j = "
              "magnitudes[j], range r_j = ranges[j], both 1 by default) for the time t, as the "
              "filter diffuse_weights of the diffreg tool.");
  bindWeights(m, "rbf_weights",
              "The paper's RBF baseline weights, sum_j m_j exp(-(d / (r_j sigma))^2), as the "
              "filter rbf_weights of the diffreg tool.");
  bindDeformation(m);
  bindFiles(m);
  bindPipeline(m);
  bindSessions(m);
}
