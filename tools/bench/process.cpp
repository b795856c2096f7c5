// The benchmark's child processes (the diffreg tool, and this benchmark again in a child mode)
// and the scratch directories that hand them files.
#include <diffreg/core/error.h>
#include <diffreg/core/file.h>
#include "bench.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <string>
#include <system_error>
#include <vector>

extern char** environ;

namespace diffreg::bench {
namespace {

// The child's exit status, or -1 when it cannot be waited for.
int waitFor(pid_t pid) {
  int status = 0;
  for (;;) {
    if (::waitpid(pid, &status, 0) == pid) return status;
    if (errno != EINTR) return -1;
  }
}

}  // namespace

std::string runProcess(const std::string& program, const std::vector<std::string>& args,
                       const std::string& what) {
  std::vector<std::string> words = args;
  std::vector<char*> argv;
  for (auto& a : words) argv.push_back(a.data());
  argv.push_back(nullptr);
  // Both ends close on every path (the child's write end at its exec as well).
  struct Pipe {
    int fd[2] = {-1, -1};
    ~Pipe() {
      for (int f : fd)
        if (f >= 0) ::close(f);
    }
    void close(int end) {
      ::close(fd[end]);
      fd[end] = -1;
    }
  } pipe;
  if (::pipe2(pipe.fd, O_CLOEXEC) != 0) throw Error(what + ": pipe() failed");
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, pipe.fd[1], STDOUT_FILENO);
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, program.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  pipe.close(1);
  if (spawned != 0) throw Error(what + ": cannot start " + program);
  std::string output;
  try {
    char buffer[256];
    for (;;) {
      const ssize_t got = ::read(pipe.fd[0], buffer, sizeof buffer);
      if (got > 0)
        output.append(buffer, static_cast<size_t>(got));
      else if (got == 0 || errno != EINTR)
        break;
    }
  } catch (...) {
    pipe.close(0);  // a child still writing ends, and is waited for
    waitFor(pid);
    throw;
  }
  const int status = waitFor(pid);
  if (status == -1 || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw Error(what + ": " + program + " failed");
  return output;
}

std::string runSelf(const std::vector<std::string>& args, const std::string& what) {
  std::vector<std::string> words{"diffreg-bench"};
  words.insert(words.end(), args.begin(), args.end());
  return runProcess("/proc/self/exe", words, what);
}

ScratchDirectory::ScratchDirectory() {
  // A new directory with an unpredictable name (mkdtemp): never one left by another run.
  std::string name = (std::filesystem::temp_directory_path() / "diffreg-bench-XXXXXX").string();
  if (!::mkdtemp(name.data())) throw IoError("cannot create a directory like " + name);
  path_ = name;
}

ScratchDirectory::~ScratchDirectory() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

bool prepareToolRun(ToolRun& run) {
  run = ToolRun();
  const std::string tool = besideThisExecutable("diffreg");
  if (tool.empty() || !std::filesystem::exists(tool)) return false;
  run.tool = tool;
  run.dir = std::make_unique<ScratchDirectory>();
  const std::filesystem::path& dir = run.dir->path();
  run.handles = (dir / "handles.json").string();
  run.output = (dir / "out.ply").string();
  run.report = (dir / "report.json").string();
  return true;
}

void runToolFilter(const ToolRun& run, const std::string& filter, const std::string& what) {
  runProcess(run.tool,
             {run.tool, "-i", run.mesh, "--handles", run.handles, "--filter", filter, "-o",
              run.output, "--quiet", "--report", run.report},
             what);
}

nlohmann::json toolReport(const ToolRun& run) {
  return nlohmann::json::parse(readFileLimited(run.report, "report", 1 << 20));
}

}  // namespace diffreg::bench
