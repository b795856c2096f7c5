// Outputs that appear together or not at all: files written under temporary names beside
// their targets and renamed into place by one commit (the diffreg tool's -o, --report and the
// files its filters write; Python's run()).
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace diffreg {

/// `path` as an absolute path with symbolic links, "." and ".." resolved (as far as it
/// exists): two spellings of one file give the same string.
std::string canonicalTarget(const std::string& path);

/// \throw IoError unless the directory that would hold `path` exists and is writable and
/// `path` is not a directory or another non-regular file: what staging it needs, checked on
/// the path given before any work (its temporary has another name).
void checkWritableDir(const std::string& path);

/// Files written under temporary names beside their targets (same extension, so writers that
/// pick a format by it still do), renamed into place together by commit(). A target that is a
/// symbolic link stays one: the file it leads to is replaced. Whatever was not
/// committed is removed, so a failed run leaves no new or clobbered file.
class StagedOutputs {
 public:
  StagedOutputs() = default;
  StagedOutputs(const StagedOutputs&) = delete;
  StagedOutputs& operator=(const StagedOutputs&) = delete;
  ~StagedOutputs();
  /// Returns the temporary name to write `path` to.
  /// \throw InvalidParameter when `path` (under any spelling) is already staged.
  std::string stage(const std::string& path);
  /// Stages `path` and has `write` write its temporary.
  /// \throw IoError when writing fails, its message naming `path` where it named the temporary.
  void stageWritten(const std::string& path, const std::function<void(const std::string&)>& write);
  /// stageWritten with `text` for the content.
  void stageText(const std::string& path, const std::string& text);
  /// Renames every temporary onto its target; when a rename fails, the targets renamed so far
  /// get back what they held (or are removed when they did not exist).
  /// \return the targets written, as given, in the order they were staged.
  /// \throw IoError when a rename fails.
  std::vector<std::string> commit();

 private:
  struct Entry {
    std::string temporary;
    std::string target;  ///< as given (for messages)
    std::string file;    ///< what is replaced: the target, or where its links lead (writeTarget)
    std::string canonical;
  };
  std::vector<Entry> staged_;
};

}  // namespace diffreg
