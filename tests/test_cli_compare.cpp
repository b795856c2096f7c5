// diffreg compare: the paper's comparison on a shipped scenario, its outputs and its errors.
#include "cli_fixture.h"
#include <diffreg/render/image.h>

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

using namespace diffreg;
namespace fs = std::filesystem;

using namespace diffreg::testing;

TEST_CASE("diffreg compare: table, report and picture of none / uniform / non-uniform",
          "[cli][compare]") {
  if (!fs::exists(DIFFREG_TOOL)) return;
  Scratch s("cli-compare");
  const ToolRun r = s.run("compare -i '" + shipped("bar.obj") + "' --handles '" +
                          shipped("bar-bend.json") +
                          "' -o c.png --report c.json --markdown c.md --size 300x200 -q");
  const std::string& out = r.out;
  const std::string& err = r.err;
  INFO(err);
  REQUIRE(r.code == 0);
  CHECK(err.empty());
  CHECK(slurp(s.dir / "c.md") == out);
  CHECK(std::count(out.begin(), out.end(), '\n') == 5);  // header, rule, three variants
  for (const char* row : {"| none |", "| uniform |", "| nonuniform |"})
    CHECK(out.find(row) != std::string::npos);
  CHECK(out.find("not converged") == std::string::npos);  // every variant ran to its stop

  const auto report = nlohmann::json::parse(slurp(s.dir / "c.json"));
  REQUIRE(report["variants"].size() == 3);
  const auto& none = report["variants"][0]["metrics"];
  const auto& uniform = report["variants"][1]["metrics"];
  const auto& nonuniform = report["variants"][2]["metrics"];
  // Uniform beta defaults to the peak of the weights (the scenario's magnitudes, 0.5).
  CHECK(report["beta"].get<double>() == Approx(0.5));
  CHECK(report["peak_weight"].get<double>() == Approx(0.5));
  CHECK(none["dist"].get<double>() == 0.0);
  CHECK(uniform["D_max"].get<double>() < none["D_max"].get<double>());
  CHECK(nonuniform["D_max"].get<double>() < none["D_max"].get<double>());
  CHECK(nonuniform["D_ave"].get<double>() < uniform["D_ave"].get<double>());
  CHECK(nonuniform["dist"].get<double>() < uniform["dist"].get<double>());

  // Four panels of 300 x 200 in a 2 x 2 grid with 10-pixel spacing.
  const Image picture = readPng((s.dir / "c.png").string());
  CHECK(picture.width == 2 * 300 + 3 * 10);
  CHECK(picture.height == 2 * 200 + 3 * 10);
}

TEST_CASE(
    "diffreg compare: a variant stopped by the iteration cap says so in the table and "
    "on stderr",
    "[cli][compare]") {
  if (!fs::exists(DIFFREG_TOOL)) return;
  Scratch s("cli-compare-cap");
  const ToolRun r =
      s.run("compare -i '" + shipped("bar.obj") + "' --handles '" + shipped("bar-bend.json") +
            "' -o c.png --deform 'deform iterations=2' --size 120x100");
  INFO(r.err);
  REQUIRE(r.code == 0);
  // Each of the three rows: its iterations, then the mark.
  const std::string mark = "| 2 (not converged) |";
  size_t rows = 0;
  for (size_t at = r.out.find(mark); at != std::string::npos; at = r.out.find(mark, at + 1)) ++rows;
  CHECK(rows == 3);
  CHECK(r.err.find("deform: not converged after 2 iterations") != std::string::npos);
}

TEST_CASE("diffreg compare: a default uniform beta of 1 is said to leave no distortion term",
          "[cli][compare]") {
  if (!fs::exists(DIFFREG_TOOL)) return;
  Scratch s("cli-compare-beta1");
  // The U's handles have magnitude 1: the weights peak at 1.
  const std::string run =
      "compare -i '" + shipped("ushape.obj") + "' --handles '" + shipped("ushape-pull.json") + "'";
  const ToolRun r = s.run(run);
  INFO(r.err);
  REQUIRE(r.code == 0);
  CHECK(r.out.find("| uniform | 1.000 |") != std::string::npos);
  CHECK(r.err.find("warning: compare: the weights peak at 1, so the uniform beta is 1, where no "
                   "distortion term is left") != std::string::npos);
  // A beta given is the user's: nothing said.
  const ToolRun given = s.run(run + " --beta 1");
  REQUIRE(given.code == 0);
  CHECK(given.err.find("no distortion term") == std::string::npos);
}

TEST_CASE("diffreg compare: what the deform parameters earn is said once, not per variant",
          "[cli][compare]") {
  if (!fs::exists(DIFFREG_TOOL)) return;
  Scratch s("cli-compare-once");
  const ToolRun r =
      s.run("compare -i '" + shipped("bar.obj") + "' --handles '" + shipped("bar-bend.json") +
            "' --deform 'deform energy=dirichlet iterations=20'");
  INFO(r.err);
  REQUIRE(r.code == 0);
  const std::string said = "deform: iterations=20 is ignored";
  const size_t first = r.err.find(said);
  CHECK(first != std::string::npos);
  CHECK(r.err.find(said, first + 1) == std::string::npos);
  CHECK(r.err.find("compare: nonuniform") != std::string::npos);  // all three ran
  // What each variant's run ends with is its own, said for each even where the words agree:
  // every variant of the cylinder stops at its first global step.
  const ToolRun capped = s.run("compare -i '" + shipped("cylinder.obj") + "' --handles '" +
                               shipped("cylinder-twist.json") + "' --deform 'deform iterations=1'");
  INFO(capped.err);
  REQUIRE(capped.code == 0);
  size_t variantsSaid = 0;
  for (size_t at = capped.err.find("not converged after 1 iteration"); at != std::string::npos;
       at = capped.err.find("not converged after 1 iteration", at + 1))
    ++variantsSaid;
  CHECK(variantsSaid == 3);
}

TEST_CASE("diffreg compare --rbf clamps the summed RBF weights unless clamp is given",
          "[cli][compare]") {
  if (!fs::exists(DIFFREG_TOOL)) return;
  Scratch s("cli-compare-rbf");
  // The bar's handles at the default magnitude 1: the middle handle's Gaussian reaches the
  // others, so the plain sums exceed 1 there.
  std::string handles = slurp(shipped("bar-bend.json"));
  for (size_t at; (at = handles.find(", \"magnitude\": 0.5")) != std::string::npos;)
    handles.erase(at, std::string(", \"magnitude\": 0.5").size());
  REQUIRE(handles.find("magnitude") == std::string::npos);
  std::ofstream(s.dir / "h.json") << handles;
  const std::string run =
      "compare -i '" + shipped("bar.obj") + "' --handles h.json --size 120x100 ";
  const ToolRun r = s.run(run + "-o c.png --rbf -q");
  INFO(r.err);
  REQUIRE(r.code == 0);
  CHECK(r.out.find("| rbf |") != std::string::npos);
  CHECK(std::count(r.out.begin(), r.out.end(), '\n') == 6);  // header, rule, four variants
  // Six panels in a 3 x 2 grid: both weights (diffused and RBF) and the four variants. The
  // last slot holds a panel (five panels left it empty).
  const Image picture = readPng((s.dir / "c.png").string());
  REQUIRE(picture.width == 3 * 120 + 4 * 10);
  REQUIRE(picture.height == 2 * 100 + 3 * 10);
  int drawn = 0;
  for (int y = 10 + 110; y < 10 + 110 + 100; ++y)
    for (int x = 10 + 2 * 130; x < 10 + 2 * 130 + 120; ++x)
      if (picture.get(x, y) != colors::white) ++drawn;
  CHECK(drawn > 1000);
  // Unclamped on request: deform names the vertex farthest above 1 and the remedy.
  const ToolRun plain = s.run(run + "-o d.png --rbf 'rbf_weights clamp=false' -q");
  INFO(plain.err);
  CHECK(plain.code == 1);
  CHECK(lineCount(plain.err) == 1);
  CHECK(plain.err.find("outside [0, 1]") != std::string::npos);
  CHECK(plain.err.find("rbf_weights clamp=true") != std::string::npos);
  CHECK_FALSE(fs::exists(s.dir / "d.png"));
}

TEST_CASE("diffreg compare --up turns the 3D views: each axis its own picture, auto one of them",
          "[cli][compare]") {
  if (!fs::exists(DIFFREG_TOOL)) return;
  Scratch s("cli-compare-up");
  auto pictures = picturesByUp(s, "compare", {"auto", "x", "y", "z"});
  CHECK(pictures["x"] != pictures["y"]);
  CHECK(pictures["y"] != pictures["z"]);
  CHECK(pictures["x"] != pictures["z"]);
  CHECK((pictures["auto"] == pictures["x"] || pictures["auto"] == pictures["y"] ||
         pictures["auto"] == pictures["z"]));
}

TEST_CASE("diffreg compare: bad options exit 2 with one line and write nothing",
          "[cli][compare]") {
  if (!fs::exists(DIFFREG_TOOL)) return;
  Scratch s("cli-compare");
  const std::string in = "-i '" + shipped("bar.obj") + "' ";
  const std::string h = "--handles '" + shipped("bar-bend.json") + "' ";
  const std::pair<std::string, std::string> cases[] = {
      {in + "-o c.png", "--handles"},
      {in + h + "-o c.png --deform 'deform regularization=none'", "regularization"},
      {in + h + "-o c.png --deform 'measure'", "deform"},
      {in + h + "-o c.png --weights 'nothing t=1'", "nothing"},
      // A step that makes no weights is refused before it runs: render would write its file.
      {in + h + "-o c.png --weights 'render file=w.png property=none'", "produces no"},
      {in + h + "-o c.png --rbf 'render file=w.png property=none'", "produces no"},
      {in + h + "-o c.png --size 20x20", "--size"},
      {in + h + "-o c.png --up w", "--up"},
      {in + h + "-o c.png --beta nan", "--beta"},
      {in + h + "-o c.png --beta 1.5", "--beta"},
  };
  for (const auto& [args, needle] : cases) {
    INFO(args);
    const ToolRun r = s.run("compare " + args);
    CHECK(r.code == 2);
    INFO(r.err);
    CHECK(lineCount(r.err) == 1);
    CHECK(r.err.find(needle) != std::string::npos);
    CHECK(s.files() == 0);
  }
  // Bad filter values are found before any variant runs: no stage line, one error line.
  for (const std::string& args : {in + h + "-o c.png --rbf 'rbf_weights sigma=nan'",
                                  in + h + "-o c.png --weights 'diffuse_weights t=-1'",
                                  in + h + "-o c.png --deform 'deform iterations=0'"}) {
    INFO(args);
    const ToolRun r = s.run("compare " + args);
    CHECK(r.code == 1);
    INFO(r.err);
    CHECK(lineCount(r.err) == 1);
    CHECK(r.err.find("diffreg: error: filter ") == 0);
    CHECK(s.files() == 0);
  }
}
