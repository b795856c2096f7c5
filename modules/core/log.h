// Warnings and progress go to stderr through one switch so that --quiet silences them.
#pragma once

#include <string>

namespace diffreg {

/// Prints "diffreg: warning: <message>" on stderr unless quiet mode is on.
void warn(const std::string& message);
/// Prints "diffreg: <message>" on stderr unless quiet mode is on.
void info(const std::string& message);
void setQuiet(bool quiet);
bool quiet();

}  // namespace diffreg
