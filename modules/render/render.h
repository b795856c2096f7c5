// A small software renderer for figures: planar meshes top-down, surfaces and the boundary of
// tet meshes in an orthographic 3D view, coloured by a scalar property with a colour bar,
// optional wireframe and marked handle vertices. Z-buffered, supersampled, no GPU needed.
#pragma once

#include <diffreg/mesh/boundary.h>  // tetBoundary: what a tet mesh is drawn by
#include <diffreg/mesh/mesh.h>
#include <diffreg/render/image.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace diffreg {

enum class Colormap {
  Viridis,   ///< perceptually uniform, dark purple (low) to yellow (high); for weights
  Coolwarm,  ///< diverging, blue (low) through light grey to red (high)
  Turbo      ///< rainbow, blue (low) to dark red (high), Turbo minus its darkest tenth; for
             ///< distortion as in the paper
};

/// Colour of s in [0, 1] (clamped; NaN gives the low end) under `map`.
Rgb colormap(Colormap map, double s);
/// "viridis", "coolwarm", "turbo". \throw InvalidParameter for any other name (listing these).
Colormap colormapFromString(const std::string& name);
const char* toString(Colormap map);

enum class ViewMode {
  Auto,  ///< Top for planar meshes, Orbit otherwise
  Top,   ///< orthographic view of the xy plane from +z (x right, y up), no shading
  Orbit  ///< orthographic 3D view from the yaw/pitch direction, Lambert shading
};

enum class ScalarSite {
  Auto,    ///< a vertex property of that name if present, else an element property
  Vertex,  ///< interpolated across elements
  Element  ///< one flat colour per face / tet
};

struct RenderOptions {
  int width = 800;  ///< image size in pixels, title and colour bar included
  int height = 600;
  int supersample = 2;  ///< mesh drawn at this factor and box-filtered down (1..4)

  ViewMode view = ViewMode::Auto;
  double yaw = 30.0;     ///< Orbit: degrees turned about the up axis
  double pitch = -20.0;  ///< Orbit: degrees of elevation; negative looks down on the mesh
  int upAxis = 1;        ///< Orbit: world axis shown vertical (0 = x, 1 = y, 2 = z)
  /// World-space box fitted into the viewport instead of the mesh's own bounds, so that
  /// several panels (rest and deformed shapes) share one scale and position.
  std::optional<Eigen::AlignedBox3d> frame;
  double margin = 0.05;  ///< fraction of the viewport left free on each side

  /// Scalar to colour by: a mesh property name, or explicit `values` (size n vertices or
  /// m elements, see `site`), which take precedence. Neither: a uniform light grey.
  std::string property;
  Eigen::VectorXd values;
  ScalarSite site = ScalarSite::Auto;
  /// Colour range; unset ends come from the finite values' min / max (a vertex property's at
  /// the referenced vertices only). Values outside are clamped; a degenerate range is widened
  /// about its value, or upwards from rangeMin when that is given.
  std::optional<double> rangeMin, rangeMax;
  Colormap colormap = Colormap::Viridis;
  Rgb noDataColor{200, 200, 205};  ///< no scalar, or a NaN value

  bool wireframe = false;  ///< thin dark edges (faded out where edges are only a few pixels)
  Rgb wireColor{25, 25, 25};

  std::vector<int> handles;  ///< vertex ids marked with dots (hidden ones in Orbit views skipped)
  Rgb handleColor = colors::red;
  double handleRadius = 0.0;  ///< pixels; 0 = automatic from the image size

  std::string title;     ///< drawn centred above the mesh
  bool colorBar = true;  ///< when a scalar is shown
  /// Keep the colour bar's space (blank) even without a scalar, so that the panels of one
  /// figure share a layout; its width follows the colour range's tick labels.
  bool reserveColorBar = false;
  std::string colorBarLabel;  ///< default: the property name without its "diffreg:" prefix
  int textScale = 0;          ///< font pixel size; 0 = automatic from the image size
  Rgb background = colors::white;
};

/// Axis-aligned pixel rectangle [x, x + w) x [y, y + h).
struct PixelRect {
  int x = 0, y = 0, w = 0, h = 0;
  bool contains(int px, int py) const { return px >= x && py >= y && px < x + w && py < y + h; }
};

/// Where renderMesh puts things: the viewport the mesh is fitted into, the colour bar's
/// gradient (top = high end), and the title band (empty rectangles when absent); and the
/// values at the colour map's two ends (0 and 0 without a scalar field).
struct RenderLayout {
  PixelRect viewport, colorBar, title;
  int textScale = 1;
  double colorMin = 0.0, colorMax = 0.0;
};

/// The layout renderMesh uses for `mesh` and `options` (the colour bar's width depends on
/// its tick labels). \throw as renderMesh.
RenderLayout renderLayout(const Mesh& mesh, const RenderOptions& options);

/// Maps world positions to image pixels (x right, y down) and view depth (larger = nearer).
class Projection {
 public:
  /// The projection renderMesh uses: view rotation from `options`, fitted so that the mesh's
  /// referenced vertices (or options.frame) fill `viewport` up to the margin.
  Projection(const Mesh& mesh, const RenderOptions& options, const PixelRect& viewport);
  /// Pixel coordinates (continuous; pixel (i, j) covers [i, i+1) x [j, j+1)) and depth.
  Eigen::Vector3d project(const Eigen::Vector3d& world) const;
  /// World direction rotated into view space (x right, y up, z towards the viewer).
  Eigen::Vector3d rotate(const Eigen::Vector3d& world) const;
  bool shaded() const { return shaded_; }

 private:
  Eigen::Matrix3d rotation_;
  Eigen::Vector3d center_;  // view-space centre of the fitted box
  double scale_ = 1.0;      // pixels per world unit
  double cx_ = 0.0, cy_ = 0.0;
  bool shaded_ = false;
};

/// The world axis drawn vertically in 3D views when none is asked for (up=auto, the tool's
/// compare and resolution without --up): the longest side of `frame`, so that a standing
/// figure stands and a long part fills a portrait panel (y for an empty frame or a tie).
int uprightAxis(const Eigen::AlignedBox3d& frame);

/// Renders `mesh` at its current positions: triangle meshes directly, tet meshes by their
/// boundary faces, coloured by the chosen scalar through options.colormap with a colour bar
/// labelled at the low end, the middle and the high end.
/// \throw MissingProperty when options.property names no vertex or element property.
/// \throw InvalidParameter for bad sizes, a `values` vector whose size matches neither vertex
///        nor element count (or the chosen site), handle ids out of range, or a colour range
///        with min > max or non-finite ends.
/// When `layout` is given it receives the layout drawn (renderLayout's, without resolving the
/// field a second time).
Image renderMesh(const Mesh& mesh, const RenderOptions& options = {},
                 RenderLayout* layout = nullptr);

}  // namespace diffreg
