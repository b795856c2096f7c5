#include <diffreg/core/file.h>

#include <diffreg/core/error.h>
#include <diffreg/core/text.h>

#include <fcntl.h>
#include <limits.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>

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
  checkNoNul(path, "open " + (what.empty() ? std::string("file") : what));
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

void checkNoNul(const std::string& path, const std::string& doing) {
  if (path.find('\0') == std::string::npos) return;
  throw IoError("cannot " + doing + " '" + nulShown(path) + "': the name has a NUL byte");
}

std::string byteText(std::uint64_t bytes) {
  char buf[64];
  if (bytes < 1024) {
    std::snprintf(buf, sizeof buf, "%llu bytes", static_cast<unsigned long long>(bytes));
  } else if (bytes % (1u << 20) == 0) {
    std::snprintf(buf, sizeof buf, "%llu MiB", static_cast<unsigned long long>(bytes >> 20));
  } else {
    std::snprintf(buf, sizeof buf, "%.1f MiB", static_cast<double>(bytes) / (1 << 20));
    // Never a whole number of MiB that it is not ("128.0 MiB" for a byte more than 128 MiB).
    const double shown = std::strtod(buf, nullptr);
    if (shown == std::floor(shown))
      std::snprintf(buf, sizeof buf, "%llu bytes", static_cast<unsigned long long>(bytes));
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

namespace {

// The registry the signal handler reads: fixed slots, each claimed and released through its
// flag, so that the handler touches no heap and no lock. The flags and the paths are zero-
// initialized static arrays without a constructor (a struct with an initialized flag beside
// each 4 KiB path was filled in at start-up, touching 64 pages of every run); the flags sit
// together, so that finding a slot reads one cache line.
std::atomic<int> g_slotState[kMaxTemporaries];  // 0 free, 1 being written, 2 holds a path
char g_slotPath[kMaxTemporaries][PATH_MAX];

constexpr int kCleanupSignals[] = {SIGINT, SIGTERM, SIGHUP};

// SignalsDeferred: how many are alive (in any thread), and a signal that came meanwhile.
std::atomic<int> g_deferDepth{0};
std::atomic<int> g_pendingSignal{0};

void removeTemporariesAndRaise(int signal) {
  for (int i = 0; i < kMaxTemporaries; ++i)
    if (g_slotState[i].load(std::memory_order_acquire) == 2) ::unlink(g_slotPath[i]);
  ::signal(signal, SIG_DFL);
  ::raise(signal);  // the default action ends the whole process, from whichever thread
}

void onCleanupSignal(int signal) {
  // Any thread may take a signal sent to the process, so deferral is a count every thread
  // reads, not a signal mask. Recorded first, then acted on here only when no deferred step
  // runs; one that ends meanwhile acts on it itself.
  g_pendingSignal.store(signal);
  if (g_deferDepth.load() == 0) removeTemporariesAndRaise(signal);
}

}  // namespace

void registerTemporary(const std::string& path) {
  if (path.size() >= PATH_MAX) return;
  for (int i = 0; i < kMaxTemporaries; ++i) {
    int expected = 0;
    if (!g_slotState[i].compare_exchange_strong(expected, 1)) continue;
    std::memcpy(g_slotPath[i], path.c_str(), path.size() + 1);
    g_slotState[i].store(2, std::memory_order_release);
    return;
  }
}

void unregisterTemporary(const std::string& path) {
  for (int i = 0; i < kMaxTemporaries; ++i) {
    int expected = 2;
    if (g_slotState[i].load() == 2 && path == g_slotPath[i] &&
        g_slotState[i].compare_exchange_strong(expected, 0))
      return;
  }
}

void removeTemporariesOnSignal() {
  struct sigaction action {};
  action.sa_handler = onCleanupSignal;
  action.sa_flags = SA_RESTART;  // a deferred signal returns: interrupted calls go on
  sigemptyset(&action.sa_mask);
  for (int s : kCleanupSignals) sigaddset(&action.sa_mask, s);
  for (int s : kCleanupSignals) ::sigaction(s, &action, nullptr);
}

SignalsDeferred::SignalsDeferred() { g_deferDepth.fetch_add(1); }

SignalsDeferred::~SignalsDeferred() {
  if (g_deferDepth.fetch_sub(1) != 1) return;
  if (const int signal = g_pendingSignal.exchange(0)) removeTemporariesAndRaise(signal);
}

std::string writeTarget(const std::string& path) {
  checkNoNul(path, "write");
  namespace fs = std::filesystem;
  fs::path p(path);
  for (int links = 0; links <= 40; ++links) {
    std::error_code ec;
    if (!fs::is_symlink(fs::symlink_status(p, ec))) return p.string();
    const fs::path to = fs::read_symlink(p, ec);
    if (ec) return p.string();  // gone meanwhile: the write creates it
    p = to.is_absolute() ? to : p.parent_path() / to;
  }
  throw IoError("cannot write '" + path + "': too many levels of symbolic links");
}

std::string createTemporary(const std::string& shown, const std::string& prefix,
                            const std::string& suffix) {
  // O_EXCL: never an existing file or a planted link.
  static const char alphabet[] = "abcdefghijklmnopqrstuvwxyz0123456789";
  std::random_device rd;
  std::mt19937 rng(rd());
  for (int attempt = 0; attempt < 100; ++attempt) {
    std::string name = prefix;
    for (int i = 0; i < 6; ++i) name += alphabet[rng() % (sizeof(alphabet) - 1)];
    name += suffix;
    const SignalsDeferred deferred;  // created and registered, or neither
    const int fd = ::open(name.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0 && errno != EEXIST)
      throw IoError("cannot write '" + shown + "': " + std::strerror(errno));
    if (fd >= 0) {
      registerTemporary(name);
      ::close(fd);
      return name;
    }
  }
  throw IoError("cannot write '" + shown + "': no free temporary name");
}

void writeFileAtomically(const std::string& shown, const std::function<void(std::ostream&)>& body) {
  const auto fail = [&shown](const std::string& reason) {
    return IoError("cannot write '" + shown + "': " + reason);
  };
  const std::string path = writeTarget(shown);
  const std::string tmp = createTemporary(shown, path + ".tmp-", "");
  struct Unregister {
    const std::string& path;
    ~Unregister() { unregisterTemporary(path); }
  } unregister{tmp};
  try {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw fail("cannot open '" + tmp + "'");
    body(out);
    out.flush();
    if (!out) throw fail("write failed");
    out.close();
    if (out.fail()) throw fail("close failed");
    // The data on disk before the name points to it (else a crash can leave an empty file).
    const int fd = ::open(tmp.c_str(), O_RDONLY | O_CLOEXEC);
    const bool synced = fd >= 0 && ::fsync(fd) == 0;
    const int err = errno;
    if (fd >= 0) ::close(fd);
    if (!synced) throw fail(std::string("sync failed: ") + std::strerror(err));
    if (std::rename(tmp.c_str(), path.c_str()) != 0) throw fail(std::strerror(errno));
  } catch (const Error&) {
    std::remove(tmp.c_str());
    throw;
  } catch (const std::exception& e) {
    std::remove(tmp.c_str());
    throw fail(e.what());
  }
}

std::string besideThisExecutable(const std::string& name) {
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::string() : (self.parent_path() / name).string();
}

}  // namespace diffreg
