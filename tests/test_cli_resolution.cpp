// diffreg resolution: the paper's resolution experiment (Fig. 9; docs/method.md, "Diffused weights"
// "Units of t") on a shipped scenario, its picture and its errors.
#include "cli_fixture.h"
#include <diffreg/render/image.h>

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <utility>
#include <vector>

using namespace diffreg;
namespace fs = std::filesystem;

using namespace diffreg::testing;

TEST_CASE("diffreg resolution: mean_edge2 weights shrink under refinement, diagonal ones stay",
          "[cli][resolution]") {
  if (!fs::exists(DIFFREG_TOOL)) return;
  Scratch s("cli-resolution");
  const ToolRun r =
      s.run("resolution -i '" + shipped("bar.obj") + "' --handles '" + shipped("bar-bend.json") +
            "' --levels 2 -o r.png --report r.json --markdown r.md --size 300x200 -q");
  INFO(r.err);
  REQUIRE(r.code == 0);
  CHECK(r.err.empty());
  CHECK(slurp(s.dir / "r.md") == r.out);
  CHECK(lineCount(r.out) == 2 + 3 * 3);  // header, rule, three units x three levels

  const auto report = nlohmann::json::parse(slurp(s.dir / "r.json"));
  REQUIRE(report["levels"].size() == 3);
  // 1-to-4 subdivision: four times the triangles per level, old vertices kept.
  for (int level = 1; level < 3; ++level) {
    CHECK(report["levels"][level]["elements"].get<int>() ==
          4 * report["levels"][level - 1]["elements"].get<int>());
    CHECK(report["levels"][level]["vertices"].get<int>() >
          report["levels"][level - 1]["vertices"].get<int>());
  }
  const auto& absolute = report["units"]["absolute"];
  const auto& diagonal = report["units"]["diagonal"];
  const auto& edge2 = report["units"]["mean_edge2"];
  REQUIRE(absolute.size() == 3);
  REQUIRE(diagonal.size() == 3);
  REQUIRE(edge2.size() == 3);
  auto at = [](const nlohmann::json& rows, int level, const char* key) {
    return rows[level][key].get<double>();
  };

  // Level 0: the three units give the same physical t, hence the same weights.
  CHECK(at(absolute, 0, "t_absolute") == Approx(at(diagonal, 0, "t_absolute")));
  CHECK(at(edge2, 0, "t_absolute") == Approx(at(diagonal, 0, "t_absolute")));
  CHECK(at(edge2, 0, "mean") == Approx(at(diagonal, 0, "mean")));
  CHECK(at(diagonal, 0, "max_change") == 0.0);
  const double mean0 = at(diagonal, 0, "mean");
  REQUIRE(mean0 > 0.0);

  for (int level = 1; level < 3; ++level) {
    INFO("level " << level);
    // Midpoint subdivision keeps the bounding box, so absolute and diagonal t stay one t...
    CHECK(at(absolute, level, "t_absolute") == Approx(at(diagonal, level, "t_absolute")));
    CHECK(at(absolute, level, "mean") == Approx(at(diagonal, level, "mean")));
    // ... and the weights at the original vertices stay close (the mean within 25%),
    CHECK(std::abs(at(diagonal, level, "mean") - mean0) < 0.25 * mean0);
    // while the physical t of mean_edge2 drops about 4x per level (the mean edge halves) and
    // its weights shrink, as in the paper's Fig. 9.
    const double ratio = at(edge2, level - 1, "t_absolute") / at(edge2, level, "t_absolute");
    CHECK(ratio > 3.5);
    CHECK(ratio < 4.5);
    CHECK(at(edge2, level, "mean") < 0.6 * at(edge2, level - 1, "mean"));
    CHECK(at(edge2, level, "mean_change") > 2.0 * at(diagonal, level, "mean_change"));
  }
  CHECK(at(edge2, 2, "mean") < 0.3 * at(diagonal, 2, "mean"));

  // Three columns (levels) by three rows (units) of 300 x 200 with 10-pixel spacing.
  const Image picture = readPng((s.dir / "r.png").string());
  CHECK(picture.width == 3 * 300 + 4 * 10);
  CHECK(picture.height == 3 * 200 + 4 * 10);
}

TEST_CASE("diffreg resolution --up turns the 3D views: each axis its own picture",
          "[cli][resolution]") {
  if (!fs::exists(DIFFREG_TOOL)) return;
  Scratch s("cli-resolution-up");
  auto pictures = picturesByUp(s, "resolution --levels 0", {"x", "y", "z"});
  CHECK(pictures["x"] != pictures["y"]);
  CHECK(pictures["y"] != pictures["z"]);
  CHECK(pictures["x"] != pictures["z"]);
}

TEST_CASE("diffreg resolution: bad options and input exit non-zero with one line, write nothing",
          "[cli][resolution]") {
  if (!fs::exists(DIFFREG_TOOL)) return;
  Scratch s("cli-resolution");
  const std::string in = "-i '" + shipped("bar.obj") + "' ";
  const std::string h = "--handles '" + shipped("bar-bend.json") + "' ";
  const std::pair<std::string, std::string> usage[] = {
      {in + "-o r.png", "--handles"},
      {h + "-o r.png", "-i"},
      {in + h + "-o r.png --levels 9", "--levels"},
      {in + h + "-o r.png --t -1", "--t"},
      {in + h + "-o r.png --t 1e308", "--t"},
      {in + h + "-o r.png --scheme cubic", "cubic"},
      {in + h + "-o r.png --size 20x20", "--size"},
      {in + h + "-o r.png --up Y", "--up"},
      {in + h + "-o r.png --probe 100000", "--probe"},
      {in + h + "-o r.png --report r.png", "twice"},
      {in + h + "-o r.png --colour red", "colour"},
  };
  for (const auto& [args, needle] : usage) {
    INFO(args);
    const ToolRun r = s.run("resolution " + args);
    INFO(r.err);
    CHECK(r.code == 2);
    CHECK(lineCount(r.err) == 1);
    CHECK(r.err.find(needle) != std::string::npos);
    CHECK(s.files() == 0);
  }
  const std::pair<std::string, std::string> input[] = {
      {"-i missing.obj " + h + "-o r.png", "missing.obj"},
      {"-i '" + shipped("tetbar.mesh") + "' --handles '" + shipped("tetbar-bend.json") +
           "' -o r.png",
       "tet"},
      {in + h + "-o no-such-dir/r.png", "no-such-dir"},
  };
  for (const auto& [args, needle] : input) {
    INFO(args);
    const ToolRun r = s.run("resolution " + args);
    INFO(r.err);
    CHECK(r.code == 1);
    CHECK(lineCount(r.err) == 1);
    CHECK(r.err.find(needle) != std::string::npos);
    CHECK(s.files() == 0);
  }
  // A vertex that no element uses has a number but no weight: said so, not "not a vertex".
  {
    std::ifstream bar(shipped("bar.obj"));
    std::ofstream(s.dir / "stray.obj") << bar.rdbuf() << "v 1e29 1e29 0\n";
  }
  const ToolRun r = s.run("resolution -i stray.obj " + h + "-o r.png --probe 293");
  INFO(r.err);
  CHECK(r.code == 2);
  CHECK(r.err.find("--probe 293 is not part of any element") != std::string::npos);
  CHECK_FALSE(s.has("r.png"));
}
