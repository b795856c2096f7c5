#include <diffreg/solver/blas_threads.h>

#include <dlfcn.h>

#include <algorithm>
#include <mutex>

namespace diffreg {
namespace {

// OpenBLAS's run-time controls, looked up in the process (none of them is in a header the
// BLAS alternatives share). blas_thread_shutdown_ is the call OpenBLAS makes itself before a
// fork: it ends the workers, and the next threaded call starts them again.
struct OpenBlas {
  void (*setThreads)(int) = nullptr;
  int (*getThreads)() = nullptr;
  int (*shutdown)() = nullptr;
  bool usable() const { return setThreads && getThreads; }
};

const OpenBlas& openBlas() {
  static const OpenBlas api = [] {
    OpenBlas a;
    a.setThreads = reinterpret_cast<void (*)(int)>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"));
    a.getThreads = reinterpret_cast<int (*)()>(dlsym(RTLD_DEFAULT, "openblas_get_num_threads"));
    a.shutdown = reinterpret_cast<int (*)()>(dlsym(RTLD_DEFAULT, "blas_thread_shutdown_"));
    return a;
  }();
  return api;
}

struct State {
  std::mutex mutex;
  bool reserved = false;
  int started = 1;  // the BLAS's thread count before reserve()
  int scopes = 0;
};

State& state() {
  static State s;
  return s;
}

// Single-threaded, with the workers stopped so that none spins. Called with the mutex held.
void quiet(const OpenBlas& api) {
  api.setThreads(1);
  if (api.shutdown) api.shutdown();
}

}  // namespace

bool blasThreadsControllable() { return openBlas().usable(); }

void reserveBlasThreads() {
  const OpenBlas& api = openBlas();
  if (!api.usable()) return;
  State& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  if (s.reserved) return;
  s.started = std::max(1, api.getThreads());
  s.reserved = true;
  if (s.scopes == 0) quiet(api);
}

bool blasThreadsReserved() {
  State& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  return s.reserved;
}

int blasThreads() {
  const OpenBlas& api = openBlas();
  return api.usable() ? std::max(1, api.getThreads()) : 1;
}

int blasScopeThreads() {
  {
    State& s = state();
    std::lock_guard<std::mutex> lock(s.mutex);
    if (s.reserved) return s.started;
  }
  return blasThreads();
}

BlasThreadScope::BlasThreadScope(bool wanted) {
  const OpenBlas& api = openBlas();
  if (!wanted || !api.usable()) return;
  State& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  if (!s.reserved) return;
  active_ = true;
  if (s.scopes++ == 0 && s.started > 1) api.setThreads(s.started);
}

BlasThreadScope::~BlasThreadScope() {
  if (!active_) return;
  State& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  if (--s.scopes == 0) quiet(openBlas());
}

}  // namespace diffreg
