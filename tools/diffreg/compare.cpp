#include "compare.h"

#include "cli.h"
#include <diffreg/core/error.h>
#include <diffreg/core/log.h>
#include <diffreg/pipeline/pipeline.h>
#include <diffreg/render/render.h>

#include <boost/program_options.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace po = boost::program_options;

namespace diffreg {
namespace {

const char* kCompareUsage =
    "Usage: diffreg compare -i MESH --handles H.json [-o PICTURE.png] [--report R.json]\n"
    "                       [--markdown T.md] [--weights 'FILTER k=v ...'] [--deform 'deform k=v "
    "...']\n"
    "                       [--beta B] [--rbf ['rbf_weights k=v ...']] [--size WxH] [--up AXIS]\n"
    "                       [--quiet]\n"
    "\n"
    "The same edit without regularization, with uniform regularization and with non-uniform\n"
    "regularization by the diffused weights (and by RBF weights with --rbf), as in the paper's\n"
    "Fig. 6/7 and Table 1. Prints the metrics as a Markdown table; -o draws the rest shape with\n"
    "its weights (with --rbf, the RBF weights beside them on one scale) and every result\n"
    "coloured by distortion on one shared scale. The uniform beta defaults to the peak of the\n"
    "weights, so that both regularizations have the same peak (below 1: at 1 no distortion\n"
    "term is left; give --beta then).\n";

/// One column of the comparison.
struct Variant {
  std::string name;            ///< none, uniform, nonuniform, rbf
  std::string title;           ///< panel title
  std::vector<Step> weights;   ///< the weights step, if any
  std::string regularization;  ///< deform's regularization
  double beta = 0.0;           ///< uniform only
  Document result;
  nlohmann::json report;
};

Step parseStep(const std::string& spec, const std::string& option) {
  const auto [name, values] = parseFilterSpec(spec);
  if (!Registry::builtin().has(name))
    throw UsageError(option + ": unknown filter '" + name + "' (known: " +
                     join(Registry::builtin().names(), ", ") + ")");
  // Its values checked now, before any variant runs.
  const ParamMap checked(name, Registry::builtin().get(name).params(), values);
  return Step{name, values};
}

// --weights and --rbf: a step that makes the weights (checked before it runs: a filter that
// writes files, such as render, would write them outside the staged outputs).
Step parseWeightsStep(const std::string& spec, const std::string& option) {
  Step step = parseStep(spec, option);
  const Filter& filter = Registry::builtin().get(step.filter);
  const std::vector<std::string> made =
      filter.produces(ParamMap(step.filter, filter.params(), step.values));
  if (std::find(made.begin(), made.end(), prop::weight) == made.end())
    throw UsageError(option + ": filter '" + step.filter + "' produces no " + prop::weight +
                     " (give a weights filter: diffuse_weights or rbf_weights)");
  return step;
}

std::string markdownTable(const std::vector<Variant>& variants) {
  std::ostringstream md;
  md << "| regularization | beta | D_max | D_ave | D_dev | Dist | inverted | energy | iterations "
        "|\n";
  md << "|:--|--:|--:|--:|--:|--:|--:|--:|--:|\n";
  for (const Variant& v : variants) {
    const auto& deform = v.report["filters"][v.weights.size()];
    const auto& m = v.report["filters"][v.weights.size() + 1]["metrics"];
    const std::string beta = v.name == "none"      ? "0"
                             : v.name == "uniform" ? fixed(v.beta, 3)
                                                   : "weights";
    md << "| " << v.name << " | " << beta << " | " << fixed(m["D_max"].get<double>(), 4) << " | "
       << fixed(m["D_ave"].get<double>(), 4) << " | " << fixed(m["D_dev"].get<double>(), 4) << " | "
       << fixed(m["dist"].get<double>(), 4) << " | " << m["inverted"].get<int>() << " | "
       << fixed(m["energy"].get<double>(), 4) << " | " << deform["iterations"].get<int>()
       << (deform["converged"].get<bool>() ? "" : " (not converged)") << " |\n";
  }
  return md.str();
}

/// The largest weight at a vertex the elements of the rest shape `doc` use.
double peakWeight(const Eigen::VectorXd& w, const Document& doc) {
  const std::vector<bool> used = doc.mesh.referenced();
  double peak = 0.0;
  for (int i = 0; i < w.size(); ++i)
    if (used[i]) peak = std::max(peak, w[i]);
  return peak;
}

double peakWeight(const Document& weighted, const Document& doc) {
  return peakWeight(weighted.mesh.vertexScalar(prop::weight), doc);
}

/// A weights step as a panel title: the filter and the values it was given.
std::string stepTitle(const Step& step) {
  std::string title = step.filter;
  for (const auto& [key, value] : step.values) title += " " + key + "=" + value;
  return title;
}

/// Rest shape with the weights and handles (and, with --rbf, with the RBF weights beside them on
/// one scale), then every variant by distortion on one scale.
Image comparePicture(const Document& rest, const Document& weighted, const Step& weightsStep,
                     const std::vector<Variant>& variants, int width, int height, int up) {
  Eigen::AlignedBox3d frame = meshBounds(rest.mesh);
  double top = 0.0;
  for (const Variant& v : variants) {
    frame.extend(meshBounds(v.result.mesh));
    top = std::max(top, v.result.mesh.elementScalar(prop::distortion).maxCoeff());
  }
  RenderOptions base;
  base.width = width;
  base.height = height;
  base.frame = frame;
  base.handles = rest.handles.allVertices();
  base.reserveColorBar = true;
  base.upAxis = up >= 0 ? up : uprightAxis(frame);  // 3D views only

  // The weights of the variants with a weights step other than the diffused ones (--rbf), on
  // the rest shape.
  std::vector<std::pair<std::string, Mesh>> others;
  double peak = peakWeight(weighted, rest);
  for (const Variant& v : variants) {
    if (v.name != "rbf") continue;
    Mesh shape = rest.mesh;
    const Eigen::VectorXd w = v.result.mesh.vertexScalar(prop::weight);
    shape.setVertexScalar(prop::weight, w);
    peak = std::max(peak, peakWeight(w, rest));
    others.emplace_back("rest shape, " + stepTitle(v.weights[0]), std::move(shape));
  }

  std::vector<Image> panels;
  RenderOptions weights = base;
  weights.property = prop::weight;
  weights.rangeMin = 0.0;
  if (!others.empty()) weights.rangeMax = peak;  // one scale for the weights compared
  weights.colormap = Colormap::Viridis;
  weights.title = others.empty() ? "rest shape, weights" : "rest shape, " + stepTitle(weightsStep);
  weights.colorBarLabel = "weight";
  panels.push_back(renderMesh(weighted.mesh, weights));
  for (const auto& [title, shape] : others) {
    weights.title = title;
    panels.push_back(renderMesh(shape, weights));
  }
  for (const Variant& v : variants) {
    RenderOptions o = base;
    o.property = prop::distortion;
    o.site = ScalarSite::Element;
    o.rangeMin = 0.0;
    o.rangeMax = top;
    o.colormap = Colormap::Turbo;
    o.colorBarLabel = "distortion";
    o.title = v.title;
    panels.push_back(renderMesh(v.result.mesh, o));
  }
  return composeGrid(panels, panels.size() <= 4 ? 2 : 3);
}

/// The options --help lists, in its order.
po::options_description compareOptions() {
  po::options_description visible("Options");
  visible.add_options()                                                                       //
      ("help,h", "show this help")                                                            //
      ("input,i", po::value<std::string>(), "mesh (obj, off, ply, om, mesh, node/ele)")       //
      ("handles", po::value<std::string>(), "handle file (JSON)")                             //
      ("output,o", po::value<std::string>(), "picture (PNG)")                                 //
      ("report,r", po::value<std::string>(), "JSON report with every variant's filters")      //
      ("markdown,m", po::value<std::string>(), "the Markdown table, also printed on stdout")  //
      ("weights", po::value<std::string>()->default_value("diffuse_weights"),
       "the weights filter and its parameters")  //
      ("deform", po::value<std::string>()->default_value("deform energy=arap"),
       "the deform filter's parameters (regularization and beta are set per variant)")  //
      ("beta", po::value<double>(), "uniform beta (default: the peak of the weights)")  //
      ("rbf", po::value<std::string>()->implicit_value("rbf_weights"),
       "add non-uniform regularization by RBF weights (filter and parameters; clamp=true "
       "unless given: deform needs weights in [0, 1])")  //
      ("size", po::value<std::string>()->default_value("560x380"),
       "size of one panel of the picture, WxH pixels")  //
      ("up", po::value<std::string>()->default_value("auto"),
       "3D meshes: the axis drawn vertically, x, y, z or auto (the shape's longest side)")  //
      ("quiet,q", po::bool_switch(), "no warnings or progress on stderr");
  return visible;
}

/// The command line, checked before the mesh is read (all but --rbf, which is checked when
/// its variant is made, after the weights).
struct CompareSettings {
  int width = 0, height = 0;
  int up = -1;  ///< --up: 0, 1, 2, or -1 for auto
  Step weights, deform;
  std::optional<Step> rbf;     ///< --rbf: a fourth column
  std::optional<double> beta;  ///< --beta; else the peak of the weights
};

/// \throw UsageError for a missing option, a filter that does not fit its option or an output
/// given twice.
CompareSettings compareSettings(const po::variables_map& vm) {
  requireOption(vm, "input", "compare", "-i MESH");
  requireOption(vm, "handles", "compare", "--handles H.json");
  CompareSettings s;
  parseSize("compare", vm["size"].as<std::string>(), s.width, s.height);
  s.up = parseUp("compare", vm["up"].as<std::string>());
  s.weights = parseWeightsStep(vm["weights"].as<std::string>(), "--weights");
  s.deform = parseStep(vm["deform"].as<std::string>(), "--deform");
  if (s.deform.filter != "deform")
    throw UsageError("compare: --deform must name the deform filter, not '" + s.deform.filter +
                     "'");
  for (const char* key : {"regularization", "beta"})
    if (s.deform.values.count(key))
      throw UsageError(std::string("compare: --deform must not set '") + key +
                       "': each variant sets it (use --beta for the uniform one)");
  if (vm.count("beta")) {
    s.beta = vm["beta"].as<double>();
    if (!(*s.beta >= 0.0 && *s.beta <= 1.0))
      throw UsageError("compare: --beta " + formatNumber(*s.beta) + " is not in [0, 1]");
  }
  if (vm.count("rbf")) {
    s.rbf = parseWeightsStep(vm["rbf"].as<std::string>(), "--rbf");
    // Summed Gaussians exceed 1 near a handle of magnitude 1 whenever another handle's tail
    // reaches it, and deform refuses weights above 1: clamped unless the caller says.
    if (s.rbf->filter == "rbf_weights") s.rbf->values.emplace("clamp", "true");
  }
  checkTableOutputs(vm, "compare");
  return s;
}

/// The rest shape with the weights of `weightsStep`, computed once for the peak and the
/// picture. \throw UsageError when the filter makes no weights.
Document weightedRest(const Document& doc, const Step& weightsStep) {
  Document weighted = doc;
  Pipeline weightsOnly;
  weightsOnly.add(weightsStep.filter, weightsStep.values);
  weightsOnly.run(weighted);
  if (!weighted.mesh.hasVertexScalar(prop::weight))
    throw UsageError("compare: --weights filter '" + weightsStep.filter + "' produces no " +
                     prop::weight);
  return weighted;
}

/// The columns: no, uniform (with `beta`) and non-uniform regularization, and with --rbf the
/// RBF weights.
std::vector<Variant> compareVariants(const CompareSettings& s, double beta) {
  const Step& weightsStep = s.weights;
  std::vector<Variant> variants(3);
  variants[0].name = "none";
  variants[0].title = "no regularization";
  variants[0].regularization = "none";
  variants[1].name = "uniform";
  variants[1].title = "uniform, beta = " + fixed(beta, 2);
  variants[1].regularization = "uniform";
  variants[1].beta = beta;
  variants[2].name = "nonuniform";
  variants[2].title = "non-uniform (" + weightsStep.filter + ")";
  variants[2].regularization = "nonuniform";
  variants[2].weights = {weightsStep};
  if (s.rbf) {
    Variant rbf;
    rbf.name = "rbf";
    rbf.weights = {*s.rbf};
    rbf.title = "non-uniform (" + rbf.weights[0].filter + ")";
    rbf.regularization = "nonuniform";
    variants.push_back(rbf);
  }
  return variants;
}

/// Runs every variant on `doc`: its weights, deform with its regularization, measure.
void runVariants(std::vector<Variant>& variants, const Document& doc, const Step& deformStep) {
  ProgressPrinter printer(1.0);
  const ParameterWarningsOnce once;  // what the deform parameters earn is said once
  for (Variant& v : variants) {
    info("compare: " + v.name);
    Pipeline p;
    for (const Step& s : v.weights) p.add(s.filter, s.values);
    auto values = deformStep.values;
    values["regularization"] = v.regularization;
    if (v.name == "uniform") values["beta"] = formatNumber(v.beta);
    p.add("deform", values);
    p.add("measure");
    v.result = doc;
    v.result.progress = [&printer, &v](const std::string& filter, int iteration, double energy,
                                       double criterion) {
      printer(v.name + " " + filter, iteration, energy, criterion);
    };
    v.report = p.run(v.result);
  }
}

/// The --report document: beta, the peak weight and every variant's metrics and filters.
nlohmann::json compareReport(const std::vector<Variant>& variants, double beta, double peak) {
  nlohmann::json report;
  report["mesh"] = variants[0].report["mesh"];
  report["beta"] = beta;
  report["peak_weight"] = peak;
  for (const Variant& v : variants)
    report["variants"].push_back({{"name", v.name},
                                  {"metrics", v.report["filters"][v.weights.size() + 1]["metrics"]},
                                  {"filters", v.report["filters"]}});
  return report;
}

}  // namespace

int runCompare(int argc, char** argv) {
  po::variables_map vm;
  if (!parseCommandLine(argc, argv, kCompareUsage, compareOptions(), vm)) return 0;
  const CompareSettings s = compareSettings(vm);

  const Document doc =
      Document::load(vm["input"].as<std::string>(), vm["handles"].as<std::string>());
  const Document weighted = weightedRest(doc, s.weights);
  const double peak = peakWeight(weighted, doc);
  const double beta = s.beta.value_or(std::min(peak, 1.0));
  if (!s.beta && beta == 1.0)
    warn("compare: the weights peak at " + formatNumber(peak) +
         ", so the uniform beta is 1, where no distortion term is left: the uniform column "
         "minimizes the regularizer alone (give --beta below 1 to compare with)");
  std::vector<Variant> variants = compareVariants(s, beta);
  runVariants(variants, doc, s.deform);

  writeTableOutputs(
      vm, markdownTable(variants),
      [&](const std::string& path) {
        writePng(path, comparePicture(doc, weighted, s.weights, variants, s.width, s.height, s.up));
      },
      [&] { return compareReport(variants, beta, peak); });
  return 0;
}

}  // namespace diffreg
