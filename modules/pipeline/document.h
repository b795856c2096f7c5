// A Document is what a pipeline works on: a mesh, its handles and its rest positions.
#pragma once

#include <diffreg/deformation/deformer.h>
#include <diffreg/discretization/discretization.h>
#include <diffreg/engine/edit_engine.h>
#include <diffreg/handles/handles.h>
#include <diffreg/mesh/mesh.h>

#include <Eigen/Core>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>

namespace diffreg {

struct Document {
  Mesh mesh;
  HandleSet handles;
  Eigen::MatrixXd rest;  ///< positions when loaded, n x 3
  std::string path;      ///< where the mesh came from ("" when built in code)
  std::string handlesPath;  ///< the handle file read into `handles` ("" for none)
  /// The options of the last deform filter run on this document (without its weights and
  /// progress callback): measure takes the energy and regularization from them and solves the
  /// same edit without regularization for Dist. Empty until a deform filter has run.
  std::optional<DeformationOptions> deformation;

  /// Where a filter writes a file it is asked to write (e.g. render's PNG): maps the requested
  /// path to the one to write now. Unset: the path itself. The diffreg tool stages such files
  /// beside their targets, so that a pipeline that fails later leaves none of them behind.
  std::function<std::string(const std::string& path)> outputFile;
  /// Progress of a long filter: its name, the iteration (1-based), the energy after it and the
  /// value of its stopping criterion (DeformationResult::criterion). Unset: no progress is
  /// reported. Exceptions thrown here end the filter.
  std::function<void(const std::string& filter, int iteration, double energy, double criterion)>
      progress;

  /// The error of `filter`, which needs handles, when there are none: that the caller give a
  /// handle file, or that the one given (handlesPath) holds none.
  std::string missingHandles(const std::string& filter) const;

  /// outputFile(path) when set, else `path`.
  std::string writePath(const std::string& path) const {
    return outputFile ? outputFile(path) : path;
  }

  /// The discretization of the rest shape (`rest`, the mesh's elements and kind): built on the
  /// first call and again only when one of those has changed since, so that the filters of a
  /// pipeline share it. \throw InvalidParameter when `rest` does not hold one row per vertex.
  const Discretization& restDiscretization() const;

  /// The edit engine of the rest shape (one-shot settings: EngineSettings::interactive off),
  /// on restDiscretization(): built on the first call and again when the rest shape changed,
  /// so that the filters of a pipeline share its factorizations (e.g. measure's unregularized
  /// reference, or a second diffuse_weights with a new t: one numeric factorization). Filters
  /// set the whole state they need before each update. A copy of a Document shares the
  /// discretization but not the engine: it builds its own when asked.
  EditEngine& engine();

  /// Reads a mesh (and optionally a handle file) and records the rest positions.
  static Document load(const std::string& meshPath, const std::string& handlesPath = "");

 private:
  struct RestCache {
    MeshKind kind;
    Eigen::MatrixXd rest;
    Eigen::MatrixXi elements;
    std::shared_ptr<const Discretization> disc;
  };
  mutable std::shared_ptr<const RestCache> restCache_;  // immutable once built: copies share it
  /// Holds the engine; copying a Document copies none.
  struct EngineSlot {
    std::unique_ptr<EditEngine> engine;
    EngineSlot() = default;
    EngineSlot(const EngineSlot&) {}
    EngineSlot& operator=(const EngineSlot&) {
      engine.reset();
      return *this;
    }
    EngineSlot(EngineSlot&&) = default;
    EngineSlot& operator=(EngineSlot&&) = default;
  };
  EngineSlot engine_;
};

}  // namespace diffreg
