#include "pipeline/document.h"

#include "mesh/io.h"

namespace diffreg {

Document Document::load(const std::string& meshPath, const std::string& handlesPath) {
  Document doc;
  doc.mesh = readMesh(meshPath);
  if (!handlesPath.empty()) doc.handles = readHandles(handlesPath, doc.mesh);
  doc.rest = doc.mesh.positions();
  doc.path = meshPath;
  return doc;
}

}  // namespace diffreg
