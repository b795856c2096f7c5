// Conversions between Python/numpy values and diffreg's C++ types, shared by the functions
// (module.cpp) and the session classes (sessions.cpp) of the Python module.
//
// Arrays in: positions are any real numeric array of shape (n, 3) (or (n, 2) for planar
// meshes), converted to float64; elements any integer array of shape (m, 3) or (m, 4). The
// library works on column-major Eigen matrices, so inputs are copied once into them (numpy's
// default is row-major). Arrays out are numpy arrays that take over the result's memory
// without a copy (column-major, i.e. Fortran-ordered, for matrices).
#pragma once

#include <diffreg/core/log.h>
#include <diffreg/handles/handles.h>
#include <diffreg/mesh/mesh.h>
#include <diffreg/pipeline/filter.h>
#include <diffreg/pipeline/params.h>
#include <diffreg/solver/solver.h>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include <map>
#include <string>
#include <vector>

namespace diffreg::python {

namespace py = pybind11;

/// Positions as an n x 3 double matrix (an (n, 2) array gets z = 0).
/// \throw InvalidParameter (ValueError) naming `what` for a wrong shape, dtype or a non-finite
///        value.
Eigen::MatrixXd toPositions(const py::handle& array, const char* what);
/// A general real matrix (rows x cols; -1 = any), e.g. targets or reference positions.
Eigen::MatrixXd toMatrix(const py::handle& array, const char* what, Eigen::Index rows,
                         Eigen::Index cols);
/// A real vector of `size` entries (-1 = any).
Eigen::VectorXd toVector(const py::handle& array, const char* what, Eigen::Index size);
/// Element indices (m x 3 triangles or m x 4 tets), each in [0, numVertices).
Eigen::MatrixXi toElements(const py::handle& array, int numVertices);
/// One 1-D array (or sequence) of vertex ids in [0, numVertices).
std::vector<int> toIds(const py::handle& array, const char* what, int numVertices);

/// Scalars of the methods' own arguments, converted here so that a wrong type is a ValueError
/// naming `what`, not pybind11's TypeError that prints every argument (whole arrays).
/// A real number: a Python or numpy number or a 0-d array (not a bool, nor a str).
double toReal(const py::handle& value, const char* what);
/// An integer by operator.index (a Python or numpy integer, not a bool).
long long toInteger(const py::handle& value, const char* what);
/// A bool (Python's or numpy's).
bool toFlag(const py::handle& value, const char* what);
/// A str.
std::string toText(const py::handle& value, const char* what);

/// Whether `value` names a file as Python's open() takes one: a str, bytes or os.PathLike
/// (e.g. pathlib.Path).
bool isPath(const py::handle& value);
/// That file name as the bytes the system takes (os.fsencode, as open() does).
/// \throw InvalidParameter (ValueError) naming `what` when `value` is not a path.
std::string toPath(const py::handle& value, const char* what);

/// A validated diffreg Mesh from arrays (the same checks as reading a file: degenerate or
/// inverted elements, non-manifold triangles), named "arrays" in messages.
Mesh toMesh(const py::handle& V, const py::handle& E);

/// Handles from Python: a list of vertex-id arrays, one per handle; `targets` either a list of
/// (k_j, 3) arrays (one per handle), one (sum k_j, 3) array stacked handle by handle, or None
/// (the rest positions); ranges and magnitudes None or one value per handle.
HandleSet toHandles(const Mesh& mesh, const py::handle& handles, const py::handle& targets,
                    const py::handle& ranges, const py::handle& magnitudes);

/// Python keyword arguments as the raw text values of a filter's parameter table (None = the
/// default; bools as true/false, numbers in the shortest exact form). Names are checked by
/// ParamMap, so unknown ones give the CLI's message listing the valid ones.
std::map<std::string, std::string> toParamText(const py::dict& kwargs);

/// Weights go with regularization 'nonuniform' and nothing else: `who` (e.g. "deform") gets
/// them exactly when `regularization` ("" for the default, none) asks for them.
/// \throw InvalidParameter otherwise.
void checkWeightsFor(const std::string& who, const std::string& regularization,
                     const py::handle& weights);

/// The numpy array owning `m` (no copy) and the vector likewise.
py::array fromMatrix(Eigen::MatrixXd m);
py::array fromMatrix(Eigen::MatrixXi m);
py::array fromVector(Eigen::VectorXd v);

py::object fromJson(const nlohmann::json& j);
py::dict fromStats(const SolverStats& stats);

/// "(V, E, handles, ...)" docstring section listing a filter's parameters from its table:
/// name, choices or range, default, help.
std::string paramDoc(const std::string& filter, const std::vector<std::string>& skip = {});
/// ", name=default, ..." of the filter's parameters, for a signature line.
std::string paramSignature(const std::string& filter, const std::vector<std::string>& skip = {});

/// Registers the translation of diffreg's exceptions: InvalidParameter, InvalidMesh,
/// SingularSystem and MissingProperty become ValueError, IoError OSError, with the message the
/// CLI prints after "diffreg: error: " (terminalLine: one line, control bytes written out).
void registerExceptions();

/// The call guard of every function and method of the module: the library's warnings during
/// the call (WarningCollector) are issued after it through Python's `warnings` module, as
/// diffreg.DiffregWarning (a UserWarning), so that Python code can filter, record or raise
/// them. One that the filters make an error is raised, unless the call already raises.
/// Constructors issue them themselves (issue()) while they still own the new object: raised
/// from the guard, pybind11 would drop the object without destroying it.
struct PyWarnings {
  WarningCollector collector;
  PyWarnings() = default;
  PyWarnings(const PyWarnings&) = delete;
  PyWarnings& operator=(const PyWarnings&) = delete;
  /// Issues the warnings collected so far; raises one the filters make an error.
  void issue();
  ~PyWarnings() noexcept(false);
};
/// Adds DiffregWarning to the module (before any call issues one).
void registerWarnings(py::module_& m);

}  // namespace diffreg::python
