#include "deform/measure.h"

#include <diffreg/core/error.h>
#include <diffreg/core/log.h>
#include <diffreg/deformation/deformer.h>
#include <diffreg/deformation/metrics.h>
#include <diffreg/engine/edit_engine.h>
#include <diffreg/mesh/io.h>
#include "deform/element_maps.h"

#include <optional>

namespace diffreg {

namespace {

/// A mesh file that must describe the same vertices as the document (and, for a rest mesh,
/// the same elements).
Mesh readMatching(const Document& doc, const std::string& path, const std::string& param,
                  bool sameElements) {
  const std::string where = "filter measure: parameter '" + param + "': ";
  Mesh other = [&] {
    try {
      return readMesh(path);
    } catch (const IoError& e) {
      throw IoError(where + e.what());
    } catch (const InvalidMesh& e) {
      throw InvalidMesh(where + e.what());
    }
  }();
  if (other.numVertices() != doc.mesh.numVertices())
    throw InvalidParameter("filter measure: parameter '" + param + "': '" + path + "' has " +
                           std::to_string(other.numVertices()) + " vertices, the mesh has " +
                           std::to_string(doc.mesh.numVertices()));
  if (sameElements && other.elements() != doc.mesh.elements())
    throw InvalidParameter("filter measure: parameter '" + param + "': '" + path +
                           "' does not have the mesh's elements");
  return other;
}

// A planar rest shape measures x and y only: `positions` (n x 3) that leave a plane z = const
// would be measured flattened, as if their z did not exist.
void checkInPlane(const Discretization& disc, const Eigen::MatrixXd& positions,
                  const std::string& what) {
  if (disc.dim() != 2 || positions.cols() < 3 || positions.rows() == 0) return;
  // The vertices the elements use, as the mesh's kind is decided.
  const Eigen::AlignedBox3d box = meshBounds(positions, disc.active());
  if (planarBox(box)) return;
  throw InvalidParameter("filter measure: the rest shape is planar, but " + what +
                         " leaves its plane (z spans " + formatNumber(box.sizes().z()) +
                         "): a planar measure would drop that z; give a rest and a deformed "
                         "mesh of one kind");
}

}  // namespace

std::string MeasureFilter::description() const {
  return "Deformation quality, as in Table 1 of the paper: per-element distortion D_k (the "
         "energy density ||e_k||^2), its maximum D_max, area-weighted mean D_ave and deviation "
         "D_dev, Dist (root mean square vertex distance to the same edit without "
         "regularization, or to a reference mesh), the number of inverted elements and the "
         "total energy. Writes diffreg:distortion and diffreg:smoothness per element. Zhu, "
         "Li, Zhang, Song: Diffusion-based non-uniform regularization for variational shape "
         "deformation, Computer-Aided Design (2016), Sec. 4.";
}

std::vector<ParamSpec> MeasureFilter::params() const {
  std::vector<std::string> energies = enumNames<Energy>();
  energies.insert(energies.begin(), "auto");
  return {
      enumParam("energy", "auto", energies,
                "Energy whose residuals define D_k; auto: the deform filter's (else arap)."),
      stringParam("reference", "",
                  "Mesh file to measure Dist against; empty: the same edit solved without "
                  "regularization (after a deform filter in the same pipeline; without one, "
                  "Dist is null)."),
      stringParam("rest", "",
                  "Undeformed mesh file, when the input is already deformed; empty: the mesh as "
                  "loaded."),
  };
}

std::vector<std::string> MeasureFilter::produces(const ParamMap&) const {
  return {prop::distortion, prop::smoothness};
}

FilterResult MeasureFilter::apply(Document& doc, const ParamMap& params) const {
  const std::string restPath = params.getString("rest");
  std::optional<Discretization> restFromFile;
  if (!restPath.empty()) restFromFile.emplace(readMatching(doc, restPath, "rest", true));
  const Discretization& disc = restFromFile ? *restFromFile : doc.restDiscretization();
  // The energy and the regularization of the deformation being measured (none before any).
  const DeformationOptions deformed = doc.deformation.value_or(DeformationOptions{});
  const std::string energyName = params.getString("energy");
  const Energy energy = energyName == "auto" ? deformed.energy : parseEnum<Energy>(energyName);
  checkInPlane(disc, doc.mesh.positions(), "the mesh being measured");
  const Eigen::MatrixXd positions = currentPositions(doc, disc);

  const Regularization mode = deformed.regularization;
  const double beta = deformed.beta;
  Eigen::VectorXd vertexWeights;
  if (mode == Regularization::Nonuniform) vertexWeights = doc.mesh.vertexScalar(prop::weight);
  const RegularizationWeights weights = makeRegularizationWeights(disc, mode, beta, vertexWeights);

  FilterResult out;
  std::optional<Eigen::MatrixXd> reference;
  nlohmann::json referenceText = nullptr;
  const std::string referencePath = params.getString("reference");
  if (!referencePath.empty()) {
    const Eigen::MatrixXd given = readMatching(doc, referencePath, "reference", false).positions();
    checkInPlane(disc, given, "the reference '" + referencePath + "'");
    reference = given.leftCols(disc.dim());
    referenceText = referencePath;
  } else if (doc.deformation) {
    if (mode == Regularization::None) {
      reference = positions;  // the deformation is its own unregularized solve
    } else {
      // The engine's reference: the same edit without regularization (its weights do not
      // matter to it, so they are not given).
      EditParams edit = editParamsOf(deformed);
      edit.deform = false;
      edit.reference = true;
      EditEngine& engine = doc.engine();
      engine.setEdit(doc.handles, std::move(edit));
      out.stats = engine.updateOrThrow().reference;
      reference = engine.referencePositions();
    }
    referenceText = "unregularized solve";
  } else if (!restPath.empty()) {
    // A deformed mesh read from a file: nothing says which edit made it.
    warn(
        "measure: Dist is null: no deform filter ran before it, so there is no unregularized "
        "solve of the edit; give reference=FILE to measure Dist against a mesh");
  }

  const ElementMaps maps = elementMaps(disc, energy, positions);
  const DeformationMetrics m =
      measureDeformation(disc, energy, positions, weights, reference ? &*reference : nullptr,
                         nullptr, nullptr, &maps.distortion);
  writeElementMaps(doc, maps);  // after the metrics: a failure leaves the mesh as it was
  out.data = {{"energy", toString(energy)},
              {"metrics",
               {{"D_max", m.dMax},
                {"D_ave", m.dAve},
                {"D_dev", m.dDev},
                {"dist", m.dist ? nlohmann::json(*m.dist) : nlohmann::json(nullptr)},
                {"inverted", m.inverted},
                {"energy", m.energy}}},
              {"dist_reference", referenceText}};
  return out;
}

}  // namespace diffreg
