#include "convert.h"

#include <diffreg/core/error.h>
#include <diffreg/core/text.h>
#include <diffreg/mesh/halfedges.h>
#include <diffreg/mesh/io.h>

#include <array>
#include <cmath>
#include <exception>
#include <optional>
#include <sstream>

namespace diffreg::python {

namespace {

std::string shapeText(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t d = 0; d < a.ndim(); ++d) s += (d ? ", " : "") + std::to_string(a.shape(d));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

// The object as a numpy array of real (or, with `integer`, integer) numbers.
py::array asArray(const py::handle& obj, const std::string& what, bool integer) {
  if (obj.is_none()) throw InvalidParameter(what + ": expected an array, got None");
  // numpy.asarray, so that an exception of the object's own (its __array__, a Ctrl-C) reaches
  // the caller as itself; what numpy says of an object it cannot take is ours, naming `what`.
  py::array a;
  try {
    a = py::module_::import("numpy").attr("asarray")(obj);
  } catch (py::error_already_set& e) {
    if (!e.matches(PyExc_ValueError) && !e.matches(PyExc_TypeError)) throw;
    throw InvalidParameter(what + ": expected an array of numbers");
  }
  const char kind = a.dtype().kind();
  if (a.size() == 0) return a;  // an empty list has dtype float64; the shape check says more
  if (integer && kind != 'i' && kind != 'u')
    throw InvalidParameter(what + ": expected integer indices, got dtype " +
                           std::string(py::str(a.dtype())));
  if (!integer && kind != 'f' && kind != 'i' && kind != 'u')
    throw InvalidParameter(what + ": expected real numbers, got dtype " +
                           std::string(py::str(a.dtype())));
  return a;
}

}  // namespace

Eigen::MatrixXd toMatrix(const py::handle& obj, const char* what, Eigen::Index rows,
                         Eigen::Index cols) {
  const py::array a = asArray(obj, what, false);
  const std::string expected = "(" + (rows < 0 ? std::string("n") : std::to_string(rows)) + ", " +
                               (cols < 0 ? std::string("k") : std::to_string(cols)) + ")";
  if (a.ndim() != 2 || (rows >= 0 && a.shape(0) != rows) || (cols >= 0 && a.shape(1) != cols))
    throw InvalidParameter(std::string(what) + ": expected shape " + expected + ", got " +
                           shapeText(a));
  const auto c = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
  const Eigen::Index r = a.shape(0), k = a.shape(1);
  Eigen::MatrixXd m(r, k);
  const double* data = c.data();
  for (Eigen::Index i = 0; i < r; ++i)
    for (Eigen::Index j = 0; j < k; ++j) m(i, j) = data[i * k + j];
  if (!m.allFinite())
    throw InvalidParameter(std::string(what) + ": non-finite value (NaN or infinity)");
  return m;
}

Eigen::MatrixXd toPositions(const py::handle& obj, const char* what) {
  const py::array a = asArray(obj, what, false);
  if (a.ndim() != 2 || (a.shape(1) != 3 && a.shape(1) != 2) || a.shape(0) == 0)
    throw InvalidParameter(std::string(what) +
                           ": expected positions of shape (n, 3) or (n, 2), got " + shapeText(a));
  Eigen::MatrixXd p = toMatrix(a, what, -1, -1);
  if (p.cols() == 2) {
    p.conservativeResize(Eigen::NoChange, 3);
    p.col(2).setZero();
  }
  return p;
}

Eigen::VectorXd toVector(const py::handle& obj, const char* what, Eigen::Index size) {
  const py::array a = asArray(obj, what, false);
  if (a.ndim() != 1 || (size >= 0 && a.shape(0) != size))
    throw InvalidParameter(std::string(what) + ": expected shape (" +
                           (size < 0 ? std::string("n") : std::to_string(size)) + ",), got " +
                           shapeText(a));
  const auto c = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
  Eigen::VectorXd v(a.shape(0));
  for (Eigen::Index i = 0; i < v.size(); ++i) v[i] = c.data()[i];
  if (!v.allFinite())
    throw InvalidParameter(std::string(what) + ": non-finite value (NaN or infinity)");
  return v;
}

namespace {

// The entry `flat` (C order) of an index array as the caller wrote it: a uint64 above the
// int64 range wraps in the conversion, and the message names the number given.
std::string givenId(const py::array& a, Eigen::Index flat) {
  return py::str(a.attr("ravel")()[py::int_(flat)]).cast<std::string>();
}

}  // namespace

Eigen::MatrixXi toElements(const py::handle& obj, int numVertices) {
  const py::array a = asArray(obj, "E", true);
  if (a.ndim() != 2 || (a.shape(1) != 3 && a.shape(1) != 4) || a.shape(0) == 0)
    throw InvalidParameter(
        "E: expected elements of shape (m, 3) (triangles) or (m, 4) (tets), got " + shapeText(a));
  const auto c = py::array_t<long long, py::array::c_style | py::array::forcecast>::ensure(a);
  const Eigen::Index m = a.shape(0), k = a.shape(1);
  Eigen::MatrixXi e(m, k);
  for (Eigen::Index i = 0; i < m; ++i)
    for (Eigen::Index j = 0; j < k; ++j) {
      const long long id = c.data()[i * k + j];
      if (id < 0 || id >= numVertices)
        throw InvalidMesh("arrays: element " + std::to_string(i) + " (0-based) refers to vertex " +
                          givenId(a, i * k + j) + ", but there are " + std::to_string(numVertices) +
                          " vertices");
      e(i, j) = static_cast<int>(id);
    }
  return e;
}

std::vector<int> toIds(const py::handle& obj, const char* what, int numVertices) {
  const py::array a = asArray(obj, what, true);
  if (a.ndim() != 1)
    throw InvalidParameter(std::string(what) + ": expected a 1-D array of vertex ids, got shape " +
                           shapeText(a));
  const auto c = py::array_t<long long, py::array::c_style | py::array::forcecast>::ensure(a);
  std::vector<int> ids(static_cast<std::size_t>(a.shape(0)));
  for (std::size_t i = 0; i < ids.size(); ++i) {
    const long long id = c.data()[i];
    if (id < 0 || id >= numVertices)
      throw InvalidParameter(
          std::string(what) + ": vertex " + givenId(a, static_cast<Eigen::Index>(i)) +
          " out of range (the mesh has " + std::to_string(numVertices) + " vertices)");
    ids[i] = static_cast<int>(id);
  }
  return ids;
}

bool isPath(const py::handle& value) {
  return py::isinstance<py::str>(value) || py::isinstance<py::bytes>(value) ||
         py::hasattr(value, "__fspath__");
}

std::string toPath(const py::handle& value, const char* what) {
  if (!isPath(value))
    throw InvalidParameter(std::string(what) +
                           ": expected a file path (str, bytes or "
                           "os.PathLike), got " +
                           py::str(py::type::of(value).attr("__name__")).cast<std::string>());
  // As open() takes it: os.fsencode gives the bytes of the name (a str with surrogate escapes,
  // as os.listdir gives a name that is not UTF-8, included). A NUL inside is refused where the
  // file is opened (checkNoNul).
  return py::module_::import("os").attr("fsencode")(value).cast<std::string>();
}

Mesh toMesh(const py::handle& V, const py::handle& E) {
  const Eigen::MatrixXd P = toPositions(V, "V");
  const Eigen::MatrixXi T = toElements(E, static_cast<int>(P.rows()));
  const std::string source = "arrays";
  if (T.cols() == 4) {
    TetMesh tet;
    for (Eigen::Index i = 0; i < P.rows(); ++i) tet.points.push_back(P.row(i).transpose());
    for (Eigen::Index k = 0; k < T.rows(); ++k)
      tet.tets.push_back({T(k, 0), T(k, 1), T(k, 2), T(k, 3)});
    Mesh mesh(std::move(tet));
    validateMesh(mesh, source);
    return mesh;
  }
  std::vector<Eigen::Vector3d> points(static_cast<std::size_t>(P.rows()));
  for (Eigen::Index i = 0; i < P.rows(); ++i)
    points[static_cast<std::size_t>(i)] = Eigen::Vector3d(P(i, 0), P(i, 1), P(i, 2));
  std::vector<std::array<int, 3>> triangles(static_cast<std::size_t>(T.rows()));
  for (Eigen::Index k = 0; k < T.rows(); ++k)
    triangles[static_cast<std::size_t>(k)] = {T(k, 0), T(k, 1), T(k, 2)};
  std::ptrdiff_t refused = -1;
  auto tri = buildTriangleMesh(points, triangles, refused);
  if (!tri) {  // the first face that does not fit, with its reason
    const auto& t = triangles[static_cast<std::size_t>(refused)];
    const bool repeats = t[0] == t[1] || t[1] == t[2] || t[0] == t[2];
    throw InvalidMesh(
        source + ": face " + std::to_string(refused) + " (0-based) " +
        (repeats ? "repeats a vertex" : "makes the mesh non-manifold or flips its orientation"));
  }
  Mesh mesh(std::move(tri));
  validateMesh(mesh, source);
  return mesh;
}

namespace {

bool isSequence(const py::handle& obj) {
  return py::isinstance<py::list>(obj) || py::isinstance<py::tuple>(obj);
}

std::vector<double> perHandle(const py::handle& obj, const char* what, std::size_t count,
                              double fallback) {
  if (obj.is_none()) return std::vector<double>(count, fallback);
  const Eigen::VectorXd v = toVector(obj, what, static_cast<Eigen::Index>(count));
  return std::vector<double>(v.data(), v.data() + v.size());
}

}  // namespace

HandleSet toHandles(const Mesh& mesh, const py::handle& handles, const py::handle& targets,
                    const py::handle& ranges, const py::handle& magnitudes) {
  const int n = mesh.numVertices();
  if (!isSequence(handles))
    throw InvalidParameter("handles: expected a list of vertex-id arrays, one per handle");
  const py::sequence list = py::reinterpret_borrow<py::sequence>(handles);
  if (list.size() == 0)
    throw InvalidParameter("handles: the list is empty (give at least one vertex-id array)");
  for (const py::handle item : list)
    if (PyIndex_Check(item.ptr()) && !py::isinstance<py::array>(item))
      throw InvalidParameter(
          "handles: expected a list of vertex-id arrays, one per handle, got a list of numbers "
          "(for one handle write [ids])");
  const Eigen::MatrixXd rest = mesh.positions();
  // Targets of 2 coordinates are a planar mesh's (its z stays); a 3D mesh needs 3.
  const bool planar = mesh.kind() == MeshKind::Planar;
  HandleSet set;
  std::size_t total = 0;
  for (std::size_t j = 0; j < list.size(); ++j) {
    Handle h;
    h.name = std::to_string(j);
    const std::string what = "handles[" + std::to_string(j) + "]";
    h.vertices = toIds(list[j], what.c_str(), n);
    h.targets.resize(static_cast<Eigen::Index>(h.vertices.size()), 3);
    for (std::size_t i = 0; i < h.vertices.size(); ++i)
      h.targets.row(static_cast<Eigen::Index>(i)) = rest.row(h.vertices[i]);
    total += h.vertices.size();
    set.handles.push_back(std::move(h));
  }
  const auto ranges_ = perHandle(ranges, "ranges", set.handles.size(), 1.0);
  const auto magnitudes_ = perHandle(magnitudes, "magnitudes", set.handles.size(), 1.0);
  for (std::size_t j = 0; j < set.handles.size(); ++j) {
    set.handles[j].range = ranges_[j];
    set.handles[j].magnitude = magnitudes_[j];
  }
  if (targets.is_none()) return set;

  // Per handle (a list of 2-D arrays, one per handle) or stacked handle by handle.
  const auto fill = [&](Handle& h, const Eigen::MatrixXd& t, Eigen::Index row) {
    for (Eigen::Index i = 0; i < h.targets.rows(); ++i) {
      h.targets(i, 0) = t(row + i, 0);
      h.targets(i, 1) = t(row + i, 1);
      if (t.cols() == 3) h.targets(i, 2) = t(row + i, 2);  // (k, 2): planar, z stays
    }
  };
  bool perHandleTargets = false;
  if (isSequence(targets)) {
    const py::sequence t = py::reinterpret_borrow<py::sequence>(targets);
    if (t.size() > 0) {
      const py::array first = py::array::ensure(t[0]);
      perHandleTargets = first && first.ndim() == 2;
      if (perHandleTargets && t.size() != set.handles.size())
        throw InvalidParameter("targets: " + std::to_string(t.size()) + " arrays for " +
                               std::to_string(set.handles.size()) +
                               " handles (one (k_j, 3) array per handle, or one stacked array)");
    }
  }
  if (perHandleTargets) {
    const py::sequence t = py::reinterpret_borrow<py::sequence>(targets);
    for (std::size_t j = 0; j < set.handles.size(); ++j) {
      Handle& h = set.handles[j];
      const std::string what = "targets[" + std::to_string(j) + "]";
      const py::array a = asArray(t[j], what, false);
      const Eigen::Index cols = planar && a.ndim() == 2 && a.shape(1) == 2 ? 2 : 3;
      fill(h, toMatrix(a, what.c_str(), h.targets.rows(), cols), 0);
    }
    return set;
  }
  const py::array a = asArray(targets, "targets", false);
  const Eigen::Index cols = planar && a.ndim() == 2 && a.shape(1) == 2 ? 2 : 3;
  const Eigen::MatrixXd t = toMatrix(a, "targets", static_cast<Eigen::Index>(total), cols);
  Eigen::Index row = 0;
  for (Handle& h : set.handles) {
    fill(h, t, row);
    row += h.targets.rows();
  }
  return set;
}

void checkWeightsFor(const std::string& who, const std::string& regularization,
                     const py::handle& weights) {
  if (regularization == "nonuniform" && weights.is_none())
    throw InvalidParameter(who +
                           ": regularization nonuniform needs weights (one per vertex, "
                           "e.g. from diffuse_weights or rbf_weights)");
  if (regularization != "nonuniform" && !weights.is_none())
    throw InvalidParameter(
        who + ": weights are used by regularization='nonuniform' only (got " +
        (regularization.empty() ? std::string("the default, 'none'") : "'" + regularization + "'") +
        ")");
}

namespace {

/// numpy's bool scalar, or a 0-d array of bools.
bool isNumpyBool(const py::handle& value) {
  const py::module_ numpy = py::module_::import("numpy");
  if (py::isinstance(value, numpy.attr("bool_"))) return true;
  if (!py::isinstance<py::array>(value)) return false;
  const py::array a = py::reinterpret_borrow<py::array>(value);
  return a.ndim() == 0 && a.dtype().kind() == 'b';
}

/// Calls `convert` (PyNumber_Index or PyNumber_Float) on `value` once: the result, or null
/// when the object is no such number (a TypeError or ValueError, cleared). Any other exception
/// of the object's own (a KeyboardInterrupt in its __index__) reaches the caller as itself.
py::object numberOf(const py::handle& value, PyObject* (*convert)(PyObject*)) {
  PyObject* result = convert(value.ptr());
  if (result) return py::reinterpret_steal<py::object>(result);
  if (!PyErr_ExceptionMatches(PyExc_TypeError) && !PyErr_ExceptionMatches(PyExc_ValueError))
    throw py::error_already_set();
  PyErr_Clear();
  return py::object();
}

/// An integer's text by operator.index (ints, numpy integers and integer 0-d arrays); nothing
/// for the others: int() would truncate a float array's 0.5 to 0.
std::optional<std::string> indexText(const py::handle& value) {
  if (!PyIndex_Check(value.ptr())) return std::nullopt;
  const py::object index = numberOf(value, PyNumber_Index);
  if (!index) return std::nullopt;
  return std::string(py::str(index));
}

[[noreturn]] void wrongType(const py::handle& value, const char* what, const char* expected) {
  throw InvalidParameter(std::string(what) + ": expected " + expected + ", got " +
                         std::string(py::str(py::type::of(value).attr("__name__"))));
}

}  // namespace

double toReal(const py::handle& value, const char* what) {
  if (PyBool_Check(value.ptr()) || isNumpyBool(value) || py::isinstance<py::str>(value) ||
      py::isinstance<py::bytes>(value) ||
      (!py::hasattr(value, "__float__") && !PyIndex_Check(value.ptr())))
    wrongType(value, what, "a number");
  const py::object number = numberOf(value, PyNumber_Float);
  if (!number) wrongType(value, what, "a number");  // e.g. a 2-element array
  return number.cast<double>();
}

long long toInteger(const py::handle& value, const char* what) {
  if (PyBool_Check(value.ptr()) || isNumpyBool(value) || !PyIndex_Check(value.ptr()))
    wrongType(value, what, "an integer");
  const py::object index = numberOf(value, PyNumber_Index);  // __index__ once
  if (!index) wrongType(value, what, "an integer");
  const long long v = PyLong_AsLongLong(index.ptr());
  if (v == -1 && PyErr_Occurred()) {  // beyond 64 bits
    PyErr_Clear();
    throw InvalidParameter(std::string(what) + ": " + std::string(py::str(index)) +
                           " is out of range");
  }
  return v;
}

bool toFlag(const py::handle& value, const char* what) {
  if (!PyBool_Check(value.ptr()) && !isNumpyBool(value)) wrongType(value, what, "a bool");
  return PyObject_IsTrue(value.ptr()) == 1;
}

std::string toText(const py::handle& value, const char* what) {
  if (!py::isinstance<py::str>(value)) wrongType(value, what, "a str");
  return value.cast<std::string>();
}

std::map<std::string, std::string> toParamText(const py::dict& kwargs) {
  std::map<std::string, std::string> out;
  for (const auto& [key, value] : kwargs) {
    const std::string name = py::str(key);
    if (value.is_none()) continue;
    if (PyBool_Check(value.ptr()) || isNumpyBool(value)) {
      out[name] = PyObject_IsTrue(value.ptr()) ? "true" : "false";
    } else if (py::isinstance<py::str>(value)) {
      out[name] = value.cast<std::string>();
    } else if (const std::optional<std::string> index = indexText(value)) {
      out[name] = *index;
    } else if (PyFloat_Check(value.ptr()) || py::hasattr(value, "__float__")) {
      out[name] =
          formatNumber(py::float_(py::reinterpret_borrow<py::object>(value)).cast<double>());
    } else {
      throw InvalidParameter("parameter '" + name +
                             "': expected a number, a bool or a string, got " +
                             std::string(py::str(py::type::of(value).attr("__name__"))));
    }
  }
  return out;
}

py::array fromMatrix(Eigen::MatrixXd m) {
  auto* heap = new Eigen::MatrixXd(std::move(m));
  py::capsule owner(heap, [](void* p) { delete static_cast<Eigen::MatrixXd*>(p); });
  const auto rows = static_cast<py::ssize_t>(heap->rows()),
             cols = static_cast<py::ssize_t>(heap->cols());
  return py::array_t<double>(
      {rows, cols},
      {static_cast<py::ssize_t>(sizeof(double)), static_cast<py::ssize_t>(sizeof(double)) * rows},
      heap->data(), owner);
}

py::array fromMatrix(Eigen::MatrixXi m) {
  py::array_t<long long> out(
      {static_cast<py::ssize_t>(m.rows()), static_cast<py::ssize_t>(m.cols())});
  auto w = out.mutable_unchecked<2>();
  for (Eigen::Index i = 0; i < m.rows(); ++i)
    for (Eigen::Index j = 0; j < m.cols(); ++j) w(i, j) = m(i, j);
  return out;
}

py::array fromVector(Eigen::VectorXd v) {
  auto* heap = new Eigen::VectorXd(std::move(v));
  py::capsule owner(heap, [](void* p) { delete static_cast<Eigen::VectorXd*>(p); });
  return py::array_t<double>({static_cast<py::ssize_t>(heap->size())}, heap->data(), owner);
}

py::object fromJson(const nlohmann::json& j) {
  switch (j.type()) {
    case nlohmann::json::value_t::null:
      return py::none();
    case nlohmann::json::value_t::boolean:
      return py::bool_(j.get<bool>());
    case nlohmann::json::value_t::number_integer:
      return py::int_(j.get<long long>());
    case nlohmann::json::value_t::number_unsigned:
      return py::int_(j.get<unsigned long long>());
    case nlohmann::json::value_t::number_float:
      return py::float_(j.get<double>());
    case nlohmann::json::value_t::string:
      return py::str(j.get<std::string>());
    case nlohmann::json::value_t::array: {
      py::list list;
      for (const auto& item : j) list.append(fromJson(item));
      return std::move(list);
    }
    case nlohmann::json::value_t::object: {
      py::dict dict;
      for (const auto& [key, value] : j.items()) dict[py::str(key)] = fromJson(value);
      return std::move(dict);
    }
    default:
      return py::none();
  }
}

py::dict fromStats(const SolverStats& s) {
  py::dict d;
  d["symbolic"] = s.symbolic;
  d["numeric"] = s.numeric;
  d["solves"] = s.solves;
  d["symbolic_seconds"] = s.symbolicSeconds;
  d["numeric_seconds"] = s.numericSeconds;
  d["solve_seconds"] = s.solveSeconds;
  return d;
}

namespace {

bool skipped(const std::string& name, const std::vector<std::string>& skip) {
  for (const auto& s : skip)
    if (s == name) return true;
  return false;
}

std::string pythonDefault(const ParamSpec& spec) {
  switch (spec.type) {
    case ParamType::Bool:
      return spec.defaultValue == "true" ? "True" : "False";
    case ParamType::Float:
    case ParamType::Int:
      return spec.defaultValue;
    default:
      return "'" + spec.defaultValue + "'";
  }
}

}  // namespace

std::string paramSignature(const std::string& filter, const std::vector<std::string>& skip) {
  std::string out;
  for (const ParamSpec& spec : Registry::builtin().get(filter).params())
    if (!skipped(spec.name, skip)) out += ", " + spec.name + "=" + pythonDefault(spec);
  return out;
}

std::string paramDoc(const std::string& filter, const std::vector<std::string>& skip) {
  std::ostringstream out;
  out << "Keyword parameters, from the table of the filter '" << filter
      << "' (as `diffreg filters` lists them):\n";
  for (const ParamSpec& spec : Registry::builtin().get(filter).params()) {
    if (skipped(spec.name, skip)) continue;
    out << "    " << spec.name << " : " << toString(spec.type);
    if (!spec.choices.empty()) {
      out << " {";
      for (std::size_t i = 0; i < spec.choices.size(); ++i)
        out << (i ? ", " : "") << spec.choices[i];
      out << "}";
    } else if (hasRange(spec)) {
      out << " in " << rangeText(spec);
    }
    out << ", default " << pythonDefault(spec) << "\n        " << spec.help << "\n";
  }
  return out.str();
}

namespace {
PyObject* g_warning = nullptr;  // diffreg.DiffregWarning, alive as long as the module
}  // namespace

void registerWarnings(py::module_& m) {
  g_warning = PyErr_NewExceptionWithDoc(
      "diffreg.DiffregWarning",
      "A warning of the diffreg library (a file read with repairs, an unconverged run, ...).",
      PyExc_UserWarning, nullptr);
  if (!g_warning) throw py::error_already_set();
  m.add_object("DiffregWarning", py::handle(g_warning));
}

namespace {

// Issues `messages`; with `raising` (an error already on its way) one made an error is dropped.
void issueWarnings(const std::vector<std::string>& messages, bool raising) {
  for (const std::string& message : messages) {
    // As on a terminal: one line, valid UTF-8 (a file name may hold any bytes).
    if (PyErr_WarnEx(g_warning ? g_warning : PyExc_UserWarning, terminalLine(message).c_str(), 1) ==
        0)
      continue;
    if (raising) {
      PyErr_Clear();
      continue;
    }
    throw py::error_already_set();
  }
}

}  // namespace

void PyWarnings::issue() { issueWarnings(collector.take(), false); }

PyWarnings::~PyWarnings() noexcept(false) {
  issueWarnings(collector.take(), std::uncaught_exceptions() > 0);
}

void registerExceptions() {
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const IoError& e) {
      PyErr_SetString(PyExc_OSError, terminalLine(e.what()).c_str());
    } catch (const InvalidParameter& e) {
      PyErr_SetString(PyExc_ValueError, terminalLine(e.what()).c_str());
    } catch (const InvalidMesh& e) {
      PyErr_SetString(PyExc_ValueError, terminalLine(e.what()).c_str());
    } catch (const SingularSystem& e) {
      PyErr_SetString(PyExc_ValueError, terminalLine(e.what()).c_str());
    } catch (const MissingProperty& e) {
      PyErr_SetString(PyExc_ValueError, terminalLine(e.what()).c_str());
    } catch (const Error& e) {
      PyErr_SetString(PyExc_RuntimeError, terminalLine(e.what()).c_str());
    }
  });
}

}  // namespace diffreg::python
