#include <diffreg/render/render.h>

#include <diffreg/core/colormap.h>
#include <diffreg/core/error.h>
#include <diffreg/core/incidence.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace diffreg {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kAmbient = 0.35;
constexpr double kDiffuse = 0.65;
constexpr double kCreaseCos = 0.766;  // corners average face normals within 40 degrees
constexpr int kMaxSide = 16384;

Rgb interpolateStops(const double (*stops)[3], int count, double s) {
  if (!std::isfinite(s)) s = 0.0;
  s = std::clamp(s, 0.0, 1.0) * (count - 1);
  const int i = std::min(count - 2, static_cast<int>(s));
  const double f = s - i;
  Rgb rgb{};
  for (int c = 0; c < 3; ++c)
    rgb[c] = static_cast<std::uint8_t>(std::lround((1.0 - f) * stops[i][c] + f * stops[i + 1][c]));
  return rgb;
}

// Moreland's "cool to warm" diverging map, 9 stops.
Rgb coolwarm(double s) {
  static const double stops[9][3] = {{59, 76, 192},   {98, 130, 234},  {141, 176, 254},
                                     {184, 208, 249}, {221, 221, 221}, {245, 196, 173},
                                     {244, 154, 123}, {222, 96, 77},   {180, 4, 38}};
  return interpolateStops(stops, 9, s);
}

// Polynomial fit of Google's Turbo map (Mikhailov 2019) without its darkest tenth, so that the
// low end reads blue rather than near-black.
Rgb turbo(double s) {
  if (!std::isfinite(s)) s = 0.0;
  const double x = 0.1 + 0.9 * std::clamp(s, 0.0, 1.0);
  static const double coeff[3][6] = {
      {0.13572138, 4.61539260, -42.66032258, 132.13108234, -152.94239396, 59.28637943},
      {0.09140261, 2.19418839, 4.84296658, -14.18503333, 4.27729857, 2.82956604},
      {0.10667330, 12.64194608, -60.58204836, 110.36276771, -89.90310912, 27.34824973}};
  Rgb rgb{};
  for (int c = 0; c < 3; ++c) {
    double v = 0.0;
    for (int k = 5; k >= 0; --k) v = v * x + coeff[c][k];
    rgb[c] = static_cast<std::uint8_t>(std::lround(255.0 * std::clamp(v, 0.0, 1.0)));
  }
  return rgb;
}

Eigen::Matrix3d viewRotation(const RenderOptions& options, bool orbit) {
  if (!orbit) return Eigen::Matrix3d::Identity();
  Eigen::Matrix3d base;  // rows: world directions shown right, up and towards the viewer
  switch (options.upAxis) {
    case 0:
      base << 0, 1, 0, 1, 0, 0, 0, 0, -1;
      break;
    case 2:
      base << 1, 0, 0, 0, 0, 1, 0, -1, 0;
      break;
    default:
      base.setIdentity();
      break;
  }
  const double yaw = -options.yaw * kPi / 180.0, tilt = -options.pitch * kPi / 180.0;
  const Eigen::Matrix3d ry = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Matrix3d rx = Eigen::AngleAxisd(tilt, Eigen::Vector3d::UnitX()).toRotationMatrix();
  return rx * ry * base;
}

bool isOrbit(const Mesh& mesh, const RenderOptions& options) {
  if (options.view == ViewMode::Auto) return mesh.kind() != MeshKind::Planar;
  return options.view == ViewMode::Orbit;
}

int autoTextScale(const RenderOptions& options) {
  if (options.textScale > 0) return options.textScale;
  return std::clamp(std::min(options.width, options.height) / 300, 1, 4);
}

std::string formatTick(double v) {
  if (v == 0.0) return "0";
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.3g", v);
  return buffer;
}

// Triangles to draw and, for each, the element whose scalar colours it.
struct DrawList {
  std::vector<std::array<int, 3>> tris;
  std::vector<int> element;
};

DrawList drawList(const Mesh& mesh) {
  DrawList list;
  if (mesh.isTet()) {
    BoundaryFaces b = tetBoundary(mesh.tet());
    list.tris = std::move(b.faces);
    list.element = std::move(b.element);
    return list;
  }
  const Eigen::MatrixXi e = mesh.elements();
  for (int k = 0; k < e.rows(); ++k) {
    list.tris.push_back({e(k, 0), e(k, 1), e(k, 2)});
    list.element.push_back(k);
  }
  return list;
}

// Scalar per vertex or per element, mapped to [0, 1] (NaN kept), plus the displayed range.
struct Field {
  bool present = false;
  bool perVertex = true;
  Eigen::VectorXd s;
  double lo = 0.0, hi = 1.0;
};

Field resolveField(const Mesh& mesh, const RenderOptions& options) {
  Field field;
  const int n = mesh.numVertices(), m = mesh.numElements();
  Eigen::VectorXd values;
  if (options.values.size() > 0) {
    const int size = static_cast<int>(options.values.size());
    bool vertex =
        options.site == ScalarSite::Vertex || (options.site == ScalarSite::Auto && size == n);
    const int expected = vertex ? n : m;
    if (options.site == ScalarSite::Auto && size != n && size != m) {
      throw InvalidParameter("render: " + std::to_string(size) + " values match neither the " +
                             std::to_string(n) + " vertices nor the " + std::to_string(m) +
                             " elements");
    }
    if (size != expected) {
      throw InvalidParameter("render: expected " + std::to_string(expected) +
                             (vertex ? " vertex" : " element") + " values, got " +
                             std::to_string(size));
    }
    field.perVertex = vertex;
    values = options.values;
  } else if (!options.property.empty()) {
    const std::string& name = options.property;
    bool vertex = options.site == ScalarSite::Vertex;
    if (options.site == ScalarSite::Auto) {
      vertex = mesh.hasVertexScalar(name);
      if (!vertex && !mesh.hasElementScalar(name)) {
        throw MissingProperty("render: the mesh has no vertex or element property '" + name + "'");
      }
    }
    field.perVertex = vertex;
    values = vertex ? mesh.vertexScalar(name) : mesh.elementScalar(name);
  }
  field.present = options.values.size() > 0 || !options.property.empty();

  // The range of what is drawn: a vertex that no element uses colours nothing.
  const std::vector<bool> used = field.perVertex ? mesh.referenced() : std::vector<bool>();
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (Eigen::Index i = 0; i < values.size(); ++i) {
    const double v = values[i];
    if (std::isfinite(v) && (used.empty() || used[static_cast<size_t>(i)])) {
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  }
  if (lo > hi) {  // no (finite) data
    lo = 0.0;
    hi = field.present ? 0.0 : 1.0;
  }
  for (const auto& end : {options.rangeMin, options.rangeMax}) {
    if (end && !std::isfinite(*end)) throw InvalidParameter("render: non-finite colour range");
  }
  if (options.rangeMin) lo = *options.rangeMin;
  if (options.rangeMax) hi = *options.rangeMax;
  if (lo > hi) {
    throw InvalidParameter("render: colour range min " + formatTick(lo) + " exceeds max " +
                           formatTick(hi));
  }
  if (hi - lo <= 1e-300 + 1e-12 * std::abs(lo)) {
    // Constant: centre it on the map, or above a bottom that was asked for (a field of zeros
    // on [0, 1], not [-1, 1]).
    const double width = lo != 0.0 ? std::abs(lo) : options.rangeMin ? 1.0 : 2.0;
    if (!options.rangeMin) lo -= 0.5 * width;
    hi = lo + width;
  }
  field.lo = lo;
  field.hi = hi;
  field.s.resize(values.size());
  for (Eigen::Index i = 0; i < values.size(); ++i) {
    const double v = values[i];
    field.s[i] = std::isfinite(v) ? std::clamp((v - lo) / (hi - lo), 0.0, 1.0)
                                  : std::numeric_limits<double>::quiet_NaN();
  }
  return field;
}

// Colour bar tick values, top to bottom, and their labels.
std::array<double, 3> tickValues(const Field& field) {
  return {field.hi, 0.5 * (field.lo + field.hi), field.lo};
}

bool showsColorBar(const Field& field, const RenderOptions& options) {
  return options.colorBar && (field.present || options.reserveColorBar);
}

RenderLayout layoutFor(const RenderOptions& options, const Field& field) {
  const int w = options.width, h = options.height;
  if (w < 16 || h < 16 || w > kMaxSide || h > kMaxSide) {
    throw InvalidParameter("render: image size " + std::to_string(w) + " x " + std::to_string(h) +
                           " outside 16..16384");
  }
  if (options.supersample < 1 || options.supersample > 4) {
    throw InvalidParameter("render: supersample must be in 1..4, got " +
                           std::to_string(options.supersample));
  }
  if (!(options.margin >= 0.0 && options.margin < 0.5)) {
    throw InvalidParameter("render: margin must be in [0, 0.5)");
  }
  RenderLayout layout;
  if (field.present) {
    layout.colorMin = field.lo;
    layout.colorMax = field.hi;
  }
  const int ts = autoTextScale(options);
  layout.textScale = ts;
  const int pad = 4 * ts, lineH = textHeight(ts);
  int top = 0;
  if (!options.title.empty()) {
    layout.title = {0, pad, w, lineH};
    top = lineH + 2 * pad;
  }
  int right = w;
  if (showsColorBar(field, options)) {
    const int barW = 8 * ts + 4;
    int labelsW = 0;
    for (double v : tickValues(field)) labelsW = std::max(labelsW, textWidth(formatTick(v), ts));
    const int areaW = pad + barW + 3 * ts + 3 + labelsW + pad;
    if (areaW < w / 2) {
      right = w - areaW;
      const int barTop = top + lineH + 6 * ts;
      const int barBottom = h - lineH - pad;
      layout.colorBar = {right + pad, barTop, barW, std::max(2, barBottom - barTop)};
    }
  }
  layout.viewport = {0, top, right, h - top};
  return layout;
}

// Per-corner view-space normals: each corner averages the area-weighted normals of the
// triangles around its vertex that are within the crease angle of its own triangle.
std::vector<std::array<Eigen::Vector3d, 3>> cornerNormals(const Eigen::MatrixXd& p,
                                                          const DrawList& list,
                                                          const Eigen::Matrix3d& rotation) {
  const int t = static_cast<int>(list.tris.size());
  const int n = static_cast<int>(p.rows());
  std::vector<Eigen::Vector3d> area(t), unit(t);
  for (int k = 0; k < t; ++k) {
    const auto& f = list.tris[k];
    const Eigen::Vector3d a = p.row(f[0]), b = p.row(f[1]), c = p.row(f[2]);
    area[k] = rotation * (b - a).cross(c - a);
    const double len = area[k].norm();
    unit[k] = len > 0.0 ? Eigen::Vector3d(area[k] / len) : Eigen::Vector3d::Zero();
  }
  const Incidence around = incidenceOf(
      n, t, 3, [&list](int k, int j) { return list.tris[k][j]; }, [](int k, int) { return k; });

  std::vector<std::array<Eigen::Vector3d, 3>> normals(t);
  for (int k = 0; k < t; ++k) {
    for (int j = 0; j < 3; ++j) {
      const int v = list.tris[k][j];
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      for (int q = around.begin(v); q < around.end(v); ++q) {
        const int other = around.entries[q];
        if (unit[other].dot(unit[k]) >= kCreaseCos) sum += area[other];
      }
      const double len = sum.norm();
      normals[k][j] = len > 0.0 ? Eigen::Vector3d(sum / len) : unit[k];
    }
  }
  return normals;
}

// Anti-aliased filled disc.
void drawDisc(Image& image, double cx, double cy, double radius, const Rgb& color) {
  const int x0 = static_cast<int>(std::floor(cx - radius - 1));
  const int x1 = static_cast<int>(std::ceil(cx + radius + 1));
  const int y0 = static_cast<int>(std::floor(cy - radius - 1));
  const int y1 = static_cast<int>(std::ceil(cy + radius + 1));
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const double d = std::hypot(x + 0.5 - cx, y + 0.5 - cy);
      image.blend(x, y, color, std::clamp(radius + 0.5 - d, 0.0, 1.0));
    }
}

void drawColorBar(Image& image, const RenderLayout& layout, const Field& field,
                  const RenderOptions& options) {
  const PixelRect& bar = layout.colorBar;
  const int ts = layout.textScale;
  const Rgb ink = colors::darkGray;
  for (int row = 0; row < bar.h; ++row) {
    const double t = bar.h > 1 ? 1.0 - static_cast<double>(row) / (bar.h - 1) : 0.5;
    image.fillRect(bar.x, bar.y + row, bar.w, 1, colormap(options.colormap, t));
  }
  // Frame just outside the gradient.
  image.fillRect(bar.x - 1, bar.y - 1, bar.w + 2, 1, ink);
  image.fillRect(bar.x - 1, bar.y + bar.h, bar.w + 2, 1, ink);
  image.fillRect(bar.x - 1, bar.y - 1, 1, bar.h + 2, ink);
  image.fillRect(bar.x + bar.w, bar.y - 1, 1, bar.h + 2, ink);
  // Ticks and labels at the high end, the middle and the low end.
  const int capHeight = 7 * ts;
  const std::array<double, 3> ticks = tickValues(field);
  for (int k = 0; k < 3; ++k) {
    const int y = bar.y + static_cast<int>(std::lround(0.5 * k * (bar.h - 1)));
    const double value = ticks[k];
    image.fillRect(bar.x + bar.w, y - ts / 2, 2 * ts + 2, std::max(1, ts / 2 + 1), ink);
    drawText(image, bar.x + bar.w + 3 * ts + 3, y - capHeight / 2, formatTick(value), ink, ts);
  }
  std::string label = options.colorBarLabel;
  if (label.empty()) {
    label = options.property;
    const std::string prefix = "diffreg:";
    if (label.compare(0, prefix.size(), prefix) == 0) label = label.substr(prefix.size());
  }
  if (!label.empty()) {
    const int w = textWidth(label, ts);
    const int x = std::clamp(bar.x + bar.w / 2 - w / 2, 0, std::max(0, image.width - w - 2));
    drawText(image, x, bar.y - 4 * ts - textHeight(ts), label, ink, ts);
  }
}

// \throw InvalidParameter for a handle vertex the mesh does not have.
void checkHandleVertices(const Mesh& mesh, const RenderOptions& options) {
  const int n = mesh.numVertices();
  for (int v : options.handles) {
    if (v < 0 || v >= n) {
      throw InvalidParameter("render: handle vertex " + std::to_string(v) + " out of range 0.." +
                             std::to_string(n - 1));
    }
  }
}

// Supersampled frame and depth buffers for the viewport.
struct Raster {
  int ss = 1;  // samples per final pixel along each axis
  int width = 0, height = 0;
  Image frame;
  std::vector<float> depth;
};

// Fewer samples per pixel when the buffers would exceed 2^26 samples.
Raster makeRaster(const PixelRect& viewport, const RenderOptions& options) {
  Raster r;
  r.ss = options.supersample;
  while (r.ss > 1 && static_cast<long long>(viewport.w) * viewport.h * r.ss * r.ss > (1LL << 26))
    --r.ss;
  r.width = viewport.w * r.ss;
  r.height = viewport.h * r.ss;
  r.frame = Image(r.width, r.height, options.background);
  r.depth.assign(static_cast<std::size_t>(r.width) * r.height,
                 -std::numeric_limits<float>::infinity());
  return r;
}

// What every triangle of one picture shares: the mesh projected into the raster, the colours,
// the lighting and the wireframe.
struct Scene {
  const RenderOptions& options;
  const Field& field;
  DrawList list;
  std::vector<Eigen::Vector3d> screen;  // per vertex: raster coordinates and depth
  bool shaded = false;
  std::vector<std::array<Eigen::Vector3d, 3>> normals;  // per triangle corner, when shaded
  Eigen::Vector3d light;
  double wireAlpha = 0.0;  // 0: no wireframe
};

// Wireframe: half a final pixel on each side of an edge, faded out on dense meshes.
double wireframeAlpha(const Scene& scene, int ss) {
  const int t = static_cast<int>(scene.list.tris.size());
  if (!scene.options.wireframe || t == 0) return 0.0;
  double sum = 0.0;
  for (const auto& f : scene.list.tris)
    for (int j = 0; j < 3; ++j)
      sum += (scene.screen[f[j]] - scene.screen[f[(j + 1) % 3]]).head<2>().norm();
  const double meanEdge = sum / (3.0 * t) / ss;  // final pixels
  return 0.6 * std::clamp((meanEdge - 4.0) / 8.0, 0.0, 1.0);
}

// Projects the mesh into the raster once, with what lighting and the wireframe need.
Scene makeScene(const Mesh& mesh, const RenderOptions& options, const Field& field,
                const Raster& raster) {
  const Projection proj(mesh, options, {0, 0, raster.width, raster.height});
  const Eigen::MatrixXd p = mesh.positions();
  Scene scene{options, field, drawList(mesh), {}, proj.shaded(), {}, {}, 0.0};
  scene.screen.resize(mesh.numVertices());
  for (int i = 0; i < mesh.numVertices(); ++i) scene.screen[i] = proj.project(p.row(i).transpose());
  if (scene.shaded) scene.normals = cornerNormals(p, scene.list, viewRotation(options, true));
  scene.light = Eigen::Vector3d(0.2, 0.5, 1.0).normalized();
  scene.wireAlpha = wireframeAlpha(scene, raster.ss);
  return scene;
}

// Draws triangle k into the raster where it is nearest the viewer: its colour (interpolated
// per pixel for vertex values), lit by its corner normals when shaded, with the wireframe.
void drawTriangle(Raster& raster, const Scene& scene, int k) {
  const RenderOptions& options = scene.options;
  const Field& field = scene.field;
  const auto& f = scene.list.tris[k];
  const Eigen::Vector3d& a = scene.screen[f[0]];
  const Eigen::Vector3d& b = scene.screen[f[1]];
  const Eigen::Vector3d& c = scene.screen[f[2]];
  if (!a.allFinite() || !b.allFinite() || !c.allFinite()) return;
  const double area = (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
  if (std::abs(area) < 1e-12) return;
  const int W = raster.width, H = raster.height;
  const int x0 = std::max(0, static_cast<int>(std::floor(std::min({a.x(), b.x(), c.x()}))));
  const int x1 = std::min(W - 1, static_cast<int>(std::ceil(std::max({a.x(), b.x(), c.x()}))));
  const int y0 = std::max(0, static_cast<int>(std::floor(std::min({a.y(), b.y(), c.y()}))));
  const int y1 = std::min(H - 1, static_cast<int>(std::ceil(std::max({a.y(), b.y(), c.y()}))));
  if (x0 > x1 || y0 > y1) return;

  // Colour inputs.
  const Eigen::Vector3d s =
      field.present && field.perVertex
          ? Eigen::Vector3d(field.s[f[0]], field.s[f[1]], field.s[f[2]])
          : Eigen::Vector3d::Constant(field.present ? field.s[scene.list.element[k]] : 0.0);
  const bool noData = !field.present || !s.allFinite();
  const Rgb flat = noData ? options.noDataColor : colormap(options.colormap, s[0]);
  std::array<Eigen::Vector3d, 3> nrm{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(),
                                     Eigen::Vector3d::Zero()};
  if (scene.shaded) {
    nrm = scene.normals[k];
    // Two-sided lighting: turn the normals of back-facing triangles towards the viewer.
    // In pixel coordinates (y down) a counter-clockwise view-space triangle has area < 0.
    if (area > 0)
      for (auto& v : nrm) v = -v;
  }
  // Altitudes (pixels) for the distance of a point to each edge.
  const double alt[3] = {std::abs(area) / (c - b).head<2>().norm(),
                         std::abs(area) / (a - c).head<2>().norm(),
                         std::abs(area) / (b - a).head<2>().norm()};
  const double halfWidth = 0.5 * raster.ss;

  for (int y = y0; y <= y1; ++y) {
    const double py = y + 0.5;
    for (int x = x0; x <= x1; ++x) {
      const double px = x + 0.5;
      double l0 = ((b.x() - px) * (c.y() - py) - (b.y() - py) * (c.x() - px)) / area;
      double l1 = ((c.x() - px) * (a.y() - py) - (c.y() - py) * (a.x() - px)) / area;
      double l2 = 1.0 - l0 - l1;
      if (l0 < -1e-9 || l1 < -1e-9 || l2 < -1e-9) continue;
      const float z = static_cast<float>(l0 * a.z() + l1 * b.z() + l2 * c.z());
      float& depth = raster.depth[static_cast<std::size_t>(y) * W + x];
      if (z <= depth) continue;
      depth = z;
      Rgb color = flat;
      if (!noData && field.perVertex)
        color = colormap(options.colormap, l0 * s[0] + l1 * s[1] + l2 * s[2]);
      if (scene.shaded) {
        const Eigen::Vector3d nn = (l0 * nrm[0] + l1 * nrm[1] + l2 * nrm[2]).normalized();
        const double shade = kAmbient + kDiffuse * std::max(0.0, nn.dot(scene.light));
        for (auto& ch : color) ch = static_cast<std::uint8_t>(std::lround(ch * shade));
      }
      if (scene.wireAlpha > 0.0) {
        const double d = std::min({l0 * alt[0], l1 * alt[1], l2 * alt[2]});
        color = mix(color, options.wireColor,
                    scene.wireAlpha * std::clamp(halfWidth + 0.5 - d, 0.0, 1.0));
      }
      raster.frame.set(x, y, color);
    }
  }
}

// Box-filters the supersampled frame into the viewport of `image`.
void downsample(const Raster& raster, Image& image, const PixelRect& vp) {
  const int ss = raster.ss;
  for (int y = 0; y < vp.h; ++y) {
    for (int x = 0; x < vp.w; ++x) {
      int sum[3] = {0, 0, 0};
      for (int j = 0; j < ss; ++j) {
        const std::uint8_t* row =
            &raster.frame.rgb[((static_cast<std::size_t>(y) * ss + j) * raster.width + x * ss) * 3];
        for (int i = 0; i < ss * 3; ++i) sum[i % 3] += row[i];
      }
      const int count = ss * ss;
      image.set(vp.x + x, vp.y + y,
                {static_cast<std::uint8_t>((sum[0] + count / 2) / count),
                 static_cast<std::uint8_t>((sum[1] + count / 2) / count),
                 static_cast<std::uint8_t>((sum[2] + count / 2) / count)});
    }
  }
}

// Handle markers at the handle vertices the depth buffer shows: white outlines first, then
// the dots, so clusters read as one region.
void drawHandles(Image& image, const Raster& raster, const Scene& scene, const PixelRect& vp) {
  const RenderOptions& options = scene.options;
  if (options.handles.empty()) return;
  const int ss = raster.ss, W = raster.width, H = raster.height;
  const double radius = options.handleRadius > 0
                            ? options.handleRadius
                            : std::max(2.5, std::min(options.width, options.height) / 150.0);
  const double outline = std::max(1.0, radius / 3.0);
  std::vector<Eigen::Vector2d> visible;
  for (int v : options.handles) {
    const Eigen::Vector3d q = scene.screen[v];
    if (!q.allFinite()) continue;
    const int sx = static_cast<int>(std::floor(q.x())), sy = static_cast<int>(std::floor(q.y()));
    bool seen = false;
    for (int j = sy - 1; j <= sy + 1 && !seen; ++j)
      for (int i = sx - 1; i <= sx + 1 && !seen; ++i)
        if (i >= 0 && j >= 0 && i < W && j < H)
          seen = q.z() >= raster.depth[static_cast<std::size_t>(j) * W + i] - 2.0 * ss;
    if (seen) visible.emplace_back(vp.x + q.x() / ss, vp.y + q.y() / ss);
  }
  for (const auto& c : visible) drawDisc(image, c.x(), c.y(), radius + outline, colors::white);
  for (const auto& c : visible) drawDisc(image, c.x(), c.y(), radius, options.handleColor);
}

// The title centred over the mesh, kept inside the image.
void drawTitle(Image& image, const RenderLayout& layout, const RenderOptions& options) {
  const int ts = layout.textScale;
  const PixelRect& vp = layout.viewport;
  const int w = textWidth(options.title, ts);
  const int x = std::max(0, std::min(vp.x + (vp.w - w) / 2, options.width - w));
  drawText(image, x, layout.title.y, options.title, colors::darkGray, ts);
}

}  // namespace

Rgb colormap(Colormap map, double s) {
  switch (map) {
    case Colormap::Coolwarm:
      return coolwarm(s);
    case Colormap::Turbo:
      return turbo(s);
    case Colormap::Viridis:
      break;
  }
  return viridis(s);
}

Colormap colormapFromString(const std::string& name) {
  for (Colormap map : {Colormap::Viridis, Colormap::Coolwarm, Colormap::Turbo})
    if (name == toString(map)) return map;
  throw InvalidParameter("unknown colour map '" + name + "' (valid: viridis, coolwarm, turbo)");
}

const char* toString(Colormap map) {
  switch (map) {
    case Colormap::Coolwarm:
      return "coolwarm";
    case Colormap::Turbo:
      return "turbo";
    case Colormap::Viridis:
      break;
  }
  return "viridis";
}

RenderLayout renderLayout(const Mesh& mesh, const RenderOptions& options) {
  return layoutFor(options, resolveField(mesh, options));
}

Projection::Projection(const Mesh& mesh, const RenderOptions& options, const PixelRect& viewport)
    : rotation_(viewRotation(options, isOrbit(mesh, options))), shaded_(isOrbit(mesh, options)) {
  Eigen::AlignedBox2d box;
  Eigen::AlignedBox<double, 1> depth;
  auto add = [&](const Eigen::Vector3d& p) {
    const Eigen::Vector3d q = rotation_ * p;
    box.extend(q.head<2>());
    depth.extend(q.tail<1>());
  };
  if (options.frame && !options.frame->isEmpty()) {
    for (int k = 0; k < 8; ++k)
      add(options.frame->corner(static_cast<Eigen::AlignedBox3d::CornerType>(k)));
  } else {
    const Eigen::MatrixXd p = mesh.positions();
    const std::vector<bool> used = mesh.referenced();
    for (int i = 0; i < p.rows(); ++i)
      if (used[i] && p.row(i).allFinite()) add(p.row(i).transpose());
  }
  if (box.isEmpty()) {
    box.extend(Eigen::Vector2d::Zero());
    depth.extend(Eigen::Matrix<double, 1, 1>::Zero());
  }
  const Eigen::Vector2d size = box.sizes();
  const double usable = 1.0 - 2.0 * options.margin;
  const double sx = size.x() > 0 ? usable * viewport.w / size.x() : HUGE_VAL;
  const double sy = size.y() > 0 ? usable * viewport.h / size.y() : HUGE_VAL;
  scale_ = std::min(sx, sy);
  if (!std::isfinite(scale_)) scale_ = 1.0;  // a single point
  const Eigen::Vector2d c = box.center();
  center_ << c.x(), c.y(), depth.center()(0);
  cx_ = viewport.x + 0.5 * viewport.w;
  cy_ = viewport.y + 0.5 * viewport.h;
}

Eigen::Vector3d Projection::rotate(const Eigen::Vector3d& world) const { return rotation_ * world; }

Eigen::Vector3d Projection::project(const Eigen::Vector3d& world) const {
  const Eigen::Vector3d q = rotation_ * world - center_;
  return {cx_ + scale_ * q.x(), cy_ - scale_ * q.y(), scale_ * q.z()};
}

int uprightAxis(const Eigen::AlignedBox3d& frame) {
  if (frame.isEmpty()) return 1;
  const Eigen::Vector3d size = frame.sizes();
  if (size.y() >= (1.0 - 1e-9) * size.maxCoeff()) return 1;  // ties: y
  return size.x() >= size.z() ? 0 : 2;
}

Image renderMesh(const Mesh& mesh, const RenderOptions& options, RenderLayout* drawn) {
  const Field field = resolveField(mesh, options);
  const RenderLayout layout = layoutFor(options, field);
  if (drawn) *drawn = layout;
  checkHandleVertices(mesh, options);
  Image image(options.width, options.height, options.background);
  Raster raster = makeRaster(layout.viewport, options);
  const Scene scene = makeScene(mesh, options, field, raster);
  for (int k = 0; k < static_cast<int>(scene.list.tris.size()); ++k)
    drawTriangle(raster, scene, k);
  downsample(raster, image, layout.viewport);
  drawHandles(image, raster, scene, layout.viewport);
  if (field.present && layout.colorBar.w > 0) drawColorBar(image, layout, field, options);
  if (!options.title.empty()) drawTitle(image, layout, options);
  return image;
}

}  // namespace diffreg
