// Reading whole input files under a byte limit. Every file diffreg reads (meshes, handle files,
// MeshLab picked points and scripts) goes through readFileLimited, so an endless or huge input
// (a device, a FIFO, a multi-gigabyte file) ends in a one-line IoError instead of a hang or
// runaway memory. Files diffreg writes go through writeFileAtomically.
#pragma once

#include <cstdint>
#include <functional>
#include <ostream>
#include <string>

namespace diffreg {

/// The byte limits of the files diffreg reads.
namespace limits {
/// A mesh file (OBJ, OFF, PLY, OM, Medit, TetGen .node or .ele). Reading one takes up to about
/// 20 times its size in memory (measured: 9.5x for a 41 MB grid OBJ, 17x for a file of vertex
/// lines only), so at most about 2.5 GiB.
inline constexpr std::uint64_t meshBytes = std::uint64_t(128) << 20;
/// A handle file, a MeshLab picked points file or filter script.
inline constexpr std::uint64_t textBytes = std::uint64_t(16) << 20;
}  // namespace limits

/// The system's calls take a file name up to its first NUL byte, so a name with one inside
/// would read or write another file than the one named. Every reader and writer of files by
/// name calls this first.
/// \throw IoError "cannot DOING 'name': the name has a NUL byte" (the NUL written as \x00).
void checkNoNul(const std::string& path, const std::string& doing);

/// The whole content of the regular file `path`; `what` names it in messages ("handle file").
/// Devices, FIFOs and sockets are refused before they are opened for reading.
/// \throw IoError "cannot open WHAT 'path': ..." when it is missing, a directory, not a regular
///        file, unreadable, or longer than `limit` bytes (also when it grows while read), or when
///        its name has a NUL byte (the system would open the name cut there).
std::string readFileLimited(const std::string& path, const std::string& what, std::uint64_t limit);

/// The size of the regular file `path`, with the same checks as readFileLimited (for readers
/// that hand the file to a library). \throw IoError as readFileLimited.
std::uint64_t checkInputFile(const std::string& path, const std::string& what, std::uint64_t limit);

/// The file that a write to `path` replaces: `path` itself, or, when `path` is a symbolic link,
/// the file its links lead to (a relative link read against its own directory; the last one may
/// name a file that does not exist yet), so that writing through a link keeps the link.
/// \throw IoError "cannot write 'path': too many levels of symbolic links" after 40 links, or
///        "cannot write 'path': the name has a NUL byte".
std::string writeTarget(const std::string& path);

/// Creates a new empty file named `prefix`, six random letters and digits, `suffix` (O_EXCL:
/// never an existing file or a planted link) and registers it as a temporary (below).
/// \throw IoError "cannot write 'shown': ..." when no such file can be created.
std::string createTemporary(const std::string& shown, const std::string& prefix,
                            const std::string& suffix);

/// Writes the file `path` all or nothing: `body` writes a new temporary file beside it
/// ("<path>.tmp-XXXXXX", in the same directory so that the rename is atomic), which is flushed,
/// synced to disk and renamed onto `path`. Readers see the old file or the whole new one, never
/// a part. On any failure the temporary is removed and `path` is left as it was. A `path` that is
/// a symbolic link stays one: the file it leads to is written (writeTarget).
/// \throw IoError "cannot write 'path': ..." when the name has a NUL byte, creating, writing,
///        syncing or renaming fails or `body` throws a standard exception; an Error thrown by
///        `body` passes unchanged.
void writeFileAtomically(const std::string& path, const std::function<void(std::ostream&)>& body);

/// Temporary files that an interrupted program should not leave behind. A program that calls
/// removeTemporariesOnSignal() (the tools do; the library installs no signal handler) removes
/// every registered path when SIGINT, SIGTERM or SIGHUP ends it, then dies of that signal.
/// writeFileAtomically registers its temporaries itself. At most kMaxTemporaries at once (more
/// are not registered); paths longer than PATH_MAX are not registered.
inline constexpr int kMaxTemporaries = 64;
void registerTemporary(const std::string& path);
void unregisterTemporary(const std::string& path);
void removeTemporariesOnSignal();

/// While one is alive (in any thread), SIGINT, SIGTERM and SIGHUP under
/// removeTemporariesOnSignal() wait: a step that must not be cut in the middle (renaming a set
/// of outputs into place) finishes first, and the last one to end acts on the signal.
class SignalsDeferred {
 public:
  SignalsDeferred();
  ~SignalsDeferred();
  SignalsDeferred(const SignalsDeferred&) = delete;
  SignalsDeferred& operator=(const SignalsDeferred&) = delete;
};

/// The path of the file `name` in the directory of the running executable (its real location,
/// symbolic links resolved), whether or not that file exists; empty when the executable's
/// location cannot be found out. For the tools that start one another.
std::string besideThisExecutable(const std::string& name);

/// "1.5 MiB", "512 MiB", "300 bytes": a byte count for messages.
std::string byteText(std::uint64_t bytes);

}  // namespace diffreg
