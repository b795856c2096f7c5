/// \file
/// \brief One-shot diffreg operators on the caller's own OpenMesh triangle mesh.
///
/// Every function here is a template on the caller's mesh type: any
/// `OpenMesh::TriMesh_ArrayKernelT<Traits>`, or an `OpenMesh::PolyMesh_ArrayKernelT<Traits>` whose
/// faces are all triangles, with float or double points. Results are stored on that mesh as
/// named properties: the vertex property `diffreg:weight` and the face properties
/// `diffreg:distortion` and `diffreg:smoothness` (all `double`, persistent, so OpenMesh's `.om`
/// writer keeps them). The mesh's other properties, attributes and connectivity are left as
/// they are. Each call converts the mesh to diffreg's own Mesh (fromOpenMesh()) and drives the
/// same edit engine (diffreg::EditEngine) as the `diffreg` tool's filters and editor, so the
/// results are identical to theirs.
///
/// A function either completes or throws before it writes anything to the caller's mesh.
#pragma once

#include <diffreg/core/error.h>
#include <diffreg/deformation/deformer.h>
#include <diffreg/deformation/options.h>
#include <diffreg/deformation/metrics.h>
#include <diffreg/discretization/discretization.h>
#include <diffreg/engine/edit_engine.h>
#include <diffreg/handles/handles.h>
#include <diffreg/mesh/io.h>
#include <diffreg/mesh/mesh.h>
#include <diffreg/pipeline/document.h>
#include <diffreg/pipeline/pipeline.h>
#include <diffreg/weights/diffusion.h>

#include <OpenMesh/Core/Mesh/PolyConnectivity.hh>
#include <OpenMesh/Core/Utils/Property.hh>
#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include <string>
#include <type_traits>
#include <vector>

namespace diffreg {

/// True for the OpenMesh mesh types the functions of diffreg/openmesh.h accept (every type
/// derived from `OpenMesh::PolyConnectivity`, which includes all TriMesh and PolyMesh types).
template <class MeshT>
inline constexpr bool isOpenMeshMesh = std::is_base_of_v<OpenMesh::PolyConnectivity, MeshT>;

namespace detail {

template <class MeshT>
using EnableIfOpenMesh = std::enable_if_t<isOpenMeshMesh<MeshT>, int>;

inline const char* const kSource = "OpenMesh mesh";

/// Whether a property container range holds a property called `name` that is not a double.
template <class It>
bool hasNonDouble(It begin, It end, const std::string& name) {
  for (It it = begin; it != end; ++it) {
    if (*it != nullptr && (*it)->name() == name &&
        dynamic_cast<const OpenMesh::PropertyT<double>*>(*it) == nullptr)
      return true;
  }
  return false;
}

/// Throws unless each name can be written as a double vertex (face) property on `mesh`.
template <class MeshT>
void checkWritable(const MeshT& mesh, const std::vector<std::string>& vertexNames,
                   const std::vector<std::string>& faceNames) {
  for (const auto& name : vertexNames) {
    if (hasNonDouble(mesh.vprops_begin(), mesh.vprops_end(), name))
      throw InvalidParameter(std::string(kSource) + ": vertex property '" + name +
                             "' exists with a type other than double");
  }
  for (const auto& name : faceNames) {
    if (hasNonDouble(mesh.fprops_begin(), mesh.fprops_end(), name))
      throw InvalidParameter(std::string(kSource) + ": face property '" + name +
                             "' exists with a type other than double");
  }
}

/// Writes `values` into the double property `name` (added, persistent, when absent).
template <class MeshT, class PropHandle, class ElementHandle>
void writeDoubles(MeshT& mesh, const std::string& name, const Eigen::VectorXd& values) {
  PropHandle h;
  if (!mesh.get_property_handle(h, name)) {
    mesh.add_property(h, name);
    mesh.property(h).set_persistent(true);
  }
  for (Eigen::Index i = 0; i < values.size(); ++i)
    mesh.property(h, ElementHandle(static_cast<int>(i))) = values[i];
}

template <class MeshT>
void writeVertexDoubles(MeshT& mesh, const std::string& name, const Eigen::VectorXd& values) {
  writeDoubles<MeshT, OpenMesh::VPropHandleT<double>, OpenMesh::VertexHandle>(mesh, name, values);
}

template <class MeshT>
void writeFaceDoubles(MeshT& mesh, const std::string& name, const Eigen::VectorXd& values) {
  writeDoubles<MeshT, OpenMesh::FPropHandleT<double>, OpenMesh::FaceHandle>(mesh, name, values);
}

/// Copies the double properties named "diffreg:..." of one OpenMesh property range.
template <class It, class Setter>
void copyDiffregDoubles(It begin, It end, Setter set) {
  for (It it = begin; it != end; ++it) {
    const auto* p = dynamic_cast<const OpenMesh::PropertyT<double>*>(*it);
    if (p == nullptr || p->name().rfind("diffreg:", 0) != 0) continue;
    const auto& data = p->data_vector();
    set(p->name(), Eigen::Map<const Eigen::VectorXd>(data.data(), data.size()));
  }
}

/// The vertex weights for non-uniform regularization: the options' own, else the property.
inline Eigen::VectorXd regularizationWeightsOf(const DeformationOptions& options,
                                               const Mesh& mesh, const char* function) {
  if (options.regularization != Regularization::Nonuniform || options.weights.size() > 0)
    return options.weights;
  if (!mesh.hasVertexScalar(prop::weight))
    throw MissingProperty(std::string(function) +
                          ": regularization nonuniform needs DeformationOptions::weights or "
                          "the vertex property 'diffreg:weight' (computeDiffusedWeights makes it)");
  return mesh.vertexScalar(prop::weight);
}

}  // namespace detail

/// Copies a caller's OpenMesh mesh into diffreg's Mesh: the connectivity (same vertex and face
/// indices), the points as doubles and every double vertex or face property whose name starts
/// with `diffreg:`. Other properties are not copied. The result is Planar when all z
/// coordinates are equal, else Surface.
/// \pre No deleted elements (call `garbage_collection()` first) and only triangular faces.
/// \throw InvalidMesh for deleted elements, a face that is not a triangle, no faces, a
///        non-finite coordinate or a degenerate face (naming the element).
template <class MeshT, detail::EnableIfOpenMesh<MeshT> = 0>
Mesh fromOpenMesh(const MeshT& mesh) {
  const std::string source = detail::kSource;
  const int n = static_cast<int>(mesh.n_vertices()), m = static_cast<int>(mesh.n_faces());
  const bool deleted = [&] {
    if (mesh.has_vertex_status())
      for (int i = 0; i < n; ++i)
        if (mesh.status(OpenMesh::VertexHandle(i)).deleted()) return true;
    if (mesh.has_face_status())
      for (int k = 0; k < m; ++k)
        if (mesh.status(OpenMesh::FaceHandle(k)).deleted()) return true;
    if (mesh.has_edge_status())
      for (int e = 0; e < static_cast<int>(mesh.n_edges()); ++e)
        if (mesh.status(OpenMesh::EdgeHandle(e)).deleted()) return true;
    return false;
  }();
  if (deleted)
    throw InvalidMesh(source + " has deleted elements; call garbage_collection() first");
  for (int k = 0; k < m; ++k) {
    const unsigned valence = mesh.valence(OpenMesh::FaceHandle(k));
    if (valence != 3)
      throw InvalidMesh(source + ": face " + std::to_string(k) + " (0-based) has " +
                        std::to_string(valence) + " vertices; diffreg needs triangles");
  }
  TriMesh tri;
  tri.assign(mesh);  // connectivity and points (cast to double); no other properties
  Mesh out(std::move(tri));
  detail::copyDiffregDoubles(mesh.vprops_begin(), mesh.vprops_end(),
                             [&](const std::string& name, const Eigen::VectorXd& values) {
                               out.setVertexScalar(name, values);
                             });
  detail::copyDiffregDoubles(mesh.fprops_begin(), mesh.fprops_end(),
                             [&](const std::string& name, const Eigen::VectorXd& values) {
                               out.setElementScalar(name, values);
                             });
  validateMesh(out, source);
  return out;
}

/// Sets the points of a caller's mesh from `positions`: n x 3, or n x 2 (x and y only, z kept)
/// as the deformation of a planar mesh returns them. Values are cast to the mesh's scalar type.
/// \throw InvalidParameter for the wrong shape or a non-finite value (nothing is written).
template <class MeshT, detail::EnableIfOpenMesh<MeshT> = 0>
void writePositions(MeshT& mesh, const Eigen::MatrixXd& positions) {
  const auto n = static_cast<Eigen::Index>(mesh.n_vertices());
  if (positions.rows() != n || (positions.cols() != 2 && positions.cols() != 3))
    throw InvalidParameter("writePositions: expected " + std::to_string(n) +
                           " x 3 (or x 2) positions, got " + std::to_string(positions.rows()) +
                           " x " + std::to_string(positions.cols()));
  if (!positions.allFinite()) throw InvalidParameter("writePositions: non-finite position");
  using Scalar = typename MeshT::Point::value_type;
  for (Eigen::Index i = 0; i < n; ++i) {
    auto& p = mesh.point(OpenMesh::VertexHandle(static_cast<int>(i)));
    for (Eigen::Index c = 0; c < positions.cols(); ++c)
      p[static_cast<int>(c)] = static_cast<Scalar>(positions(i, c));
  }
}

/// Reads a handle file (README: "Handle files") against the current points of a caller's mesh.
/// \throw IoError unreadable file. \throw InvalidParameter malformed file or a selection that
///        does not fit the mesh (see diffreg::readHandles). \throw InvalidMesh as fromOpenMesh().
template <class MeshT, detail::EnableIfOpenMesh<MeshT> = 0>
HandleSet readHandles(const std::string& path, const MeshT& mesh) {
  return readHandles(path, fromOpenMesh(mesh));
}

/// Same as readHandles(), from JSON text; `source` names it in messages.
template <class MeshT, detail::EnableIfOpenMesh<MeshT> = 0>
HandleSet parseHandles(const std::string& jsonText, const MeshT& mesh, const std::string& source) {
  return parseHandles(jsonText, fromOpenMesh(mesh), source);
}

/// Diffused regularization weights (paper Sec. 3.2-3.3): heat flows from the handles (value
/// m_j, range r_j) over the mesh's current shape for the time of `params`.
/// \return the weights, one per vertex (m_j at handle vertices, 0 at isolated vertices, within
///         [0, max m_j] while params.clip is on); also stored as the vertex property
///         `diffreg:weight` (double) on `mesh`.
/// \throw InvalidParameter no handles, a bad handle (vertex id, r_j <= 0, m_j < 0), t <= 0, or a
///        non-double property named `diffreg:weight` on the mesh.
/// \throw InvalidMesh as fromOpenMesh(). \throw SingularSystem from the solver.
template <class MeshT, detail::EnableIfOpenMesh<MeshT> = 0>
Eigen::VectorXd computeDiffusedWeights(MeshT& mesh, const HandleSet& handles,
                                       const DiffusionParams& params = {}) {
  detail::checkWritable(mesh, {prop::weight}, {});
  if (handles.empty()) throw InvalidParameter("computeDiffusedWeights: no handles");
  EditParams edit;
  edit.scheme = WeightScheme::Diffusion;
  edit.diffusion = params;
  edit.deform = false;
  edit.reference = false;
  EngineSettings settings;
  settings.interactive = false;
  EditEngine engine(fromOpenMesh(mesh), settings);
  engine.setEdit(handles, std::move(edit));
  engine.updateOrThrow();
  detail::writeVertexDoubles(mesh, prop::weight, engine.weights());
  return engine.weights();
}

/// Deforms the mesh with the handle vertices moved to their targets (hard constraints),
/// minimizing options.energy with options.regularization. The mesh's current points are the
/// rest shape. Non-uniform regularization takes its vertex weights from options.weights or,
/// when that is empty, from the vertex property `diffreg:weight`.
/// \return the solver's result (positions, energies, iterations, convergence). The points of
///         `mesh` are set to the deformed positions, and the face properties
///         `diffreg:distortion` (D_k) and `diffreg:smoothness` (the largest ||e_k - e_l||^2 over
///         the face's edges) are stored on it (double).
/// \throw MissingProperty non-uniform regularization without weights.
/// \throw InvalidParameter no handles, a bad handle, bad options (beta or weights outside
///        [0, 1], iterations < 1), a non-double property with one of the output names.
/// \throw SingularSystem a connected part without enough handle points.
/// \throw InvalidMesh as fromOpenMesh().
template <class MeshT, detail::EnableIfOpenMesh<MeshT> = 0>
DeformationResult deform(MeshT& mesh, const HandleSet& handles,
                         const DeformationOptions& options = {}) {
  detail::checkWritable(mesh, {}, {prop::distortion, prop::smoothness});
  Mesh rest = fromOpenMesh(mesh);
  if (handles.empty()) throw InvalidParameter("deform: no handles");
  EditParams edit = editParamsOf(options);
  edit.givenWeights = detail::regularizationWeightsOf(options, rest, "deform");
  EngineSettings settings;
  settings.backend = options.backend;
  settings.interactive = false;
  EditEngine engine(std::move(rest), settings);
  engine.setEdit(handles, std::move(edit));
  engine.setProgress(options.progress);
  engine.updateOrThrow();

  DeformationResult result = engine.lastRun();
  result.positions = engine.positions().leftCols(engine.discretization().dim());
  writePositions(mesh, result.positions);
  detail::writeFaceDoubles(mesh, prop::distortion, engine.distortion());
  detail::writeFaceDoubles(mesh, prop::smoothness, engine.smoothness());
  return result;
}

/// The paper's Table 1 measures of a deformation: `deformed` against its `rest` shape (the same
/// faces), under options.energy and the regularization of `options` (used for the energy
/// value; non-uniform weights from options.weights, else `diffreg:weight` on `deformed`, else
/// on `rest`). Dist is measured against `reference` (for instance the same edit without
/// regularization) when one is given.
/// \return D_max, D_ave, D_dev, inverted elements, energy and, with a reference, Dist. The face
///         properties `diffreg:distortion` and `diffreg:smoothness` are stored on `deformed`.
/// \throw InvalidParameter `deformed` or `reference` without the faces (vertex count) of
///        `rest`, bad regularization options, a non-double property with an output name.
/// \throw MissingProperty non-uniform regularization without weights.
/// \throw InvalidMesh as fromOpenMesh().
template <class MeshT, detail::EnableIfOpenMesh<MeshT> = 0>
DeformationMetrics measure(const MeshT& rest, MeshT& deformed,
                           const DeformationOptions& options = {},
                           const MeshT* reference = nullptr) {
  detail::checkWritable(deformed, {}, {prop::distortion, prop::smoothness});
  const Mesh restMesh = fromOpenMesh(rest);
  const Mesh deformedMesh = fromOpenMesh(deformed);
  if (deformedMesh.numVertices() != restMesh.numVertices() ||
      deformedMesh.elements() != restMesh.elements())
    throw InvalidParameter("measure: the deformed mesh does not have the rest mesh's faces");
  const Discretization disc(restMesh);
  const Mesh& weightSource =
      deformedMesh.hasVertexScalar(prop::weight) ? deformedMesh : restMesh;
  const Eigen::VectorXd vertexWeights =
      detail::regularizationWeightsOf(options, weightSource, "measure");
  const RegularizationWeights weights =
      makeRegularizationWeights(disc, options.regularization, options.beta, vertexWeights);

  const Eigen::MatrixXd positions = deformedMesh.positions().leftCols(disc.dim());
  Eigen::MatrixXd referencePositions;
  if (reference != nullptr) {
    const Mesh referenceMesh = fromOpenMesh(*reference);
    if (referenceMesh.numVertices() != restMesh.numVertices())
      throw InvalidParameter("measure: the reference mesh has " +
                             std::to_string(referenceMesh.numVertices()) +
                             " vertices, the rest mesh " +
                             std::to_string(restMesh.numVertices()));
    referencePositions = referenceMesh.positions().leftCols(disc.dim());
  }
  const DeformationMetrics metrics =
      measureDeformation(disc, options.energy, positions, weights,
                         reference != nullptr ? &referencePositions : nullptr);
  const ElementMaps maps = elementMaps(disc, options.energy, positions);
  detail::writeFaceDoubles(deformed, prop::distortion, maps.distortion);
  detail::writeFaceDoubles(deformed, prop::smoothness, maps.smoothness);
  return metrics;
}

/// Runs a pipeline of registered filters (the same registry the `diffreg` tool and `.mlx`
/// scripts use) on a caller's mesh: a Document is made from the mesh (its current points are
/// the rest shape, its `diffreg:` double properties come along) and `handles`, the pipeline
/// runs, and the resulting points and the document's vertex and face scalar properties (those
/// brought along and those the filters wrote) are copied back to `mesh`.
/// \return the pipeline's report (Pipeline::run).
/// \throw Error what Pipeline::check() and the filters throw, before anything is written to
///        `mesh`.
/// \throw InvalidParameter a filter changed the vertices or faces (such pipelines run on a
///        Document, whose mesh then holds the result).
template <class MeshT, detail::EnableIfOpenMesh<MeshT> = 0>
nlohmann::json runPipeline(const Pipeline& pipeline, MeshT& mesh, const HandleSet& handles = {}) {
  Document doc;
  doc.mesh = fromOpenMesh(mesh);
  doc.handles = handles;
  doc.rest = doc.mesh.positions();
  const Eigen::MatrixXi elements = doc.mesh.elements();
  nlohmann::json report = pipeline.run(doc);
  if (doc.mesh.isTet() || doc.mesh.numVertices() != static_cast<int>(mesh.n_vertices()) ||
      doc.mesh.elements() != elements)
    throw InvalidParameter(
        "runPipeline: the pipeline changed the mesh's vertices or faces; run it on a Document");
  detail::checkWritable(mesh, doc.mesh.vertexScalarNames(), doc.mesh.elementScalarNames());
  writePositions(mesh, doc.mesh.positions());
  for (const auto& name : doc.mesh.vertexScalarNames())
    detail::writeVertexDoubles(mesh, name, doc.mesh.vertexScalar(name));
  for (const auto& name : doc.mesh.elementScalarNames())
    detail::writeFaceDoubles(mesh, name, doc.mesh.elementScalar(name));
  return report;
}

}  // namespace diffreg
