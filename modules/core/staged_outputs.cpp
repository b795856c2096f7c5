#include <diffreg/core/staged_outputs.h>

#include <diffreg/core/error.h>
#include <diffreg/core/file.h>
#include <diffreg/core/log.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>

#include <unistd.h>

namespace fs = std::filesystem;

namespace diffreg {

std::string canonicalTarget(const std::string& path) {
  std::error_code ec;
  const fs::path p = fs::weakly_canonical(fs::absolute(path), ec);
  return ec ? fs::absolute(path).lexically_normal().string() : p.string();
}

void checkWritableDir(const std::string& path) {
  fs::path dir = fs::path(writeTarget(path)).parent_path();  // where the temporary goes
  if (dir.empty()) dir = ".";
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw IoError("cannot write '" + path + "': '" + dir.string() + "' " +
                  (fs::exists(dir, ec) ? "is not a directory" : "does not exist"));
  if (::access(dir.c_str(), W_OK | X_OK) != 0)
    throw IoError("cannot write '" + path + "': directory '" + dir.string() + "' is not writable");
  const fs::file_status st = fs::status(path, ec);
  if (fs::is_directory(st)) throw IoError("cannot write '" + path + "': it is a directory");
  if (fs::exists(st) && !fs::is_regular_file(st))
    throw IoError("cannot write '" + path + "': it exists and is not a regular file");
}

StagedOutputs::~StagedOutputs() {
  for (const Entry& e : staged_) {
    std::remove(e.temporary.c_str());
    unregisterTemporary(e.temporary);
  }
}

std::string StagedOutputs::stage(const std::string& path) {
  // A link stays a link: the file it leads to is written. Absolute, so that a change of the
  // working directory during the run changes nothing.
  const fs::path p = fs::absolute(writeTarget(path));
  const std::string canonical = canonicalTarget(path);
  for (const Entry& e : staged_)
    if (e.canonical == canonical)
      throw InvalidParameter("output '" + path + "' is written twice" +
                             (e.target != path ? " (also as '" + e.target + "')" : ""));
  // A new file beside the one it replaces (the rename is atomic there), with the extension of
  // `path` as given: the writers pick the format by it, and a link's own target may have
  // another. Registered: an interrupted run removes it (removeTemporariesOnSignal).
  const std::string tmp =
      createTemporary(path, (p.parent_path() / ("." + p.stem().string() + ".tmp-")).string(),
                      fs::path(path).extension().string());
  staged_.push_back({tmp, path, p.string(), canonical});
  return tmp;
}

void StagedOutputs::stageWritten(const std::string& path,
                                 const std::function<void(const std::string&)>& write) {
  const std::string temporary = stage(path);
  // What the writer says of the file (a full disk, a property left out) names the output, not
  // its temporary.
  const auto named = [&](std::string text) {
    for (size_t at = text.find(temporary); at != std::string::npos;
         at = text.find(temporary, at + path.size()))
      text.replace(at, temporary.size(), path);
    return text;
  };
  std::vector<std::string> said;
  std::exception_ptr failure;
  {
    WarningCollector collector;
    try {
      write(temporary);
    } catch (...) {
      failure = std::current_exception();
    }
    said = collector.take();
  }
  for (const auto& w : said) warn(named(w));
  if (!failure) return;
  try {
    std::rethrow_exception(failure);
  } catch (const IoError& e) {
    throw IoError(named(e.what()));
  } catch (const InvalidMesh& e) {
    throw InvalidMesh(named(e.what()));
  }  // any other, as it was
}

void StagedOutputs::stageText(const std::string& path, const std::string& text) {
  stageWritten(path, [&text](const std::string& temporary) {
    writeFileAtomically(temporary, [&text](std::ostream& out) { out << text; });
  });
}

std::vector<std::string> StagedOutputs::commit() {
  // Each existing target is moved aside first; if any rename fails, every target renamed so far
  // gets its old file (or its absence) back. An interrupt waits until the set is in place.
  const SignalsDeferred deferred;
  std::vector<std::pair<std::string, std::string>> done;  // target, backup ("" = was absent)
  const auto undo = [&done] {
    for (auto it = done.rbegin(); it != done.rend(); ++it) {
      if (it->second.empty())
        std::remove(it->first.c_str());
      else
        std::rename(it->second.c_str(), it->first.c_str());
    }
  };
  for (const Entry& e : staged_) {
    std::string backup;
    std::error_code ec;
    const fs::file_status st = fs::symlink_status(e.file, ec);
    if (fs::is_directory(st)) {  // became one after the checks: never moved aside
      undo();
      throw IoError("cannot write '" + e.target + "': it is a directory");
    }
    if (fs::exists(st)) {
      backup = e.temporary + ".old";
      if (std::rename(e.file.c_str(), backup.c_str()) != 0) {
        const int err = errno;
        undo();
        throw IoError("cannot write '" + e.target + "': " + std::strerror(err));
      }
    }
    if (std::rename(e.temporary.c_str(), e.file.c_str()) != 0) {
      const int err = errno;
      if (!backup.empty()) std::rename(backup.c_str(), e.file.c_str());
      undo();
      throw IoError("cannot write '" + e.target + "': " + std::strerror(err));
    }
    done.emplace_back(e.file, backup);
  }
  for (const auto& [target, backup] : done)
    if (!backup.empty()) std::remove(backup.c_str());
  std::vector<std::string> written;
  for (const Entry& e : staged_) {
    unregisterTemporary(e.temporary);
    written.push_back(e.target);
  }
  staged_.clear();
  return written;
}

}  // namespace diffreg
