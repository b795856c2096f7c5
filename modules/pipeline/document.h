// A Document is what a pipeline works on: a mesh, its handles and its rest positions.
#pragma once

#include "handles/handles.h"
#include "mesh/mesh.h"

#include <Eigen/Core>
#include <map>
#include <string>

namespace diffreg {

struct Document {
  Mesh mesh;
  HandleSet handles;
  Eigen::MatrixXd rest;  ///< positions when loaded, n x 3
  std::string path;      ///< where the mesh came from ("" when built in code)
  /// What earlier filters of a pipeline leave for later ones, as "filter.key" -> text (e.g. the
  /// deform filter's energy, read by measure).
  std::map<std::string, std::string> state;

  /// Reads a mesh (and optionally a handle file) and records the rest positions.
  static Document load(const std::string& meshPath, const std::string& handlesPath = "");
};

}  // namespace diffreg
