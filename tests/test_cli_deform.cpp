// diffreg end to end on the shipped scenarios of all three mesh kinds: diffuse_weights, deform
// and measure chained on the command line, with the report's metrics and the outputs checked;
// and the deformation's errors as one line with no output.
#include "cli_fixture.h"
#include <diffreg/mesh/io.h>

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>


using namespace diffreg;
namespace fs = std::filesystem;

using namespace diffreg::testing;

TEST_CASE("diffreg chains diffuse_weights, deform and measure on planar, surface and tet "
          "scenarios",
          "[cli][deform]") {
  if (!fs::exists(DIFFREG_TOOL)) return;
  for (const auto& [mesh, handles, outputs] :
       {std::tuple{"bar.obj", "bar-bend.json", "-o out.ply"},
        std::tuple{"cylinder.obj", "cylinder-twist.json", "-o out.ply"},
        std::tuple{"tetbar.mesh", "tetbar-bend.json", "-o out.mesh -o out.ply"}}) {
    INFO(mesh);
    Scratch s("cli-deform");
    const ToolRun r = s.run("-i '" + shipped(mesh) + "' --handles '" + shipped(handles) +
                               "' --filter 'diffuse_weights t=0.01' --filter 'deform "
                               "energy=arap regularization=nonuniform iterations=10' --filter "
                               "measure " + outputs + " --report r.json --quiet");
    INFO(r.err);
    REQUIRE(r.code == 0);
    CHECK(r.err.empty());
    const auto report = nlohmann::json::parse(slurp(s.dir / "r.json"));
    const auto& filters = report["filters"];
    REQUIRE(filters.size() == 3);
    CHECK(filters[1]["name"] == "deform");
    CHECK(filters[1]["energies"].size() >= 1);
    CHECK(filters[1]["iterations"].get<int>() <= 10);
    const auto& metrics = filters[2]["metrics"];
    for (const char* key : {"D_max", "D_ave", "D_dev", "dist", "inverted", "energy"}) {
      INFO(key);
      REQUIRE(metrics.contains(key));
      CHECK(metrics[key].is_number());
    }
    CHECK(metrics["D_max"].get<double>() >= metrics["D_ave"].get<double>());
    CHECK(metrics["dist"].get<double>() > 0.0);

    // The PLY carries the distortion as face quality; a tet mesh's PLY is its boundary.
    const Mesh written = readMesh((s.dir / "out.ply").string());
    const std::string ply = slurp(s.dir / "out.ply");
    const std::string header = ply.substr(0, ply.find("end_header"));
    CHECK(header.find("element face") != std::string::npos);
    CHECK(header.substr(header.find("element face")).find("property double quality") !=
          std::string::npos);
    CHECK(written.numVertices() > 0);
    if (std::string(mesh) == "tetbar.mesh") {
      const Mesh tets = readMesh((s.dir / "out.mesh").string());
      CHECK(tets.isTet());
      CHECK(tets.numElements() == 1536);
    }
  }
}

TEST_CASE("diffreg: deformation errors are one line and write nothing", "[cli][deform]") {
  if (!fs::exists(DIFFREG_TOOL)) return;
  Scratch s("cli-deform");
  // Two separate triangles; the handle pins only the first: the second is free.
  std::ofstream(s.dir / "two.off") << "OFF\n6 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 0\n4 0 0\n3 1 0\n"
                                      "3 0 1 2\n3 3 4 5\n";
  std::ofstream(s.dir / "h.json") << R"({"handles": [{"vertices": [0, 1], "translate": [1, 0]}]})";
  std::ofstream(s.dir / "bar.json") << slurp(shipped("bar-bend.json"));
  const std::string bar = "-i '" + shipped("bar.obj") + "' --handles bar.json ";
  const std::pair<std::string, std::string> cases[] = {
      {"-i two.off --handles h.json --filter deform -o out.ply", "component"},
      {bar + "--filter 'deform beta=2' -o out.ply", "beta"},
      {bar + "--filter 'deform energy=rigid' -o out.ply", "energy"},
      {bar + "--filter 'deform local_step=foo' -o out.ply", "'local_step' = 'foo' is not one of: exact, reference"},
      {bar + "--filter 'deform acceleration=fast' -o out.ply", "lbfgs, anderson, none"},
      {bar + "--filter 'deform regularization=nonuniform' -o out.ply", "diffreg:weight"},
      {bar + "--filter deform --filter 'measure reference=nothere.ply' -o out.ply", "nothere.ply"},
      {bar + "--filter deform -o out.ply -o out.ply", "twice"},
      // render has written its picture by the time measure fails: it must not stay.
      {bar + "--filter deform --filter 'render file=pic.png property=distortion' --filter "
             "'measure reference=nothere.ply' -o out.ply",
       "nothere.ply"},
      {bar + "--filter deform --filter 'render file=pic.png property=distortion' --filter "
             "'render file=pic.png property=smoothness' -o out.ply",
       "twice"},
      {bar + "--filter deform --filter 'render file=nodir/pic.png property=distortion' -o out.ply",
       "nodir"},
  };
  for (const auto& [args, needle] : cases) {
    INFO(args);
    const ToolRun r = s.run(args);
    CHECK(r.code != 0);
    INFO(r.err);
    CHECK(lineCount(r.err) == 1);
    CHECK(r.err.find(needle) != std::string::npos);
    CHECK_FALSE(s.has("out.ply"));
    CHECK_FALSE(s.has("out.png"));
    CHECK_FALSE(s.has("pic.png"));
    CHECK(s.files() == 3);  // the inputs only: no staged leftovers
  }
}

TEST_CASE("diffreg reports a long deformation's iterations on stderr unless quiet",
          "[cli][deform]") {
  if (!fs::exists(DIFFREG_TOOL)) return;
  Scratch s("cli-deform");
  const std::string run = "-i '" + shipped("bar.obj") + "' --handles '" + shipped("bar-bend.json") +
                          "' --filter 'deform iterations=5 tolerance=0' -o out.ply";
  // --progress-after 0: every run counts as long; lines are at most one a second.
  const ToolRun verbose = s.run(run + " --progress-after 0");
  REQUIRE(verbose.code == 0);
  INFO(verbose.err);
  CHECK(verbose.err.find("diffreg: deform: iteration 1, energy ") != std::string::npos);
  CHECK(verbose.err.find(", criterion ") != std::string::npos);
  // A surface starts from the rest shape: its first step's criterion is not measured, not 0.
  const ToolRun surface =
      s.run("-i '" + shipped("cylinder.obj") + "' --handles '" + shipped("cylinder-twist.json") +
            "' --filter 'deform iterations=1' -o one.ply --progress-after 0");
  REQUIRE(surface.code == 0);
  CHECK(surface.err.find("deform: iteration 1, energy ") != std::string::npos);
  CHECK(surface.err.find(", criterion not measured yet\n") != std::string::npos);
  CHECK(surface.err.find("not converged after 1 iteration: the first global step") !=
        std::string::npos);
  const ToolRun quiet = s.run(run + " --progress-after 0 -q");
  REQUIRE(quiet.code == 0);
  CHECK(quiet.err.empty());
  // A short run under the default threshold of one second prints no iteration, only that it
  // stopped unconverged (with tolerance=0 a run goes on until only rounding is left).
  const ToolRun shortRun = s.run(run);
  REQUIRE(shortRun.code == 0);
  CHECK(shortRun.err.find("deform: iteration") == std::string::npos);
  CHECK(shortRun.err.find("warning: deform: not converged after 5 iterations") !=
        std::string::npos);
  CHECK(shortRun.err.find("tolerance=0") != std::string::npos);
}

TEST_CASE(
    "diffreg says on stderr when a deformation stops at its iteration cap, with how far "
    "it is, and nothing when it converges",
    "[cli][deform]") {
  if (!fs::exists(DIFFREG_TOOL)) return;
  Scratch s("cli-deform-cap");
  const std::string in =
      "-i '" + shipped("bar.obj") + "' --handles '" + shipped("bar-bend.json") + "' -o out.ply ";
  const ToolRun capped = s.run(in + "--filter 'deform iterations=3' --report r.json");
  INFO(capped.err);
  REQUIRE(capped.code == 0);
  const auto report = nlohmann::json::parse(slurp(s.dir / "r.json"));
  const auto& deform = report["filters"][0];
  REQUIRE_FALSE(deform["converged"].get<bool>());
  // One line: the count, the criterion as the report has it (two digits), the remedy.
  char gain[32];
  std::snprintf(gain, sizeof gain, "%.2g", deform["criterion"].get<double>());
  CHECK(capped.err.find("diffreg: warning: deform: not converged after 3 iterations: the last "
                        "one changed the energy by " +
                        std::string(gain) + " of it (above tolerance=1e-7; raise iterations)\n") !=
        std::string::npos);
  const ToolRun quiet = s.run(in + "--filter 'deform iterations=3' -q");
  REQUIRE(quiet.code == 0);
  CHECK(quiet.err.empty());
  const ToolRun converged = s.run(in + "--filter deform --report r.json");
  REQUIRE(converged.code == 0);
  const auto done = nlohmann::json::parse(slurp(s.dir / "r.json"))["filters"][0];
  CHECK(done["converged"].get<bool>());
  CHECK(converged.err.find("not converged") == std::string::npos);
  // A converged L-BFGS run ends with the plain iteration that confirms the stop; capped just
  // before it, the last iteration is within the tolerance and the warning says what is missing.
  const int last = done["iterations"].get<int>();
  const ToolRun early = s.run(in + "--filter 'deform iterations=" + std::to_string(last - 1) + "'");
  INFO(early.err);
  REQUIRE(early.code == 0);
  CHECK(early.err.find("within tolerance=1e-7, but the cap came before the plain iteration that "
                       "confirms convergence") != std::string::npos);
}
