// diffreg: applies registered filters to a mesh and writes the result and a JSON report.
//
//   diffreg -i IN [--handles H.json] [--filter 'NAME key=value ...']... -o OUT [--report R.json]
//   diffreg filters
//
// Every check (options, filters, parameters, needed handles and properties, output paths)
// happens before any work; output files appear only when everything succeeded. Errors print
// one line "diffreg: error: ..." on stderr; the exit code is 2 for usage errors, else 1.

#include <diffreg/core/error.h>
#include <diffreg/core/file.h>
#include <diffreg/core/heap.h>
#include <diffreg/core/log.h>
#include <diffreg/core/timer.h>
#include <diffreg/mesh/io.h>
#include <diffreg/pipeline/mlx.h>
#include <diffreg/pipeline/pipeline.h>
#include "cli.h"
#include "compare.h"
#include "plugins.h"
#include "resolution.h"

#include <boost/program_options.hpp>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#ifndef DIFFREG_VERSION
#define DIFFREG_VERSION "0.1.0"
#endif

namespace po = boost::program_options;
namespace fs = std::filesystem;

namespace diffreg {
namespace {

const char* kUsage =
    "Usage: diffreg -i IN [--handles H.json] [-s SCRIPT.mlx] [--filter 'NAME key=value ...']...\n"
    "               -o OUT [--report R.json] [--quiet]\n"
    "       diffreg filters      list every filter with its parameters\n"
    "       diffreg filters --mlx  print a MeshLab .mlx script of every filter at its defaults\n"
    "       diffreg compare ...  none / uniform / non-uniform regularization side by side\n"
    "       diffreg serve -i MESH [--handles H.json] [--port 8080]  edit in the browser\n"
    "       diffreg resolution ...  weights under refinement for each unit of t (paper Fig. 9)\n"
    "       diffreg --help | --version\n"
    "\n"
    "Applies the filters in the order given to the mesh IN and writes OUT; the extension of\n"
    "OUT picks the format (obj, off, ply, om for triangle meshes; mesh, or ply for the boundary\n"
    "surface of a tet mesh); -o may be repeated. PLY output carries the weights as vertex\n"
    "quality and colours, the distortion as face quality and every other named property\n"
    "under its own name. Without --filter the mesh is only converted. Nothing is written\n"
    "when anything fails.\n"
    "-s runs the filters of a MeshLab FilterScript (.mlx) first, then any --filter ones.\n";

/// Wraps `text` to `width` columns, each line starting with `indent`.
std::string wrap(const std::string& text, const std::string& indent, size_t width = 78) {
  std::istringstream words(text);
  std::string word, line, out;
  while (words >> word) {
    if (!line.empty() && indent.size() + line.size() + 1 + word.size() > width) {
      out += indent + line + "\n";
      line.clear();
    }
    line += (line.empty() ? "" : " ") + word;
  }
  if (!line.empty()) out += indent + line + "\n";
  return out;
}

/// The `diffreg filters` listing, generated from the registry's parameter tables.
std::string describeFilters(const Registry& registry) {
  std::string out;
  for (const auto& name : registry.names()) {
    const Filter& filter = registry.get(name);
    const ParamMap defaults(name, filter.params(), {});
    std::vector<std::string> notes;
    if (filter.needsHandles()) notes.push_back("needs handles");
    const auto needs = filter.requires(defaults);
    // What a filter needs can depend on its parameters: this is what it needs at their defaults.
    if (!needs.empty()) notes.push_back("requires " + join(needs, ", ") + " at the defaults");
    const auto makes = filter.produces(defaults);
    if (!makes.empty()) notes.push_back("produces " + join(makes, ", "));
    out += name + (notes.empty() ? "" : "  (" + join(notes, "; ") + ")") + "\n";
    out += wrap(filter.description(), "  ");
    const auto specs = filter.params();
    out += specs.empty() ? "  No parameters.\n" : "  Parameters:\n";
    for (const auto& spec : specs) {
      std::string type = toString(spec.type);
      if (spec.type == ParamType::Enum) type += ": " + join(spec.choices, " | ");
      if (hasRange(spec)) type += " in " + rangeText(spec);
      out += "    " + spec.name + " = " + defaults.text().at(spec.name) + "  (" + type + ")\n";
      out += wrap(spec.help, "        ");
    }
    out += "\n";
  }
  return out;
}

int runPipeline(const po::variables_map& vm) {
  const Timer total;
  if (!vm.count("input")) throw UsageError("missing -i IN (see diffreg --help)");
  if (!vm.count("output")) throw UsageError("missing -o OUT (see diffreg --help)");
  const std::string input = vm["input"].as<std::string>();
  currentInput() = input;
  const double progressAfter = vm["progress-after"].as<double>();
  if (!(progressAfter >= 0.0) || !std::isfinite(progressAfter))
    throw UsageError("--progress-after " + formatNumber(progressAfter) +
                     " must be a non-negative number of seconds");
  const auto outputs = vm["output"].as<std::vector<std::string>>();
  const std::string handles = vm.count("handles") ? vm["handles"].as<std::string>() : "";
  const std::string reportPath = vm.count("report") ? vm["report"].as<std::string>() : "";

  // Everything that can be checked before work is checked first.
  Pipeline pipeline;
  if (vm.count("script")) {
    for (const Step& step : readFilterScript(vm["script"].as<std::string>())) pipeline.add(step);
  }
  if (vm.count("filter")) {
    for (const auto& spec : vm["filter"].as<std::vector<std::string>>()) {
      const auto [name, values] = parseFilterSpec(spec);
      pipeline.add(name, values);
    }
  }
  // Two spellings of one file (a.ply, ./a.ply, a link to it) are one output.
  std::vector<std::string> targets = outputs;
  if (!reportPath.empty()) targets.push_back(reportPath);
  const auto option = [&](size_t i) { return i < outputs.size() ? "-o" : "--report"; };
  for (size_t i = 0; i < targets.size(); ++i) {
    checkWritableDir(targets[i]);
    for (size_t j = 0; j < i; ++j)
      if (canonicalTarget(targets[i]) == canonicalTarget(targets[j]))
        throw UsageError("output '" + targets[i] + "' given twice (" + option(i) + ", also as " +
                         option(j) + " '" + targets[j] + "')");
  }

  Timer phase;
  Document doc = Document::load(input, handles);
  const double readSeconds = phase.seconds();
  for (const auto& output : outputs) checkWritable(output, doc.mesh.kind());
  pipeline.check(doc);
  // Files the filters write (render's PNG) are staged with the outputs: all or nothing.
  StagedOutputs staged;
  doc.outputFile = [&staged](const std::string& path) { return staged.stage(path); };
  ProgressPrinter printer(progressAfter);
  doc.progress = [&printer](const std::string& filter, int iteration, double energy,
                            double criterion) { printer(filter, iteration, energy, criterion); };
  phase.reset();
  nlohmann::json report = pipeline.run(doc);
  const double filterSeconds = phase.seconds();

  phase.reset();
  for (const auto& output : outputs)
    staged.stageWritten(output,
                        [&doc](const std::string& temporary) { writeMesh(temporary, doc.mesh); });
  // Where the time of the run went (the report itself and the final renames are not counted).
  report["seconds"] = {{"read", readSeconds},
                       {"filters", filterSeconds},
                       {"write", phase.seconds()},
                       {"total", total.seconds()}};
  if (!reportPath.empty()) staged.stageText(reportPath, reportText(report));
  info("wrote " + join(staged.commit(), ", "));  // the filters' files too
  return 0;
}

// `diffreg serve ...` is the executable diffreg-serve beside this one (on the PATH when this
// one's location is unknown), started in this process's place: the HTTP server and the
// libraries it links are loaded only by it. argv[0] is "serve".
int runServe(int argc, char** argv) {
  std::string tool = besideThisExecutable("diffreg-serve");
  if (tool.empty()) tool = "diffreg-serve";
  std::vector<std::string> args = {tool};
  for (int i = 1; i < argc; ++i) args.emplace_back(argv[i]);
  std::vector<char*> pointers;
  for (std::string& a : args) pointers.push_back(a.data());
  pointers.push_back(nullptr);
  ::execvp(tool.c_str(), pointers.data());
  throw IoError("serve: cannot run '" + tool + "': " + std::strerror(errno) +
                " (the editor is the executable diffreg-serve, installed beside diffreg)");
}

int run(int argc, char** argv) {
  if (argc > 1 && std::string(argv[1]) == "compare") return runCompare(argc - 1, argv + 1);
  if (argc > 1 && std::string(argv[1]) == "serve") return runServe(argc - 1, argv + 1);
  if (argc > 1 && std::string(argv[1]) == "resolution") return runResolution(argc - 1, argv + 1);
  po::options_description visible("Options");
  visible.add_options()                                                                        //
      ("help,h", "show this help and the filter names")                                        //
      ("version", "show the version")                                                          //
      ("input,i", po::value<std::string>(), "input mesh (obj, off, ply, om, mesh, node/ele)")  //
      ("output,o", po::value<std::vector<std::string>>()->composing(),
       "output mesh; the extension picks the format; repeat for several")  //
      ("handles", po::value<std::string>(), "handle file (JSON)")          //
      ("filter,f", po::value<std::vector<std::string>>()->composing(),
       "'NAME key=value ...': a filter to apply; repeat for a chain, applied in order")  //
      ("report,r", po::value<std::string>(), "write a JSON report of the run")           //
      ("script,s", po::value<std::string>(),
       "MeshLab .mlx filter script: its filters run first, then any --filter ones")      //
      ("mlx", po::bool_switch(), "with 'filters': print a MeshLab .mlx script instead")  //
      ("quiet,q", po::bool_switch(), "no warnings or progress on stderr")                //
      ("progress-after", po::value<double>()->default_value(1.0, "1"),
       "seconds of work before iterations are reported on stderr");
  po::options_description hidden;
  hidden.add_options()("command", po::value<std::vector<std::string>>());
  po::options_description all;
  all.add(visible).add(hidden);
  po::positional_options_description positional;
  positional.add("command", -1);

  po::variables_map vm;
  po::store(po::command_line_parser(argc, argv).options(all).positional(positional).run(), vm);
  po::notify(vm);
  if (vm["quiet"].as<bool>()) setQuiet(true);

  const Registry& registry = Registry::builtin();
  if (vm.count("help")) {
    std::cout << kUsage << "\n"
              << visible << "\nFilters (details: diffreg filters): " << join(registry.names(), ", ")
              << "\n";
    return 0;
  }
  if (vm.count("version")) {
    std::cout << "diffreg " << DIFFREG_VERSION << "\n";
    return 0;
  }
  if (vm.count("command")) {
    const auto commands = vm["command"].as<std::vector<std::string>>();
    for (const char* command : {"compare", "serve", "resolution"})
      if (commands[0] == command)
        throw UsageError("'" + commands[0] + "' must come first: diffreg " + commands[0] +
                         " ... (see diffreg " + commands[0] + " --help)");
    if (commands[0] != "filters")
      throw UsageError("unexpected argument '" + commands[0] +
                       "' (commands: filters, compare, serve, resolution; see diffreg --help)");
    if (commands.size() != 1)
      throw UsageError("unexpected argument '" + commands[1] +
                       "': the filters command lists every filter and takes no name");
    std::cout << (vm["mlx"].as<bool>() ? defaultFilterScript(registry) : describeFilters(registry));
    return 0;
  }
  if (vm["mlx"].as<bool>())
    throw UsageError("--mlx goes with the filters command: diffreg filters --mlx");
  return runPipeline(vm);
}

}  // namespace
}  // namespace diffreg

int main(int argc, char** argv) {
  diffreg::tuneHeapForBatchRun();  // a run reads, computes, writes and exits
  diffreg::removeTemporariesOnSignal();  // Ctrl-C leaves no half-written file behind
  return diffreg::runCommand([&] { return diffreg::run(argc, argv); });
}
