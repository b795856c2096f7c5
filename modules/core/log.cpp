#include <diffreg/core/log.h>
#include <diffreg/core/text.h>

#include <atomic>
#include <iostream>

namespace diffreg {
namespace {
std::atomic<bool> g_quiet{false};
}

void warn(const std::string& message) {
  if (!g_quiet) std::cerr << "diffreg: warning: " << terminalLine(message) << "\n";
}
void info(const std::string& message) {
  if (!g_quiet) std::cerr << "diffreg: " << terminalLine(message) << "\n";
}
void setQuiet(bool quiet) { g_quiet = quiet; }
bool quiet() { return g_quiet; }

}  // namespace diffreg
