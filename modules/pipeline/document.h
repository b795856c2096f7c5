// A Document is what a pipeline works on: a mesh, its handles and its rest positions.
#pragma once

#include "handles/handles.h"
#include "mesh/mesh.h"

#include <Eigen/Core>
#include <string>

namespace diffreg {

struct Document {
  Mesh mesh;
  HandleSet handles;
  Eigen::MatrixXd rest;  ///< positions when loaded, n x 3
  std::string path;      ///< where the mesh came from ("" when built in code)

  /// Reads a mesh (and optionally a handle file) and records the rest positions.
  static Document load(const std::string& meshPath, const std::string& handlesPath = "");
};

}  // namespace diffreg
