#include "render/render_filter.h"

#include <diffreg/core/error.h>
#include <diffreg/render/render.h>
#include "plugins.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>

#include <unistd.h>

namespace diffreg {
namespace {

/// The mesh property shown for the `property` parameter ("" for none).
std::string propertyName(const std::string& choice) {
  if (choice == "weight") return prop::weight;
  if (choice == "distortion") return prop::distortion;
  if (choice == "smoothness") return prop::smoothness;
  return "";
}

/// The filters that produce `choice`, for error messages.
const char* producers(const std::string& choice) {
  return choice == "weight" ? "diffuse_weights or rbf_weights" : "deform or measure";
}

/// \throw InvalidParameter for an empty or non-PNG name, IoError for a missing or unwritable
///        directory, before any rendering work.
void checkOutput(const std::string& file) {
  if (file.empty())
    throw InvalidParameter("filter render: parameter 'file' is required (the PNG to write)");
  std::string ext = std::filesystem::path(file).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".png")
    throw InvalidParameter("filter render: parameter 'file' = '" + file +
                           "' must name a .png file");
  std::filesystem::path dir = std::filesystem::path(file).parent_path();
  if (dir.empty()) dir = ".";
  std::error_code error;
  if (!std::filesystem::is_directory(dir, error))
    throw IoError("filter render: cannot write '" + file + "': directory '" + dir.string() +
                  "' does not exist");
  if (::access(dir.c_str(), W_OK) != 0)
    throw IoError("filter render: cannot write '" + file + "': directory '" + dir.string() +
                  "' is not writable");
}

/// The rest shape's bounds (the current mesh's when the document has no rest positions): the
/// up axis of up=auto, the same before and after a deformation.
Eigen::AlignedBox3d restBounds(const Document& doc) {
  if (doc.rest.rows() != doc.mesh.numVertices() || doc.rest.cols() != 3)
    return meshBounds(doc.mesh);
  return meshBounds(doc.mesh, doc.rest);
}

}  // namespace

std::string RenderFilter::description() const {
  return "Writes a PNG picture of the mesh at its current positions, coloured by a property: "
         "the regularization weights diffreg:weight (viridis), or the per-element distortion "
         "diffreg:distortion or energy smoothness diffreg:smoothness (turbo, as the paper's "
         "figures), with a colour bar from 0 to the largest value (or scale_max, to share one "
         "scale between pictures), an optional wireframe and the handle vertices marked in "
         "red. Planar meshes are drawn from above; surfaces and the boundary of tet meshes in "
         "a shaded orthographic 3D view. The mesh is not changed. The file is written under a "
         "temporary name and renamed into place. Figures as in Zhu, Li, Zhang, Song: "
         "Diffusion-based non-uniform regularization for variational shape deformation, "
         "Computer-Aided Design (2016), Fig. 6-10.";
}

std::vector<ParamSpec> RenderFilter::params() const {
  return {
      stringParam("file", "",
                  "The PNG file to write (required), relative to the working directory."),
      enumParam("property", "weight", {"weight", "distortion", "smoothness", "none"},
                "Colour by weight (vertex property diffreg:weight), distortion "
                "(diffreg:distortion), smoothness (diffreg:smoothness) or none (uniform grey)."),
      floatParam("scale_max", "0", 0.0, 1e12,
                 "Top of the colour scale (the bottom is 0); 0 = the largest value shown. Give "
                 "several pictures the same value to compare them."),
      enumParam("colormap", "auto", {"auto", "viridis", "turbo", "coolwarm"},
                "auto (viridis for weights, turbo for distortion and smoothness), viridis, turbo "
                "or coolwarm."),
      boolParam("wireframe", false, "Draw the mesh edges."),
      boolParam("handles", true, "Mark the handle vertices with red dots."),
      intParam("width", "800", 64, 8192, "Picture width in pixels."),
      intParam("height", "600", 64, 8192, "Picture height in pixels."),
      enumParam("view", "auto", {"auto", "top", "orbit"},
                "auto (top for planar meshes, orbit otherwise), top (the xy plane from +z) or "
                "orbit (shaded 3D view from yaw and pitch)."),
      floatParam("yaw", "30", -360.0, 360.0, "Orbit view: degrees turned about the up axis."),
      floatParam("pitch", "-20", -90.0, 90.0,
                 "Orbit view: degrees of elevation; negative looks down on the mesh."),
      enumParam("up", "auto", {"auto", "x", "y", "z"},
                "Orbit view: the world axis shown vertical; auto = the rest shape's longest side."),
      stringParam("title", "", "Text above the picture (none when empty)."),
  };
}

std::vector<std::string> RenderFilter::requires(const ParamMap& params) const {
  const std::string name = propertyName(params.getString("property"));
  if (name.empty()) return {};
  return {name};
}

void RenderFilter::check(const Document&, const ParamMap& params) const {
  checkOutput(params.getString("file"));
  requireTextRendering();
}

FilterResult RenderFilter::apply(Document& doc, const ParamMap& params) const {
  const std::string file = params.getString("file");
  checkOutput(file);
  const Mesh& mesh = doc.mesh;  // read only

  const std::string choice = params.getString("property");
  RenderOptions options;
  options.property = propertyName(choice);
  if (!options.property.empty()) {
    const bool perVertex = choice == "weight";
    const bool present = perVertex ? mesh.hasVertexScalar(options.property)
                                   : mesh.hasElementScalar(options.property);
    if (!present)
      throw MissingProperty("filter render: property=" + choice + " needs the " +
                            (perVertex ? "vertex" : "element") + " property '" + options.property +
                            "', which the mesh does not have (run " + producers(choice) +
                            " first)");
    options.site = perVertex ? ScalarSite::Vertex : ScalarSite::Element;
    options.rangeMin = 0.0;
    if (params.getFloat("scale_max") > 0.0) options.rangeMax = params.getFloat("scale_max");
    const std::string map = params.getString("colormap");
    options.colormap =
        map == "auto" ? (perVertex ? Colormap::Viridis : Colormap::Turbo) : colormapFromString(map);
    options.colorBarLabel = choice;
  }
  options.width = params.getInt("width");
  options.height = params.getInt("height");
  options.wireframe = params.getBool("wireframe");
  if (params.getBool("handles")) options.handles = doc.handles.allVertices();
  const std::string view = params.getString("view");
  options.view = view == "top" ? ViewMode::Top : view == "orbit" ? ViewMode::Orbit : ViewMode::Auto;
  options.yaw = params.getFloat("yaw");
  options.pitch = params.getFloat("pitch");
  const std::string up = params.getString("up");
  options.upAxis = up == "x" ? 0 : up == "y" ? 1 : up == "z" ? 2 : uprightAxis(restBounds(doc));
  options.title = params.getString("title");

  RenderLayout layout;
  const Image image = renderMesh(mesh, options, &layout);
  writePng(doc.writePath(file), image);

  FilterResult result;
  result.data = {{"file", file}, {"property", choice}};
  if (!options.property.empty()) {  // the colour bar's ends, as drawn
    result.data["scale_min"] = layout.colorMin;
    result.data["scale_max"] = layout.colorMax;
  }
  return result;
}

void registerRenderFilters(Registry& registry) { registry.add(std::make_unique<RenderFilter>()); }

}  // namespace diffreg
