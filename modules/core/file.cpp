#include "core/file.h"

#include "core/error.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

namespace diffreg {
namespace {

std::string name(const std::string& what, const std::string& path) {
  return (what.empty() ? "" : what + " ") + "'" + path + "'";
}

/// Throws unless `st` describes a regular file of at most `limit` bytes.
void checkStat(const struct stat& st, const std::string& what, const std::string& path,
               std::uint64_t limit) {
  if (S_ISDIR(st.st_mode)) throw IoError("cannot read " + name(what, path) + ": is a directory");
  if (!S_ISREG(st.st_mode)) {
    throw IoError("cannot read " + name(what, path) +
                  ": not a regular file (a device, FIFO or socket is never read)");
  }
  if (static_cast<std::uint64_t>(st.st_size) > limit) {
    throw IoError("cannot read " + name(what, path) + ": it has " +
                  byteText(static_cast<std::uint64_t>(st.st_size)) + ", more than the limit of " +
                  byteText(limit));
  }
}

/// Opens `path` for reading after checking it is a regular file within `limit`.
int openChecked(const std::string& path, const std::string& what, std::uint64_t limit) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    throw IoError("cannot open " + name(what, path) + ": " +
                  (errno == ENOENT ? std::string("no such file") : std::strerror(errno)));
  }
  checkStat(st, what, path, limit);
  // O_NONBLOCK: should the path become a FIFO between stat and open, open does not wait.
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) throw IoError("cannot open " + name(what, path) + ": " + std::strerror(errno));
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode) ||
      static_cast<std::uint64_t>(st.st_size) > limit) {
    ::close(fd);
    if (!S_ISREG(st.st_mode) || static_cast<std::uint64_t>(st.st_size) > limit)
      checkStat(st, what, path, limit);
    throw IoError("cannot read " + name(what, path) + ": " + std::strerror(errno));
  }
  return fd;
}

}  // namespace

std::string byteText(std::uint64_t bytes) {
  char buf[64];
  if (bytes < 1024) {
    std::snprintf(buf, sizeof buf, "%llu bytes", static_cast<unsigned long long>(bytes));
  } else if (bytes % (1u << 20) == 0) {
    std::snprintf(buf, sizeof buf, "%llu MiB", static_cast<unsigned long long>(bytes >> 20));
  } else {
    std::snprintf(buf, sizeof buf, "%.1f MiB", static_cast<double>(bytes) / (1 << 20));
  }
  return buf;
}

std::uint64_t checkInputFile(const std::string& path, const std::string& what,
                             std::uint64_t limit) {
  const int fd = openChecked(path, what, limit);
  struct stat st {};
  ::fstat(fd, &st);
  ::close(fd);
  return static_cast<std::uint64_t>(st.st_size);
}

std::string readFileLimited(const std::string& path, const std::string& what, std::uint64_t limit) {
  const int fd = openChecked(path, what, limit);
  struct stat st {};
  ::fstat(fd, &st);
  std::string text;
  text.reserve(static_cast<size_t>(st.st_size));
  char buf[1 << 16];
  for (;;) {
    const ssize_t got = ::read(fd, buf, sizeof buf);
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) {
      const int err = errno;
      ::close(fd);
      throw IoError("cannot read " + name(what, path) + ": " + std::strerror(err));
    }
    if (got == 0) break;
    if (text.size() + static_cast<size_t>(got) > limit) {  // it grew while read
      ::close(fd);
      throw IoError("cannot read " + name(what, path) + ": longer than the limit of " +
                    byteText(limit));
    }
    text.append(buf, static_cast<size_t>(got));
  }
  ::close(fd);
  return text;
}

}  // namespace diffreg
