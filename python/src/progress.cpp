#include "progress.h"

#include <diffreg/core/error.h>

namespace diffreg::python {

namespace {

constexpr std::chrono::milliseconds kSignalInterval{50};

}  // namespace

PyProgress::PyProgress(const py::object& callback) : callback_(callback) {
  hasCallback_ = !callback.is_none();
  if (hasCallback_ && !PyCallable_Check(callback.ptr()))
    throw InvalidParameter(
        "progress must be None or a callable (iteration, energy, criterion), "
        "not " +
        py::str(py::type::of(callback).attr("__name__")).cast<std::string>());
  const py::module_ threading = py::module_::import("threading");
  mainThread_ = threading.attr("get_ident")().equal(threading.attr("main_thread")().attr("ident"));
}

std::function<void(int, double, double)> PyProgress::hook() {
  return [this](int iteration, double energy, double criterion) {
    report(iteration, energy, criterion);
  };
}

void PyProgress::report(int iteration, double energy, double criterion) {
  if (!hasCallback_) {
    if (!mainThread_) return;
    const auto now = std::chrono::steady_clock::now();
    if (now < nextCheck_) return;
    nextCheck_ = now + kSignalInterval;
  }
  const py::gil_scoped_acquire gil;
  if (hasCallback_) callback_(iteration, energy, criterion);  // raises error_already_set
  if (mainThread_ && PyErr_CheckSignals() != 0) throw py::error_already_set();
}

}  // namespace diffreg::python
