#include "cli.h"

#include <diffreg/core/error.h>
#include <diffreg/core/file.h>
#include <diffreg/core/log.h>
#include <diffreg/core/text.h>
#include <diffreg/render/image.h>
#include <diffreg/solver/blas_threads.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <sstream>

namespace fs = std::filesystem;

namespace diffreg {

std::string join(const std::vector<std::string>& items, const char* separator) {
  std::string out;
  for (size_t i = 0; i < items.size(); ++i) out += (i ? separator : "") + items[i];
  return out;
}

namespace {

/// Prints the one error line (terminalLine: line breaks folded, control bytes escaped, at most
/// a few thousand bytes of it).
void printError(const std::string& message) {
  std::cerr << "diffreg: error: " << terminalLine(message) << std::endl;
}

}  // namespace

std::string& currentInput() {
  static std::string input;
  return input;
}

int runCommand(const std::function<int()>& body) {
  reserveBlasThreads();
  try {
    return body();
  } catch (const UsageError& e) {
    printError(e.what());
    return 2;
  } catch (const boost::program_options::error& e) {
    printError(e.what());
    return 2;
  } catch (const std::bad_alloc&) {
    try {  // the unwinding freed the run's memory; should even this message not fit, a fixed one
      printError("out of memory (" + (currentInput().empty()
                                          ? std::string("before reading any input")
                                          : "while working on '" + currentInput() + "'") +
                 ")");
    } catch (...) {
      std::fputs("diffreg: error: out of memory\n", stderr);
    }
    return 1;
  } catch (const std::exception& e) {
    printError(e.what());
    return 1;
  }
}

bool parseCommandLine(int argc, char** argv, const char* usage,
                      const boost::program_options::options_description& options,
                      boost::program_options::variables_map& vm) {
  namespace po = boost::program_options;
  po::store(po::command_line_parser(argc, argv).options(options).run(), vm);
  po::notify(vm);
  if (vm.count("help")) {
    std::cout << usage << "\n" << options;
    return false;
  }
  if (vm.count("quiet") && vm["quiet"].as<bool>()) setQuiet(true);
  if (vm.count("input")) currentInput() = vm["input"].as<std::string>();
  return true;
}

void requireOption(const boost::program_options::variables_map& vm, const std::string& key,
                   const std::string& command, const std::string& what) {
  if (!vm.count(key))
    throw UsageError(command + ": missing " + what + " (see diffreg " + command + " --help)");
}

std::string fixed(double value, int digits) {
  if (!std::isfinite(value)) return "-";
  std::ostringstream out;
  const double magnitude = std::abs(value);
  if (value != 0.0 && (magnitude < 1e-3 || magnitude >= 1e5)) {
    out.precision(digits - 1);
    out << std::scientific << value;
  } else {
    out.precision(digits);
    out << std::fixed << value;
  }
  return out.str();
}

void parseSize(const std::string& command, const std::string& size, int& width, int& height) {
  char x = 0;
  std::istringstream in(size);
  if (!(in >> width >> x >> height) || x != 'x' || !in.eof() || width < 100 || height < 100 ||
      width > 4000 || height > 4000)
    throw UsageError(command + ": --size '" + size + "' is not WxH with 100 <= W, H <= 4000");
}

int parseUp(const std::string& command, const std::string& up) {
  if (up == "auto") return -1;
  if (up == "x" || up == "y" || up == "z") return up[0] - 'x';
  throw UsageError(command + ": --up '" + up + "' is not one of auto, x, y, z");
}

void checkOutputTarget(const std::string& path, const std::vector<std::string>& extensions) {
  checkWritableDir(path);
  if (extensions.empty()) return;
  std::string ext = fs::path(path).extension().string();
  if (!ext.empty()) ext = ext.substr(1);
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  for (const auto& e : extensions)
    if (e == ext) return;
  throw IoError("cannot write '" + path + "': this output is written as " + join(extensions, ", ") +
                ", not '" + (ext.empty() ? "(no extension)" : "." + ext) + "'");
}

void ProgressPrinter::operator()(const std::string& filter, int iteration, double energy,
                                 double criterion) {
  const double now =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  if (now < after_ || (last_ >= 0.0 && now - last_ < 1.0)) return;
  last_ = now;
  std::ostringstream line;
  line << filter << ": iteration " << iteration << ", energy " << std::setprecision(6) << energy;
  if (std::isnan(criterion))
    line << ", criterion not measured yet";
  else
    line << ", criterion " << std::setprecision(2) << criterion;
  info(line.str());
}

void checkTableOutputs(const boost::program_options::variables_map& vm,
                       const std::string& command) {
  std::vector<std::string> outputs;
  for (const char* key : {"output", "report", "markdown"})
    if (vm.count(key)) {
      const std::string path = vm[key].as<std::string>();
      for (const auto& other : outputs)
        if (canonicalTarget(other) == canonicalTarget(path))
          throw UsageError(command + ": output '" + path + "' given twice");
      outputs.push_back(path);
      checkOutputTarget(
          path, key == std::string("output") ? kPictureExtensions : std::vector<std::string>{});
      if (key == std::string("output")) requireTextRendering();  // before the work, not after
    }
}

void writeTableOutputs(const boost::program_options::variables_map& vm, const std::string& table,
                       const std::function<void(const std::string&)>& drawPicture,
                       const std::function<nlohmann::json()>& makeReport) {
  StagedOutputs staged;
  if (vm.count("output")) staged.stageWritten(vm["output"].as<std::string>(), drawPicture);
  if (vm.count("report"))
    staged.stageText(vm["report"].as<std::string>(), reportText(makeReport()));
  if (vm.count("markdown")) staged.stageText(vm["markdown"].as<std::string>(), table);
  const std::vector<std::string> written = staged.commit();
  std::cout << table;
  if (!written.empty()) info("wrote " + join(written, ", "));
}

}  // namespace diffreg
