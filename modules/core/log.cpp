#include <diffreg/core/log.h>
#include <diffreg/core/text.h>

#include <atomic>
#include <iostream>

namespace diffreg {
namespace {
std::atomic<bool> g_quiet{false};
thread_local WarningCollector* t_collector = nullptr;
thread_local ParameterWarningsOnce* t_parameterScope = nullptr;
}  // namespace

void warn(const std::string& message) {
  if (t_collector)
    t_collector->messages_.push_back(message);
  else if (!g_quiet)
    std::cerr << "diffreg: warning: " << terminalLine(message) << "\n";
}

WarningCollector::WarningCollector() : outer_(t_collector) { t_collector = this; }
WarningCollector::~WarningCollector() { t_collector = outer_; }

void warnParameter(const std::string& message) {
  if (t_parameterScope && !t_parameterScope->given_.insert(message).second) return;
  warn(message);
}

ParameterWarningsOnce::ParameterWarningsOnce() : outer_(t_parameterScope) {
  t_parameterScope = this;
}
ParameterWarningsOnce::~ParameterWarningsOnce() { t_parameterScope = outer_; }

std::vector<std::string> WarningCollector::take() {
  std::vector<std::string> out;
  out.swap(messages_);
  return out;
}
void info(const std::string& message) {
  if (!g_quiet) std::cerr << "diffreg: " << terminalLine(message) << "\n";
}
void setQuiet(bool quiet) { g_quiet = quiet; }
bool quiet() { return g_quiet; }

}  // namespace diffreg
