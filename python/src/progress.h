// Progress and interruption of the long calls (deformations) from Python: the library reports
// every iteration to a hook that runs on the solving thread without the GIL. The hook calls the
// caller's `progress(iteration, energy, criterion)` with the GIL held, and on the main thread
// lets Python handle a pending signal, so that Ctrl-C stops a solve. An exception raised there
// (KeyboardInterrupt, or whatever the callback raises) ends the run and reaches the caller as
// itself.
#pragma once

#include "convert.h"

#include <chrono>
#include <functional>

namespace diffreg::python {

/// The docstrings' sentence on the `progress` argument.
inline constexpr const char* kProgressDoc =
    "progress: None or a callable progress(iteration, energy, criterion), called after every "
    "iteration of a deformation with its 1-based count, the energy and the stopping "
    "criterion's value (NaN where not measured yet: a first step from the rest shape or a given "
    "shape); an "
    "exception it raises ends the run and is raised by this call. On "
    "the main thread Ctrl-C (KeyboardInterrupt) stops a running deformation too, at the end "
    "of an iteration.";

class PyProgress {
 public:
  /// `callback`: None or a callable (iteration, energy, criterion). Made with the GIL held, on
  /// the thread that will run the solve.
  /// \throw InvalidParameter (ValueError) when `callback` is neither None nor callable.
  explicit PyProgress(const py::object& callback);
  PyProgress(const PyProgress&) = delete;
  PyProgress& operator=(const PyProgress&) = delete;

  /// The library's progress hook (DeformationOptions::progress); valid while this object lives.
  std::function<void(int iteration, double energy, double criterion)> hook();

 private:
  void report(int iteration, double energy, double criterion);

  py::object callback_;
  bool hasCallback_ = false;
  bool mainThread_ = false;  // only the main thread handles signals
  // Without a callback, signals are looked at no more often than this: taking the GIL may wait
  // for another Python thread.
  std::chrono::steady_clock::time_point nextCheck_{};
};

}  // namespace diffreg::python
