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

/// While alive, a warning already given on the thread that made it since it was made is not
/// given again: a run of several variants of one step (compare's columns) says each thing once.
class RepeatedWarningsDropped {
 public:
  RepeatedWarningsDropped();
  ~RepeatedWarningsDropped();
  RepeatedWarningsDropped(const RepeatedWarningsDropped&) = delete;
  RepeatedWarningsDropped& operator=(const RepeatedWarningsDropped&) = delete;

 private:
  friend void warn(const std::string& message);
  std::set<std::string> given_;
  RepeatedWarningsDropped* outer_;
};

/// Prints "diffreg: <message>" on stderr unless quiet mode is on.
void info(const std::string& message);
void setQuiet(bool quiet);
bool quiet();

}  // namespace diffreg
