#include "cli.h"

#include "core/error.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include <unistd.h>

namespace fs = std::filesystem;

namespace diffreg {

std::string join(const std::vector<std::string>& items, const char* separator) {
  std::string out;
  for (size_t i = 0; i < items.size(); ++i) out += (i ? separator : "") + items[i];
  return out;
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

std::string StagedOutputs::stage(const std::string& path) {
  const fs::path p(path);
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
