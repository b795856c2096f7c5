// Running the diffreg tool from the tests: a scratch directory per test and the tool's exit
// code, stdout and stderr.
#pragma once

#include <diffreg/render/image.h>
#include "test_support.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <sys/wait.h>
#include <unistd.h>

namespace diffreg::testing {

namespace fs = std::filesystem;

inline std::string slurp(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

inline int lineCount(const std::string& text) {
  return static_cast<int>(std::count(text.begin(), text.end(), '\n'));
}

struct ToolRun {
  int code = -1;
  std::string out, err;
};

/// A fresh directory under the system's temporary directory, removed with the object.
struct Scratch {
  fs::path dir;
  explicit Scratch(const std::string& tag)
      : dir(fs::temp_directory_path() / ("diffreg-" + tag + "-" + std::to_string(::getpid()))) {
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  ~Scratch() { fs::remove_all(dir); }
  Scratch(const Scratch&) = delete;
  Scratch& operator=(const Scratch&) = delete;

  /// Runs `diffreg ARGS` (shell words) in the directory; stdout and stderr are captured and
  /// leave no file behind.
  ToolRun run(const std::string& args) const {
    const std::string command = "cd '" + dir.string() + "' && '" + DIFFREG_TOOL + "' " + args +
                                " > .stdout 2> .stderr";
    const int status = std::system(command.c_str());
    ToolRun r;
    r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.out = slurp(dir / ".stdout");
    r.err = slurp(dir / ".stderr");
    fs::remove(dir / ".stdout");
    fs::remove(dir / ".stderr");
    return r;
  }
  bool has(const std::string& name) const { return fs::exists(dir / name); }
  /// Number of files in the directory.
  int files() const {
    return static_cast<int>(std::distance(fs::directory_iterator(dir), fs::directory_iterator()));
  }
};

/// The pixels of the picture that `command` (a picture command with its options, e.g.
/// "resolution --levels 0") draws of the shipped cylinder twist with `--up` set to each of
/// `ups`, by value. Each run must succeed.
inline std::map<std::string, std::vector<std::uint8_t>> picturesByUp(
    const Scratch& s, const std::string& command, const std::vector<std::string>& ups) {
  std::map<std::string, std::vector<std::uint8_t>> pictures;
  for (const std::string& up : ups) {
    const ToolRun r = s.run(command + " -i '" + shipped("cylinder.obj") + "' --handles '" +
                            shipped("cylinder-twist.json") + "' -o " + up +
                            ".png --size 120x100 --up " + up + " -q");
    INFO(up << ": " << r.err);
    REQUIRE(r.code == 0);
    pictures[up] = readPng((s.dir / (up + ".png")).string()).rgb;
  }
  return pictures;
}

}  // namespace diffreg::testing
