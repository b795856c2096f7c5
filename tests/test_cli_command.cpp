// runCommand and parseCommandLine (tools/diffreg/cli.h), shared by every diffreg command: the
// one error line, its exit code, and the input an out-of-memory error names.
#include "cli.h"

#include <catch2/catch.hpp>

#include <iostream>
#include <new>
#include <sstream>
#include <string>
#include <vector>

using namespace diffreg;
namespace po = boost::program_options;

namespace {

// Runs `body` through runCommand with std::cerr captured: its exit code and what it printed.
std::pair<int, std::string> run(const std::function<int()>& body) {
  std::ostringstream captured;
  std::streambuf* const old = std::cerr.rdbuf(captured.rdbuf());
  const int code = runCommand(body);
  std::cerr.rdbuf(old);
  return {code, captured.str()};
}

// Parses `args` as a command with -i and --quiet.
po::variables_map parse(std::vector<std::string> args) {
  po::options_description options("Options");
  options.add_options()("input,i", po::value<std::string>(), "mesh")  //
      ("quiet,q", po::bool_switch(), "quiet");
  args.insert(args.begin(), "diffreg-test");
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  po::variables_map vm;
  REQUIRE(parseCommandLine(static_cast<int>(argv.size()), argv.data(), "usage", options, vm));
  return vm;
}

}  // namespace

TEST_CASE("an out-of-memory error names the input of the command", "[cli]") {
  currentInput().clear();
  auto [code, text] = run([]() -> int { throw std::bad_alloc(); });
  CHECK(code == 1);
  CHECK(text == "diffreg: error: out of memory (before reading any input)\n");

  // Every command's options go through parseCommandLine (compare, resolution, serve), which
  // records -i; before, only the filter pipeline did and the others said "before reading".
  parse({"-i", "big mesh.obj", "--quiet"});
  CHECK(currentInput() == "big mesh.obj");
  std::tie(code, text) = run([]() -> int { throw std::bad_alloc(); });
  CHECK(code == 1);
  CHECK(text == "diffreg: error: out of memory (while working on 'big mesh.obj')\n");
  currentInput().clear();
}

TEST_CASE("runCommand: usage errors exit 2, other errors 1, each one line", "[cli]") {
  auto [code, text] = run([]() -> int { throw UsageError("missing -o OUT"); });
  CHECK(code == 2);
  CHECK(text == "diffreg: error: missing -o OUT\n");
  std::tie(code, text) = run([]() -> int { throw std::runtime_error("bad\nfile"); });
  CHECK(code == 1);
  CHECK(text == "diffreg: error: bad file\n");
  std::tie(code, text) = run([] { return 0; });
  CHECK(code == 0);
  CHECK(text.empty());
}
