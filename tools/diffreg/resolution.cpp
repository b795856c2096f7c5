#include "resolution.h"

#include "cli.h"
#include <diffreg/core/error.h>
#include <diffreg/core/log.h>
#include <diffreg/discretization/discretization.h>
#include <diffreg/pipeline/params.h>
#include <diffreg/pipeline/pipeline.h>
#include <diffreg/render/render.h>

#include <boost/program_options.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace po = boost::program_options;
namespace fs = std::filesystem;

namespace diffreg {
namespace {

const char* kResolutionUsage =
    "Usage: diffreg resolution -i MESH --handles H.json [-o PICTURE.png] [--levels 2] [--t 0.01]\n"
    "                          [--scheme midpoint|loop] [--probe V] [--report R.json]\n"
    "                          [--markdown T.md] [--size WxH] [--up AXIS] [--quiet]\n"
    "\n"
    "The paper's resolution experiment (Fig. 9): the mesh is refined 1-to-4 up to --levels\n"
    "times (the original vertices keep their ids; a handle region grows with its edges, a\n"
    "one-vertex handle stays one vertex) and the diffused weights are computed on every level\n"
    "with t in each unit of the diffuse_weights filter. --t is in the default unit, squared\n"
    "bounding-box diagonals of the level-0 mesh; the absolute and mean_edge2 values are\n"
    "converted so that all three units give the same physical t on level 0 and the same\n"
    "weights there. With absolute and diagonal t the weights at the original vertices\n"
    "converge under refinement; with mean_edge2 the physical t drops 4x per level and the\n"
    "weights shrink. Prints per unit and level the largest and mean change of the weights\n"
    "at the original vertices outside the handles against level 0, their mean, and the weight\n"
    "at a probe vertex (default: the original vertex whose level-0 weight is nearest half the\n"
    "peak). -o draws a grid, rows = units, columns = levels, weights on one scale.\n";

const char* kUnits[] = {"absolute", "diagonal", "mean_edge2"};

/// One unit on one level.
struct Cell {
  std::string unit;
  int level = 0;
  double t = 0.0;          ///< in the unit
  double tAbsolute = 0.0;  ///< length^2, as the filter reports it
  Eigen::VectorXd weights;
  double maxChange = 0.0, meanChange = 0.0, mean = 0.0, probe = 0.0;
};

/// A short number for picture titles (3 significant digits).
std::string shortNumber(double value) {
  std::ostringstream out;
  out.precision(3);
  out << value;
  return out.str();
}

std::string markdownTable(const std::vector<Cell>& cells, const std::vector<Document>& levels,
                          int probe) {
  std::ostringstream md;
  md << "| t unit | level | vertices | t | t (length^2) | max abs change | mean abs change | "
        "mean weight | weight at vertex "
     << probe << " |\n";
  md << "|:--|--:|--:|--:|--:|--:|--:|--:|--:|\n";
  for (const Cell& c : cells)
    md << "| " << c.unit << " | " << c.level << " | " << levels[c.level].mesh.numVertices() << " | "
       << fixed(c.t, 4) << " | " << fixed(c.tAbsolute, 4) << " | " << fixed(c.maxChange, 4) << " | "
       << fixed(c.meanChange, 4) << " | " << fixed(c.mean, 4) << " | " << fixed(c.probe, 4)
       << " |\n";
  return md.str();
}

/// Rows = units, columns = levels, every panel the weights on the shared scale [0, top].
/// height = 0: each panel as high as the shape needs at `width` (at least 150 pixels), so that
/// the mesh fills its panel.
Image resolutionPicture(const std::vector<Cell>& cells, const std::vector<Document>& levels,
                        double top, int width, int height, int up) {
  Eigen::AlignedBox3d frame = meshBounds(levels[0].mesh);
  for (const Document& d : levels) frame.extend(meshBounds(d.mesh));
  RenderOptions base;
  base.width = width;
  base.height = height;
  base.frame = frame;
  base.property = prop::weight;
  base.rangeMin = 0.0;
  base.rangeMax = top;
  base.colormap = Colormap::Viridis;
  base.colorBarLabel = "weight";
  base.textScale = std::clamp(width / 260, 1, 4);
  base.upAxis = up >= 0 ? up : uprightAxis(frame);  // 3D views only
  if (height == 0) {
    // The frame's extent in the view at a trial size gives the height at which the viewport
    // has the shape's aspect ratio.
    RenderOptions trial = base;
    trial.height = std::max(width, 400);
    const Mesh& mesh = levels[0].mesh;
    trial.values = Eigen::VectorXd::Zero(mesh.numVertices());  // any values: the range is set
    trial.site = ScalarSite::Vertex;
    const RenderLayout layout = renderLayout(mesh, trial);
    const Projection projection(mesh, trial, layout.viewport);
    Eigen::AlignedBox2d extent;
    for (int corner = 0; corner < 8; ++corner)
      extent.extend(
          projection.project(frame.corner(static_cast<Eigen::AlignedBox3d::CornerType>(corner)))
              .head<2>());
    const double aspect = extent.sizes().y() / std::max(extent.sizes().x(), 1e-9);
    const int viewportHeight = static_cast<int>(std::ceil(aspect * layout.viewport.w));
    height = std::clamp(trial.height - layout.viewport.h + viewportHeight, 150, 3 * width);
    base.height = height;
  }
  std::vector<Image> panels;
  for (const Cell& c : cells) {
    const Document& doc = levels[c.level];
    RenderOptions o = base;
    o.handles = doc.handles.allVertices();
    // Finer levels have many more handle vertices; smaller dots keep the weights visible.
    o.handleRadius = std::max(1.5, 0.006 * std::min(width, height) * std::pow(0.7, c.level));
    o.values = c.weights;
    o.site = ScalarSite::Vertex;
    o.title = c.unit + ", level " + std::to_string(c.level) + " (" +
              std::to_string(doc.mesh.numVertices()) + " v), t = " + shortNumber(c.t) +
              (c.unit == "absolute" ? "" : " (" + shortNumber(c.tAbsolute) + " length^2)");
    panels.push_back(renderMesh(doc.mesh, o));
  }
  return composeGrid(panels, static_cast<int>(levels.size()));
}

/// The command line, checked before any mesh is read.
struct ResolutionSettings {
  std::string input, handles, scheme;
  int levels = 2;
  double t = 0.01;              ///< squared level-0 bounding-box diagonals
  int width = 520, height = 0;  ///< height 0: as high as the shape needs
  int up = -1;                  ///< --up: 0, 1, 2, or -1 for auto
  std::optional<int> probe;     ///< --probe, checked against the mesh once it is read
};

/// The options --help lists, in its order.
po::options_description resolutionOptions() {
  po::options_description visible("Options");
  visible.add_options()                                                                     //
      ("help,h", "show this help")                                                          //
      ("input,i", po::value<std::string>(), "mesh (obj, off, ply, om; planar or surface)")  //
      ("handles", po::value<std::string>(), "handle file (JSON)")                           //
      ("output,o", po::value<std::string>(), "picture (PNG)")                               //
      ("levels", po::value<int>()->default_value(2), "refinements, 0..4")                   //
      ("t", po::value<double>()->default_value(0.01),
       "diffusion time in squared level-0 bounding-box diagonals")  //
      ("scheme", po::value<std::string>()->default_value("midpoint"),
       "subdivision: midpoint (shape kept) or loop (smoothed)")                               //
      ("probe", po::value<int>(), "vertex id whose weight the table shows")                   //
      ("report,r", po::value<std::string>(), "JSON report")                                   //
      ("markdown,m", po::value<std::string>(), "the Markdown table, also printed on stdout")  //
      ("size", po::value<std::string>()->default_value("auto"),
       "size of one panel of the picture, WxH pixels; auto: 520 wide, as high as the shape "
       "needs")  //
      ("up", po::value<std::string>()->default_value("auto"),
       "3D meshes: the axis drawn vertically, x, y, z or auto (the shape's longest side)")  //
      ("quiet,q", po::bool_switch(), "no warnings or progress on stderr");
  return visible;
}

/// \throw UsageError for a missing or out-of-range option or an output given twice.
ResolutionSettings resolutionSettings(const po::variables_map& vm) {
  requireOption(vm, "input", "resolution", "-i MESH");
  requireOption(vm, "handles", "resolution", "--handles H.json");
  ResolutionSettings s;
  s.input = vm["input"].as<std::string>();
  s.handles = vm["handles"].as<std::string>();
  s.levels = vm["levels"].as<int>();
  if (s.levels < 0 || s.levels > 4)
    throw UsageError("resolution: --levels " + std::to_string(s.levels) +
                     " is out of range 0..4 (each level has 4x the triangles)");
  s.t = vm["t"].as<double>();
  if (!(s.t > 0.0 && s.t <= kMaxDiffusionTime))
    throw UsageError("resolution: --t " + formatNumber(s.t) + " is not in (0, " +
                     formatNumber(kMaxDiffusionTime) + "]");
  s.scheme = vm["scheme"].as<std::string>();
  if (s.scheme != "midpoint" && s.scheme != "loop")
    throw UsageError("resolution: --scheme '" + s.scheme + "' is not one of midpoint, loop");
  if (vm["size"].as<std::string>() != "auto")
    parseSize("resolution", vm["size"].as<std::string>(), s.width, s.height);
  s.up = parseUp("resolution", vm["up"].as<std::string>());
  checkTableOutputs(vm, "resolution");
  if (vm.count("probe")) s.probe = vm["probe"].as<int>();
  return s;
}

/// The original vertices outside every handle: where the weights are compared.
/// \throw InvalidParameter for a tet mesh, no handle or no such vertex; UsageError for a
/// --probe that is not a vertex.
std::vector<int> comparedVertices(const Document& base, const ResolutionSettings& s) {
  if (base.mesh.isTet())
    throw InvalidParameter("resolution: '" + s.input +
                           "' is a tet mesh; subdivision applies to planar and surface meshes");
  if (base.handles.handles.empty())
    throw InvalidParameter("resolution: the handle file '" + s.handles + "' defines no handle");
  const int n0 = base.mesh.numVertices();
  const std::vector<bool> used = base.mesh.referenced();
  const std::vector<int> owner = base.handles.handleOfVertex(n0);
  std::vector<int> free;
  for (int v = 0; v < n0; ++v)
    if (used[v] && owner[v] < 0) free.push_back(v);
  if (free.empty())
    throw InvalidParameter("resolution: every vertex of '" + s.input +
                           "' is a handle vertex; there are no weights to compare");
  if (s.probe && (*s.probe < 0 || *s.probe >= n0))
    throw UsageError("resolution: --probe " + std::to_string(*s.probe) +
                     " is not a vertex of the mesh (0.." + std::to_string(n0 - 1) + ")");
  if (s.probe && !used[static_cast<size_t>(*s.probe)])
    throw UsageError("resolution: --probe " + std::to_string(*s.probe) +
                     " is not part of any element, so it has no weight to follow");
  return free;
}

/// Appends `count` refinements of the last level, each by the subdivide filter.
void addLevels(std::vector<Document>& levels, int count, const std::string& scheme) {
  for (int level = 1; level <= count; ++level) {
    info("resolution: subdividing, level " + std::to_string(level));
    Document next = levels.back();
    Pipeline p;
    p.add("subdivide", {{"iterations", "1"}, {"scheme", scheme}, {"handles", "grow"}});
    p.run(next);
    levels.push_back(std::move(next));
  }
}

/// The level-0 scales that convert --t into every unit.
struct LevelZeroScale {
  double tAbsolute = 0.0;  ///< --t in length^2
  double meanEdge = 0.0;   ///< the mean edge length of level 0
};

/// One physical t on level 0 for all units: --t is in squared diagonals there.
LevelZeroScale levelZeroScale(const Document& base, double t) {
  const Discretization disc0(base.mesh.kind(), base.rest, base.mesh.elements());
  const double diagonal2 = disc0.boundingBoxDiagonal() * disc0.boundingBoxDiagonal();
  return {t * diagonal2, disc0.meanEdgeLength()};
}

/// The diffused weights of every unit on every level, unit by unit (level 0 first in each).
std::vector<Cell> weightCells(const std::vector<Document>& levels, double t,
                              const LevelZeroScale& scale) {
  std::vector<Cell> cells;
  for (const char* unit : kUnits) {
    for (int level = 0; level < static_cast<int>(levels.size()); ++level) {
      info(std::string("resolution: weights, t_unit ") + unit + ", level " + std::to_string(level));
      Cell c;
      c.unit = unit;
      c.level = level;
      c.t = c.unit == "absolute"   ? scale.tAbsolute
            : c.unit == "diagonal" ? t
                                   : scale.tAbsolute / (scale.meanEdge * scale.meanEdge);
      Document d = levels[level];
      Pipeline p;
      p.add("diffuse_weights", {{"t", formatNumber(c.t)}, {"t_unit", unit}});
      const nlohmann::json report = p.run(d);
      c.tAbsolute = report["filters"][0]["t_absolute"].get<double>();
      c.weights = d.mesh.vertexScalar(prop::weight);
      cells.push_back(std::move(c));
    }
  }
  return cells;
}

/// The free original vertex whose level-0 weight `w0` is nearest half the peak.
int defaultProbe(const Eigen::VectorXd& w0, const std::vector<int>& free) {
  int probe = -1;
  double peak = 0.0;
  for (int v : free) peak = std::max(peak, w0[v]);
  double best = std::numeric_limits<double>::infinity();
  for (int v : free)
    if (std::abs(w0[v] - 0.5 * peak) < best) {
      best = std::abs(w0[v] - 0.5 * peak);
      probe = v;
    }
  return probe;
}

/// Fills every cell's changes against level 0 of its unit, its mean and its probe weight at
/// the `free` vertices. Returns the top of the picture's scale: the largest handle magnitude
/// or weight. \throw SingularSystem for non-finite weights.
double compareLevels(std::vector<Cell>& cells, const std::vector<int>& free, int probe,
                     const HandleSet& handles) {
  double top = 0.0;
  for (const Handle& h : handles.handles) top = std::max(top, h.magnitude);
  for (std::size_t k = 0; k < cells.size(); ++k) {
    Cell& c = cells[k];
    const Eigen::VectorXd& ref = cells[k - c.level].weights;  // the same unit on level 0
    double sumChange = 0.0, sum = 0.0;
    for (int v : free) {
      const double change = std::abs(c.weights[v] - ref[v]);
      c.maxChange = std::max(c.maxChange, change);
      sumChange += change;
      sum += c.weights[v];
    }
    c.meanChange = sumChange / static_cast<double>(free.size());
    c.mean = sum / static_cast<double>(free.size());
    c.probe = c.weights[probe];
    for (int i = 0; i < c.weights.size(); ++i)
      if (!std::isfinite(c.weights[i]))
        throw SingularSystem(std::string("resolution: non-finite weights with t_unit ") + c.unit +
                             " on level " + std::to_string(c.level));
    top = std::max(top, c.weights.maxCoeff());
  }
  return top;
}

/// The --report document: the settings, every level's size and every unit's rows.
nlohmann::json resolutionReport(const ResolutionSettings& s, const LevelZeroScale& scale,
                                int probe, std::size_t compared,
                                const std::vector<Document>& levels,
                                const std::vector<Cell>& cells) {
  nlohmann::json report;
  report["mesh"] = s.input;
  report["scheme"] = s.scheme;
  report["t"] = s.t;
  report["t_unit"] = "diagonal";
  report["t_absolute_level0"] = scale.tAbsolute;
  report["mean_edge_level0"] = scale.meanEdge;
  report["probe"] = probe;
  report["compared_vertices"] = compared;
  for (const Document& d : levels) {
    int handleVertices = 0;
    for (const Handle& h : d.handles.handles)
      handleVertices += static_cast<int>(h.vertices.size());
    report["levels"].push_back({{"vertices", d.mesh.numVertices()},
                                {"elements", d.mesh.numElements()},
                                {"handle_vertices", handleVertices}});
  }
  for (const char* unit : kUnits) {
    nlohmann::json rows = nlohmann::json::array();
    for (const Cell& c : cells)
      if (c.unit == unit)
        rows.push_back({{"level", c.level},
                        {"t", c.t},
                        {"t_absolute", c.tAbsolute},
                        {"max_change", c.maxChange},
                        {"mean_change", c.meanChange},
                        {"mean", c.mean},
                        {"probe", c.probe}});
    report["units"][unit] = rows;
  }
  return report;
}

}  // namespace

int runResolution(int argc, char** argv) {
  po::variables_map vm;
  if (!parseCommandLine(argc, argv, kResolutionUsage, resolutionOptions(), vm)) return 0;
  const ResolutionSettings s = resolutionSettings(vm);

  std::vector<Document> levels;
  levels.reserve(s.levels + 1);
  levels.push_back(Document::load(s.input, s.handles));
  const std::vector<int> free = comparedVertices(levels[0], s);
  addLevels(levels, s.levels, s.scheme);

  const LevelZeroScale scale = levelZeroScale(levels[0], s.t);
  std::vector<Cell> cells = weightCells(levels, s.t, scale);
  const int probe = s.probe ? *s.probe : defaultProbe(cells[0].weights, free);
  const double top = compareLevels(cells, free, probe, levels[0].handles);

  writeTableOutputs(
      vm, markdownTable(cells, levels, probe),
      [&](const std::string& path) {
        writePng(path, resolutionPicture(cells, levels, top, s.width, s.height, s.up));
      },
      [&] { return resolutionReport(s, scale, probe, free.size(), levels, cells); });
  return 0;
}

}  // namespace diffreg
