// diffreg -s: a MeshLab FilterScript runs the same pipeline as the equivalent --filter chain,
// `diffreg filters --mlx` writes a script the tool reads back, and a bad script is one line
// naming the file with nothing written.
#include "cli_fixture.h"
#include <diffreg/mesh/io.h>
#include <diffreg/pipeline/document.h>
#include <diffreg/pipeline/pipeline.h>

#include <catch2/catch.hpp>

using namespace diffreg;
using namespace diffreg::testing;

namespace {

const char* kScript = R"(<!DOCTYPE FilterScript>
<FilterScript>
 <filter name="diffuse_weights">
  <Param name="t" type="RichFloat" value="0.01" description="time"/>
 </filter>
 <filter name="deform">
  <Param name="energy" type="RichEnum" value="0" enum_cardinality="4" enum_val0="arap"
         enum_val1="asap" enum_val2="larap" enum_val3="dirichlet"/>
  <Param name="regularization" type="RichEnum" value="2" enum_cardinality="3" enum_val0="none"
         enum_val1="uniform" enum_val2="nonuniform"/>
  <Param name="iterations" type="RichInt" value="10"/>
 </filter>
</FilterScript>
)";

}  // namespace

TEST_CASE("diffreg -s runs a MeshLab script exactly as the same --filter chain", "[cli][mlx]") {
  if (!fs::exists(DIFFREG_TOOL)) return;
  Scratch s("cli-mlx");
  std::ofstream(s.dir / "chain.mlx") << kScript;
  const std::string in =
      "-i '" + shipped("bar.obj") + "' --handles '" + shipped("bar-bend.json") + "' ";
  const ToolRun a = s.run(in + "-s chain.mlx -o script.ply -q");
  INFO(a.err);
  REQUIRE(a.code == 0);
  const ToolRun b = s.run(in +
                          "--filter 'diffuse_weights t=0.01' --filter 'deform energy=arap "
                          "regularization=nonuniform iterations=10' -o chain.ply -q");
  REQUIRE(b.code == 0);
  const std::string script = slurp(s.dir / "script.ply"), chain = slurp(s.dir / "chain.ply");
  CHECK(script.size() > 1000);
  CHECK(script == chain);

  // The same pipeline built in code: the same positions and weights (OM keeps doubles).
  REQUIRE(s.run(in + "-s chain.mlx -o script.om -q").code == 0);
  REQUIRE(s.run(in +
                "--filter 'diffuse_weights t=0.01' --filter 'deform energy=arap "
                "regularization=nonuniform iterations=10' -o chain.om -q")
              .code == 0);
  Document doc = Document::load(shipped("bar.obj"), shipped("bar-bend.json"));
  Pipeline inCode;
  inCode.add("diffuse_weights", {{"t", "0.01"}})
      .add("deform", {{"energy", "arap"}, {"regularization", "nonuniform"}, {"iterations", "10"}});
  inCode.run(doc);
  for (const char* file : {"script.om", "chain.om"}) {
    INFO(file);
    const Mesh written = readMesh((s.dir / file).string());
    REQUIRE(written.hasVertexScalar("diffreg:weight"));
    CHECK((written.positions() - doc.mesh.positions()).cwiseAbs().maxCoeff() <= 1e-12);
    CHECK((written.vertexScalar("diffreg:weight") - doc.mesh.vertexScalar("diffreg:weight"))
              .cwiseAbs()
              .maxCoeff() <= 1e-12);
  }
  // The script's filters run first, then the --filter ones.
  const ToolRun c = s.run(in + "-s chain.mlx --filter measure -o measured.ply --report r.json -q");
  INFO(c.err);
  REQUIRE(c.code == 0);
  const std::string report = slurp(s.dir / "r.json");
  CHECK(report.find("\"diffuse_weights\"") < report.find("\"deform\""));
  CHECK(report.find("\"deform\"") < report.find("\"measure\""));
}

TEST_CASE("diffreg filters --mlx is a script of every filter that the tool reads back",
          "[cli][mlx]") {
  if (!fs::exists(DIFFREG_TOOL)) return;
  Scratch s("cli-mlx");
  const ToolRun all = s.run("filters --mlx");
  REQUIRE(all.code == 0);
  const ToolRun list = s.run("filters");
  for (const char* name : {"diffuse_weights", "rbf_weights", "deform", "measure", "render"}) {
    INFO(name);
    CHECK(all.out.find("<filter name=\"" + std::string(name) + "\"") != std::string::npos);
    CHECK(list.out.find(name) != std::string::npos);
  }
  // Only the weights step of the template, run on the bar: a script the tool accepts.
  const size_t begin = all.out.find("<filter name=\"diffuse_weights\"");
  const size_t end = all.out.find("</filter>", begin) + std::string("</filter>").size();
  std::ofstream(s.dir / "w.mlx") << "<!DOCTYPE FilterScript>\n<FilterScript>\n"
                                 << all.out.substr(begin, end - begin) << "\n</FilterScript>\n";
  const ToolRun r = s.run("-i '" + shipped("bar.obj") + "' --handles '" + shipped("bar-bend.json") +
                          "' -s w.mlx -o w.ply -q");
  INFO(r.err);
  CHECK(r.code == 0);
  CHECK(s.has("w.ply"));
}

TEST_CASE("diffreg -s with a bad script: one line naming the file, nothing written",
          "[cli][mlx]") {
  if (!fs::exists(DIFFREG_TOOL)) return;
  Scratch s("cli-mlx");
  std::ofstream(s.dir / "unknown.mlx")
      << "<!DOCTYPE FilterScript>\n<FilterScript>\n <filter name=\"smooth_everything\"/>\n"
         "</FilterScript>\n";
  std::ofstream(s.dir / "broken.mlx") << "<FilterScript>\n <filter name=\"deform\">\n";
  std::ofstream(s.dir / "range.mlx")
      << "<FilterScript><filter name=\"deform\"><Param name=\"beta\" type=\"RichFloat\" "
         "value=\"3\"/></filter></FilterScript>\n";
  // A step whose file is missing fails when it runs, not in the check: still named by line.
  std::ofstream(s.dir / "absent.mlx")
      << "<FilterScript>\n <filter name=\"diffuse_weights\"/>\n <filter name=\"measure\">\n"
         "  <Param name=\"reference\" type=\"RichString\" value=\"nope.obj\"/>\n"
         " </filter>\n</FilterScript>\n";
  const std::string in =
      "-i '" + shipped("bar.obj") + "' --handles '" + shipped("bar-bend.json") + "' ";
  for (const auto& [script, needle] :
       {std::pair{"unknown.mlx", "smooth_everything"}, std::pair{"broken.mlx", "broken.mlx"},
        std::pair{"range.mlx", "beta"}, std::pair{"missing.mlx", "missing.mlx"},
        std::pair{"absent.mlx", "absent.mlx:3: filter measure: parameter 'reference'"}}) {
    INFO(script);
    const ToolRun r = s.run(in + "-s " + script + " -o out.ply");
    CHECK(r.code != 0);
    INFO(r.err);
    CHECK(lineCount(r.err) == 1);
    CHECK(r.err.find(needle) != std::string::npos);
    CHECK_FALSE(s.has("out.ply"));
  }
}
