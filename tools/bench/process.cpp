// The benchmark's child processes (the diffreg tool, and this benchmark again in a child mode)
// and the scratch directories that hand them files.
#include <diffreg/core/error.h>
#include "bench.h"

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <string>
#include <system_error>
#include <vector>

extern char** environ;

namespace diffreg::bench {

std::string runProcess(const std::string& program, const std::vector<std::string>& args,
                       const std::string& what) {
  std::vector<std::string> words = args;
  std::vector<char*> argv;
  for (auto& a : words) argv.push_back(a.data());
  argv.push_back(nullptr);
  int fds[2];
  if (pipe(fds) != 0) throw Error(what + ": pipe() failed");
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, fds[1], STDOUT_FILENO);
  posix_spawn_file_actions_addclose(&actions, fds[0]);
  posix_spawn_file_actions_addclose(&actions, fds[1]);
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, program.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  close(fds[1]);
  std::string output;
  char buffer[256];
  ssize_t got = 0;
  while (spawned == 0 && (got = read(fds[0], buffer, sizeof buffer)) > 0)
    output.append(buffer, static_cast<size_t>(got));
  close(fds[0]);
  if (spawned != 0) throw Error(what + ": cannot start " + program);
  int status = 0;
  waitpid(pid, &status, 0);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw Error(what + ": " + program + " failed");
  return output;
}

std::string runSelf(const std::vector<std::string>& args, const std::string& what) {
  std::vector<std::string> words{"diffreg-bench"};
  words.insert(words.end(), args.begin(), args.end());
  return runProcess("/proc/self/exe", words, what);
}

ScratchDirectory::ScratchDirectory() {
  static std::atomic<int> made{0};
  path_ = std::filesystem::temp_directory_path() /
          ("diffreg-bench-" + std::to_string(::getpid()) + "-" + std::to_string(made++));
  std::filesystem::create_directories(path_);
}

ScratchDirectory::~ScratchDirectory() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

}  // namespace diffreg::bench
