// warn() and WarningCollector (modules/core/log.h): a collector on a thread takes that thread's
// warnings instead of stderr, nested collectors take their own, other threads still print.
#include <diffreg/core/log.h>

#include <catch2/catch.hpp>

#include <iostream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

using diffreg::warn;
using diffreg::WarningCollector;

namespace {

// stderr (std::cerr) while `f` runs.
template <class F>
std::string stderrOf(F&& f) {
  std::ostringstream captured;
  std::streambuf* old = std::cerr.rdbuf(captured.rdbuf());
  f();
  std::cerr.rdbuf(old);
  return captured.str();
}

}  // namespace

TEST_CASE("a warning collector takes its thread's warnings, in order, instead of stderr",
          "[core][log]") {
  CHECK(stderrOf([] { warn("plain"); }) == "diffreg: warning: plain\n");
  std::vector<std::string> outer, inner;
  const std::string err = stderrOf([&] {
    WarningCollector collector;
    warn("one");
    {
      WarningCollector nested;
      warn("two");
      inner = nested.take();
    }
    warn("three");
    diffreg::setQuiet(true);  // quiet silences stderr, not a collector
    warn("four");
    diffreg::setQuiet(false);
    outer = collector.take();
    CHECK(collector.take().empty());  // taken once
  });
  CHECK(err.empty());
  CHECK(inner == std::vector<std::string>{"two"});
  CHECK(outer == std::vector<std::string>{"one", "three", "four"});
  // Gone with its scope: warnings print again.
  CHECK(stderrOf([] { warn("after"); }) == "diffreg: warning: after\n");
}

TEST_CASE("a parameter warning is given once while the scope lives, on its thread only",
          "[core][log]") {
  using diffreg::warnParameter;
  std::vector<std::string> collected;
  const std::string err = stderrOf([&] {
    warnParameter("before");
    {
      const diffreg::ParameterWarningsOnce once;
      warnParameter("before");  // not given in the scope yet
      warnParameter("a");
      warnParameter("b");
      warnParameter("a");
      warn("result");  // plain warnings are never dropped
      warn("result");
      std::thread other([] { warnParameter("a"); });  // another thread's are its own
      other.join();
      WarningCollector collector;  // what a collector takes is dropped alike
      warnParameter("b");
      warnParameter("c");
      collected = collector.take();
    }
    warnParameter("a");  // the scope is gone
  });
  CHECK(err ==
        "diffreg: warning: before\ndiffreg: warning: before\ndiffreg: warning: a\n"
        "diffreg: warning: b\ndiffreg: warning: result\ndiffreg: warning: result\n"
        "diffreg: warning: a\ndiffreg: warning: a\n");
  CHECK(collected == std::vector<std::string>{"c"});
}

TEST_CASE("a warning collector leaves other threads' warnings on stderr", "[core][log]") {
  std::vector<std::string> mine;
  const std::string err = stderrOf([&] {
    WarningCollector collector;
    std::thread other([] { warn("elsewhere"); });
    other.join();
    warn("here");
    mine = collector.take();
  });
  CHECK(mine == std::vector<std::string>{"here"});
  CHECK(err == "diffreg: warning: elsewhere\n");
}
