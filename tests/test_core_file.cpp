// Temporary files and signals (modules/core/file.h): an interrupted program leaves none of its
// registered temporaries behind, and dies of the signal that ended it.
#include <diffreg/core/error.h>
#include <diffreg/core/file.h>

#include <catch2/catch.hpp>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

namespace fs = std::filesystem;
using namespace diffreg;

namespace {

/// Runs `child` in a forked process; returns its wait status.
template <class F>
int inChild(F child) {
  const pid_t pid = ::fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    child();
    ::_exit(0);
  }
  int status = 0;
  REQUIRE(::waitpid(pid, &status, 0) == pid);
  return status;
}

fs::path scratch(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / ("diffreg-core-file-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir / name;
}

}  // namespace

TEST_CASE("an interrupted program removes its registered temporaries", "[core][file]") {
  const fs::path kept = scratch("kept.txt"), tmp = scratch(".out.tmp"), done = scratch("done.txt");
  for (const fs::path& p : {kept, tmp, done}) std::ofstream(p) << "x";
  for (int signal : {SIGINT, SIGTERM, SIGHUP}) {
    INFO(signal);
    std::ofstream(tmp) << "half";
    const int status = inChild([&] {
      removeTemporariesOnSignal();
      registerTemporary(tmp.string());
      registerTemporary(done.string());
      unregisterTemporary(done.string());  // renamed into place: no longer a temporary
      ::raise(signal);
      ::_exit(3);  // not reached: the signal ends the process
    });
    CHECK(WIFSIGNALED(status));
    CHECK(WTERMSIG(status) == signal);
    CHECK_FALSE(fs::exists(tmp));
    CHECK(fs::exists(kept));
    CHECK(fs::exists(done));
  }
  fs::remove_all(kept.parent_path());
}

TEST_CASE("a signal waits while SignalsDeferred is alive", "[core][file]") {
  const fs::path tmp = scratch(".deferred.tmp"), marker = scratch("finished.txt");
  std::ofstream(tmp) << "half";
  const int status = inChild([&] {
    removeTemporariesOnSignal();
    registerTemporary(tmp.string());
    // A second thread, as the solver's and the BLAS's: a signal sent to the process may be
    // taken by it rather than by the thread in the deferred step.
    std::thread other([] { std::this_thread::sleep_for(std::chrono::seconds(2)); });
    other.detach();
    {
      const SignalsDeferred deferred;
      ::kill(::getpid(), SIGINT);  // to the process, as Ctrl-C
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
      std::ofstream(marker) << "the step finished";
      unregisterTemporary(tmp.string());  // as a rename into place would
    }
    ::_exit(3);  // not reached: the deferred signal ends the process here
  });
  CHECK(WIFSIGNALED(status));
  CHECK(WTERMSIG(status) == SIGINT);
  CHECK(fs::exists(marker));  // the step was not cut
  CHECK(fs::exists(tmp));     // and what it put in place was not removed
  fs::remove_all(tmp.parent_path());
}

TEST_CASE("writeFileAtomically's temporary goes with an interrupt", "[core][file]") {
  const fs::path target = scratch("atomic.txt");
  const int status = inChild([&] {
    removeTemporariesOnSignal();
    writeFileAtomically(target.string(), [](std::ostream& out) {
      out << "half";
      out.flush();
      ::raise(SIGTERM);  // interrupted while writing
    });
  });
  CHECK(WIFSIGNALED(status));
  CHECK(WTERMSIG(status) == SIGTERM);
  CHECK(fs::is_empty(target.parent_path()));  // neither the file nor its temporary
  // Uninterrupted, the whole file is in place and nothing else.
  writeFileAtomically(target.string(), [](std::ostream& out) { out << "whole"; });
  std::ifstream in(target);
  std::string text;
  in >> text;
  CHECK(text == "whole");
  CHECK(std::distance(fs::directory_iterator(target.parent_path()), fs::directory_iterator()) == 1);
  fs::remove_all(target.parent_path());
}

TEST_CASE("byteText never rounds to a size it is not", "[core][file]") {
  CHECK(byteText(300) == "300 bytes");
  CHECK(byteText(std::uint64_t(128) << 20) == "128 MiB");
  CHECK(byteText((std::uint64_t(3) << 19)) == "1.5 MiB");
  // One byte over 128 MiB is not "128.0 MiB, more than the limit of 128 MiB".
  CHECK(byteText((std::uint64_t(128) << 20) + 1) == "134217729 bytes");
}

TEST_CASE("writeFileAtomically writes through a symbolic link and keeps it", "[core][file]") {
  const fs::path dir = scratch("links");
  fs::remove_all(dir);
  fs::create_directories(dir / "data");
  const auto read = [](const fs::path& p) {
    std::ifstream in(p);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  const auto write = [](const fs::path& p, const std::string& text) {
    writeFileAtomically(p.string(), [&text](std::ostream& out) { out << text; });
  };
  // A relative link to a file in another directory, and a link to that link.
  std::ofstream(dir / "data" / "mesh.ply") << "old";
  fs::create_symlink("data/mesh.ply", dir / "link.ply");
  fs::create_symlink("link.ply", dir / "link2.ply");
  write(dir / "link2.ply", "new");
  CHECK(fs::is_symlink(dir / "link2.ply"));
  CHECK(fs::is_symlink(dir / "link.ply"));
  CHECK(read(dir / "data" / "mesh.ply") == "new");
  CHECK(writeTarget((dir / "link2.ply").string()) == (dir / "data" / "mesh.ply").string());
  // A dangling link: its file is created.
  fs::create_symlink("data/fresh.ply", dir / "fresh.ply");
  write(dir / "fresh.ply", "made");
  CHECK(fs::is_symlink(dir / "fresh.ply"));
  CHECK(read(dir / "data" / "fresh.ply") == "made");
  // A loop of links is refused, and nothing is written.
  fs::create_symlink("b.ply", dir / "a.ply");
  fs::create_symlink("a.ply", dir / "b.ply");
  CHECK_THROWS_WITH(write(dir / "a.ply", "x"),
                    Catch::Contains("too many levels of symbolic links"));
  CHECK(fs::is_symlink(dir / "a.ply"));
  // No temporary is left anywhere.
  for (const auto& entry : fs::recursive_directory_iterator(dir))
    CHECK(entry.path().filename().string().find(".tmp") == std::string::npos);
  fs::remove_all(dir.parent_path());  // the scratch directory too
}

TEST_CASE("a name with a NUL byte is refused: the system would use the name cut there",
          "[core][file]") {
  const fs::path dir = scratch("nul");
  fs::remove_all(dir);
  fs::create_directories(dir);
  // "cut" exists and "cut\0.ply" would open it; writing would replace it.
  std::ofstream(dir / "cut") << "kept";
  const std::string named = (dir / "cut").string() + std::string(1, '\0') + ".ply";
  CHECK_THROWS_WITH(readFileLimited(named, "mesh file", 100),
                    Catch::Contains("mesh file") && Catch::Contains("the name has a NUL byte"));
  CHECK_THROWS_AS(checkInputFile(named, "mesh file", 100), IoError);
  CHECK_THROWS_WITH(
      writeFileAtomically(named, [](std::ostream& out) { out << "replaced"; }),
      Catch::StartsWith("cannot write") && Catch::Contains("the name has a NUL byte"));
  std::ifstream in(dir / "cut");
  CHECK(std::string(std::istreambuf_iterator<char>(in), {}) == "kept");
  int entries = 0;
  for ([[maybe_unused]] const auto& entry : fs::directory_iterator(dir)) ++entries;
  CHECK(entries == 1);  // no temporary either
  fs::remove_all(dir.parent_path());
}
