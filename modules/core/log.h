// Warnings and progress go to stderr through one switch so that --quiet silences them.
#pragma once

#include <set>
#include <string>
#include <vector>

namespace diffreg {

/// Prints "diffreg: warning: <message>" on stderr unless quiet mode is on, or hands the message
/// to this thread's WarningCollector when one is alive (quiet or not).
void warn(const std::string& message);

/// While alive, collects the warnings warn() is given on the thread that made it, instead of
/// printing them: a host with its own warnings (the Python module: Python's `warnings`) passes
/// them on. Collectors nest (the innermost one collects); warnings on other threads print.
class WarningCollector {
 public:
  WarningCollector();
  ~WarningCollector();
  WarningCollector(const WarningCollector&) = delete;
  WarningCollector& operator=(const WarningCollector&) = delete;
  /// The messages collected so far, in order; the collector keeps collecting.
  std::vector<std::string> take();

 private:
  friend void warn(const std::string& message);
  std::vector<std::string> messages_;
  WarningCollector* outer_;
};

/// warn() for what a step's parameters earn whatever the data (a parameter that has no effect):
/// the same step run again says it again, so inside a ParameterWarningsOnce scope it is said
/// once. Warnings about results (a run that did not converge) go through warn().
void warnParameter(const std::string& message);

/// While alive, a warnParameter() message already given on the thread that made it since it was
/// made is not given again: a run of several variants of one step (compare's columns) says each
/// such thing once. warn() is never dropped.
class ParameterWarningsOnce {
 public:
  ParameterWarningsOnce();
  ~ParameterWarningsOnce();
  ParameterWarningsOnce(const ParameterWarningsOnce&) = delete;
  ParameterWarningsOnce& operator=(const ParameterWarningsOnce&) = delete;

 private:
  friend void warnParameter(const std::string& message);
  std::set<std::string> given_;
  ParameterWarningsOnce* outer_;
};

/// Prints "diffreg: <message>" on stderr unless quiet mode is on.
void info(const std::string& message);
void setQuiet(bool quiet);
bool quiet();

}  // namespace diffreg
