// Small helpers the tests share: the shipped meshes, documents built in code, nearest vertices,
// scratch directories.
#pragma once

#include <diffreg/handles/handles.h>
#include <diffreg/mesh/mesh.h>
#include <diffreg/pipeline/document.h>

#include <Eigen/Core>
#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

namespace diffreg::testing {

/// The message of the exception of type E that `f` throws, checked to be one line (fails when
/// it throws none).
template <class E, class F>
std::string messageOf(F&& f) {
  try {
    f();
  } catch (const E& e) {
    const std::string what = e.what();
    CHECK(what.find('\n') == std::string::npos);  // one line
    return what;
  }
  FAIL("no exception of the expected type");
  return "";
}

/// What `f` prints on std::cerr (where warnings go).
template <class F>
std::string stderrOf(F&& f) {
  std::ostringstream captured;
  std::streambuf* const old = std::cerr.rdbuf(captured.rdbuf());
  try {
    f();
  } catch (...) {
    std::cerr.rdbuf(old);
    throw;
  }
  std::cerr.rdbuf(old);
  return captured.str();
}

/// A mesh or handle file the project ships in meshes/.
inline std::string shipped(const std::string& name) {
  return std::string(DIFFREG_SOURCE_DIR) + "/meshes/" + name;
}

/// A document of `mesh` (its positions as the rest shape) with handles parsed from JSON text.
inline Document inCode(Mesh mesh, const std::string& handleJson) {
  Document doc;
  doc.mesh = std::move(mesh);
  doc.rest = doc.mesh.positions();
  doc.handles = parseHandles(handleJson, doc.mesh, "test handles");
  return doc;
}

/// The vertex of `mesh` nearest to `p` (the first of equals).
inline int nearest(const Mesh& mesh, const Eigen::Vector3d& p) {
  const Eigen::MatrixXd x = mesh.positions();
  int best = 0;
  for (int v = 1; v < x.rows(); ++v)
    if ((x.row(v).transpose() - p).norm() < (x.row(best).transpose() - p).norm()) best = v;
  return best;
}

/// A fresh, empty directory under the system's temporary directory, removed (whatever the
/// permissions a test left on its contents) with the object.
struct TempDir {
  std::filesystem::path path;
  TempDir() {
    std::string pattern = (std::filesystem::temp_directory_path() / "diffreg-test-XXXXXX").string();
    if (mkdtemp(pattern.data()) == nullptr)
      throw std::runtime_error("cannot create a temporary directory");
    path = pattern;
  }
  ~TempDir() {
    std::error_code ec;
    for (const auto& entry : std::filesystem::recursive_directory_iterator(path, ec))
      std::filesystem::permissions(entry.path(), std::filesystem::perms::owner_all,
                                   std::filesystem::perm_options::add, ec);
    std::filesystem::remove_all(path, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  /// The path of `name` inside the directory.
  std::string operator/(const std::string& name) const { return (path / name).string(); }
  /// Writes `text` to `name` and returns its path.
  std::string file(const std::string& name, const std::string& text) const {
    const std::string p = *this / name;
    std::ofstream(p) << text;
    return p;
  }
  /// Number of entries in the directory.
  int entries() const {
    return static_cast<int>(std::distance(std::filesystem::directory_iterator(path),
                                          std::filesystem::directory_iterator()));
  }
};

}  // namespace diffreg::testing
