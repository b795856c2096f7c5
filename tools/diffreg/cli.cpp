#include "cli.h"

#include "core/error.h"
#include "core/log.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iomanip>
#include <sstream>

#include <unistd.h>

namespace fs = std::filesystem;

namespace diffreg {

std::string join(const std::vector<std::string>& items, const char* separator) {
  std::string out;
  for (size_t i = 0; i < items.size(); ++i) out += (i ? separator : "") + items[i];
  return out;
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

void checkWritableDir(const std::string& path) {
  fs::path dir = fs::path(path).parent_path();
  if (dir.empty()) dir = ".";
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw IoError("cannot write '" + path + "': directory '" + dir.string() + "' does not exist");
}

StagedOutputs::~StagedOutputs() {
  for (const auto& [tmp, path] : staged_) std::remove(tmp.c_str());
}

void ProgressPrinter::operator()(const std::string& filter, int iteration, double energy,
                                 double criterion) {
  const double now =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  if (now < after_ || (last_ >= 0.0 && now - last_ < 1.0)) return;
  last_ = now;
  std::ostringstream line;
  line << filter << ": iteration " << iteration << ", energy " << std::setprecision(6) << energy
       << ", criterion " << std::setprecision(2) << criterion;
  info(line.str());
}

std::string StagedOutputs::stage(const std::string& path) {
  const fs::path p(path);
  for (const auto& [tmp, target] : staged_)
    if (fs::absolute(target) == fs::absolute(p))
      throw InvalidParameter("output '" + path + "' is written twice (by -o, --report or a filter)");
  const std::string tmp = (p.parent_path() / ("." + p.stem().string() + ".tmp" +
                                              std::to_string(::getpid()) + p.extension().string()))
                              .string();
  staged_.emplace_back(tmp, path);
  return tmp;
}

void StagedOutputs::stageText(const std::string& path, const std::string& text) {
  const std::string tmp = stage(path);
  std::ofstream out(tmp, std::ios::binary);
  out << text;
  out.close();
  if (!out) throw IoError("cannot write '" + path + "'");
}

void StagedOutputs::commit() {
  for (const auto& [tmp, path] : staged_)
    if (std::rename(tmp.c_str(), path.c_str()) != 0)
      throw IoError("cannot write '" + path + "': " + std::strerror(errno));
  staged_.clear();
}

}  // namespace diffreg
