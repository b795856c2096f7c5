// Helpers for the hostile-input tests: running code in a child process under a memory limit.
#pragma once

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>

namespace diffreg::testing {

/// Runs `f` in a forked child whose address space is limited to `bytes`; true when `f`
/// returned true there (false when it returned false, crashed or ran out of memory).
template <class F>
bool inChildWithMemoryLimit(std::uint64_t bytes, F&& f) {
  const pid_t pid = ::fork();
  if (pid < 0) return false;
  if (pid == 0) {
    struct rlimit limit {};
    limit.rlim_cur = limit.rlim_max = bytes;
    ::setrlimit(RLIMIT_AS, &limit);
    bool ok = false;
    try {
      ok = f();
    } catch (...) {
      ok = false;
    }
    std::_Exit(ok ? 0 : 1);
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

}  // namespace diffreg::testing
