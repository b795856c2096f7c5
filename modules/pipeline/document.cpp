#include <diffreg/pipeline/document.h>

#include <diffreg/mesh/io.h>

namespace diffreg {

Document Document::load(const std::string& meshPath, const std::string& handlesPath) {
  Document doc;
  doc.mesh = readMesh(meshPath);
  if (!handlesPath.empty()) doc.handles = readHandles(handlesPath, doc.mesh);
  doc.handlesPath = handlesPath;
  doc.rest = doc.mesh.positions();
  doc.path = meshPath;
  return doc;
}

std::string Document::missingHandles(const std::string& filter) const {
  return "filter " + filter + " needs handles: " +
         (handlesPath.empty() ? std::string("give --handles")
                              : "the handle file '" + handlesPath + "' holds none");
}

const Discretization& Document::restDiscretization() const {
  if (rest.rows() != mesh.numVertices())
    throw InvalidParameter("document: 'rest' holds " + std::to_string(rest.rows()) +
                           " positions for the mesh's " + std::to_string(mesh.numVertices()) +
                           " vertices (Document::load sets it; a Document built in code needs "
                           "rest = the mesh's rest positions, e.g. mesh.positions())");
  const RestCache* c = restCache_.get();
  const bool valid = c && c->kind == mesh.kind() && c->rest.rows() == rest.rows() &&
                     c->rest.cols() == rest.cols() && c->rest == rest &&
                     c->elements.rows() == mesh.numElements() && c->elements == mesh.elements();
  if (!valid) {
    auto disc = std::make_shared<const Discretization>(mesh, rest);
    const Eigen::MatrixXi& elements = disc->elements();  // the mesh's, read once
    restCache_ = std::make_shared<const RestCache>(RestCache{mesh.kind(), rest, elements, disc});
  }
  return *restCache_->disc;
}

EditEngine& Document::engine() {
  restDiscretization();  // brings the cache in line with the rest shape
  if (!engine_.engine || engine_.engine->sharedDiscretization() != restCache_->disc) {
    Mesh restMesh = mesh;
    restMesh.setPositions(rest);
    EngineSettings settings;
    settings.interactive = false;
    engine_.engine = std::make_unique<EditEngine>(std::move(restMesh), restCache_->disc, settings);
  }
  return *engine_.engine;
}

}  // namespace diffreg
