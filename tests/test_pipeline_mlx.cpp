// MeshLab FilterScripts: every registered filter with its defaults round-trips through the
// .mlx writer and reader; MeshLab's own way of writing (attribute order, enum indices, comments)
// is read; every bad script is one line naming the file, the line and the valid choices.
#include <diffreg/pipeline/mlx.h>

#include <diffreg/core/error.h>
#include <diffreg/mesh/shapes.h>
#include <diffreg/pipeline/pipeline.h>
#include "plugins.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>

#include <unistd.h>

using namespace diffreg;
namespace fs = std::filesystem;

namespace {

/// A filter with one parameter of every type, to test the mapping independently of the
/// built-in filters.
class AllTypes : public Filter {
 public:
  std::string name() const override { return "all_types"; }
  std::string description() const override { return "test"; }
  std::vector<ParamSpec> params() const override {
    std::vector<ParamSpec> specs(6);
    specs[0].name = "free";  // unbounded: RichFloat
    specs[0].type = ParamType::Float;
    specs[0].defaultValue = "-2.5";
    specs[1].name = "bounded";  // both bounds finite: RichAbsPerc
    specs[1].type = ParamType::Float;
    specs[1].defaultValue = "0.25";
    specs[1].min = 0.0;
    specs[1].max = 2.0;
    specs[2].name = "count";
    specs[2].type = ParamType::Int;
    specs[2].defaultValue = "3";
    specs[2].min = 1;
    specs[2].max = 9;
    specs[3].name = "flag";
    specs[3].type = ParamType::Bool;
    specs[3].defaultValue = "true";
    specs[4].name = "mode";
    specs[4].type = ParamType::Enum;
    specs[4].defaultValue = "beta";
    specs[4].choices = {"alpha", "beta", "gamma"};
    specs[5].name = "label";
    specs[5].type = ParamType::String;
    specs[5].defaultValue = "a \"quoted\" <tag> & 'more'";
    specs[5].help = "help with <markup> & \"quotes\"";
    return specs;
  }
  FilterResult apply(Document&, const ParamMap&) const override { return {}; }
};

class NoParams : public Filter {
 public:
  std::string name() const override { return "no_params"; }
  std::string description() const override { return "test"; }
  std::vector<ParamSpec> params() const override { return {}; }
  FilterResult apply(Document&, const ParamMap&) const override { return {}; }
};

const Registry& testRegistry() {
  static const Registry registry = [] {
    Registry r;
    r.add(std::make_unique<AllTypes>());
    r.add(std::make_unique<NoParams>());
    return r;
  }();
  return registry;
}

/// The canonical text of every parameter of `filter` with `values` given.
std::map<std::string, std::string> canonical(const Registry& registry, const std::string& filter,
                                             const std::map<std::string, std::string>& values) {
  return ParamMap(filter, registry.get(filter).params(), values).text();
}

/// The message of the InvalidParameter that parsing `text` throws ("" when none).
std::string errorOf(const std::string& text, const Registry& registry = testRegistry()) {
  try {
    parseFilterScript(text, "s.mlx", registry);
  } catch (const InvalidParameter& e) {
    return e.what();
  }
  return "";
}

std::string script(const std::string& params, const std::string& filter = "all_types") {
  return "<!DOCTYPE FilterScript>\n<FilterScript>\n <filter name=\"" + filter + "\">\n" + params +
         "\n </filter>\n</FilterScript>\n";
}

}  // namespace

TEST_CASE("every registered filter with its defaults round-trips through .mlx", "[pipeline][mlx]") {
  const Registry& registry = Registry::builtin();
  const std::string text = defaultFilterScript(registry);
  CHECK(text.rfind("<!DOCTYPE FilterScript>\n<FilterScript>\n", 0) == 0);
  const std::vector<Step> steps = parseFilterScript(text, "defaults.mlx", registry);
  const auto names = registry.names();
  REQUIRE(steps.size() == names.size());
  for (size_t i = 0; i < steps.size(); ++i) {
    INFO(names[i]);
    CHECK(steps[i].filter == names[i]);
    // Every parameter is present in the script, at its default, in canonical text.
    CHECK(steps[i].values == canonical(registry, names[i], {}));
    CHECK(steps[i].values.size() == registry.get(names[i]).params().size());
  }
  // Writing the steps read back gives the same script.
  CHECK(writeFilterScript(steps, registry) == text);
  // The built-in parameters need these MeshLab types, and the script uses each of them.
  for (const char* type : {"RichAbsPerc", "RichInt", "RichBool", "RichEnum", "RichString"}) {
    INFO(type);
    CHECK(text.find(std::string("type=\"") + type + "\"") != std::string::npos);
  }
}

TEST_CASE(".mlx maps every parameter type to MeshLab's and back", "[pipeline][mlx]") {
  const Registry& registry = testRegistry();
  const std::string text = defaultFilterScript(registry);
  CHECK(text.find("name=\"free\" type=\"RichFloat\" value=\"-2.5\"") != std::string::npos);
  CHECK(text.find("name=\"bounded\" type=\"RichAbsPerc\" value=\"0.25\" min=\"0\" max=\"2\"") !=
        std::string::npos);
  CHECK(text.find("name=\"count\" type=\"RichInt\" value=\"3\"") != std::string::npos);
  CHECK(text.find("name=\"flag\" type=\"RichBool\" value=\"true\"") != std::string::npos);
  // Enum: the index into the choices, which are listed as enum_val0..N.
  CHECK(text.find("name=\"mode\" type=\"RichEnum\" value=\"1\" enum_cardinality=\"3\" "
                  "enum_val0=\"alpha\" enum_val1=\"beta\" enum_val2=\"gamma\"") !=
        std::string::npos);
  CHECK(text.find("type=\"RichString\" value=\"a &quot;quoted&quot; &lt;tag&gt; &amp; 'more'\"") !=
        std::string::npos);
  CHECK(text.find(" <filter name=\"no_params\">\n </filter>\n") != std::string::npos);

  SECTION("defaults") {
    const auto steps = parseFilterScript(text, "t.mlx", registry);
    REQUIRE(steps.size() == 2);
    CHECK(steps[0].values == canonical(registry, "all_types", {}));
    CHECK(steps[1].filter == "no_params");
    CHECK(steps[1].values.empty());
  }
  SECTION("values other than the defaults, and the same filter twice") {
    const std::vector<Step> in = {
        {"all_types",
         {{"free", "0.30000000000000004"},  // needs all 17 digits
          {"bounded", "2"},
          {"count", "9"},
          {"flag", "false"},
          {"mode", "gamma"},
          {"label", "line\nbreak\ttab & <>"}}},
        {"all_types", {{"free", "1e-300"}, {"mode", "alpha"}, {"label", ""}}},
    };
    const auto out = parseFilterScript(writeFilterScript(in, registry), "t.mlx", registry);
    REQUIRE(out.size() == 2);
    for (size_t i = 0; i < 2; ++i) {
      CHECK(out[i].filter == "all_types");
      CHECK(out[i].values == canonical(registry, "all_types", in[i].values));
    }
    CHECK(std::stod(out[0].values.at("free")) == 0.30000000000000004);
    CHECK(out[0].values.at("label") == "line\nbreak\ttab & <>");
    CHECK(out[1].values.at("mode") == "alpha");
  }
}

TEST_CASE(".mlx reads scripts written the way MeshLab writes them", "[pipeline][mlx]") {
  const Registry& registry = testRegistry();
  // MeshLab's attribute order (value, type, description, tooltip, name), an XML declaration,
  // comments, single quotes, parameters left out (defaults), RichDynamicFloat for a float.
  const std::string text =
      "<?xml version=\"1.0\"?>\n"
      "<!DOCTYPE FilterScript>\n"
      "<FilterScript>\n"
      " <!-- smoothing first -->\n"
      " <filter name=\"all_types\">\n"
      "  <Param value=\"0.5\" type=\"RichDynamicFloat\" min=\"0\" max=\"1\" description=\"B\" "
      "tooltip=\"\" name=\"bounded\"/>\n"
      "  <Param value='2' type='RichEnum' enum_cardinality='3' enum_val0='alpha' "
      "enum_val1='beta' enum_val2='gamma' name='mode'/>\n"
      "  <Param value=\"TRUE\" type=\"RichBool\" name=\"flag\"/>\n"
      " </filter>\n"
      " <filter name=\"no_params\"/>\n"
      "</FilterScript>\n";
  const auto steps = parseFilterScript(text, "meshlab.mlx", registry);
  REQUIRE(steps.size() == 2);
  CHECK(steps[0].values ==
        std::map<std::string, std::string>{{"bounded", "0.5"}, {"mode", "gamma"}, {"flag", "true"}});
  CHECK(steps[1].filter == "no_params");

  SECTION("an enum is taken by its index when the script lists no names") {
    const auto s = parseFilterScript(script("<Param name=\"mode\" type=\"RichEnum\" value=\"0\"/>"),
                                     "s.mlx", registry);
    CHECK(s[0].values.at("mode") == "alpha");
  }
  SECTION("an enum is taken by its name when the script lists the choices in another order") {
    const auto s = parseFilterScript(
        script("<Param name=\"mode\" type=\"RichEnum\" value=\"0\" enum_cardinality=\"2\" "
               "enum_val0=\"gamma\" enum_val1=\"alpha\"/>"),
        "s.mlx", registry);
    CHECK(s[0].values.at("mode") == "gamma");
  }
  SECTION("a float may be written as RichFloat or RichAbsPerc whatever its range") {
    const auto s = parseFilterScript(
        script("<Param name=\"bounded\" type=\"RichFloat\" value=\"1.5\"/>\n"
               "<Param name=\"free\" type=\"RichAbsPerc\" value=\"-7\" min=\"-10\" max=\"10\"/>"),
        "s.mlx", registry);
    CHECK(s[0].values.at("bounded") == "1.5");
    CHECK(s[0].values.at("free") == "-7");
  }
  SECTION("an empty script is an empty pipeline") {
    CHECK(parseFilterScript("<!DOCTYPE FilterScript>\n<FilterScript/>\n", "e.mlx", registry)
              .empty());
  }
}

TEST_CASE("bad .mlx scripts: one line naming the file, the line and the valid choices",
          "[pipeline][mlx]") {
  struct Case {
    std::string text;
    std::vector<std::string> needles;
  };
  const Case cases[] = {
      {script("  <Param name=\"count\" type=\"RichInt\" value=\"3\">"),
       {"s.mlx:", "malformed XML", "</filter> does not close <Param>"}},
      {"<!DOCTYPE PickedPoints>\n<PickedPoints/>\n",
       {"s.mlx:2: ", "root element is <PickedPoints>", "<FilterScript>"}},
      {script("", "smooth"),
       {"s.mlx:3: ", "unknown filter 'smooth'", "filters: all_types, no_params"}},
      {"<FilterScript>\n<filter/>\n</FilterScript>", {"s.mlx:2: ", "<filter> without a name"}},
      {"<FilterScript>\n<xmlfilter name=\"x\"/>\n</FilterScript>", {"s.mlx:2: ", "<xmlfilter>"}},
      {"<FilterScript>\n<Param name=\"x\"/>\n</FilterScript>",
       {"s.mlx:2: ", "unexpected <Param> inside <FilterScript>"}},
      {script("<param name=\"count\" type=\"RichInt\" value=\"3\"/>"),
       {"s.mlx:4: ", "unexpected <param>", "expected <Param>"}},
      {script("<Param name=\"size\" type=\"RichInt\" value=\"3\"/>"),
       {"s.mlx:4: ", "filter all_types has no parameter 'size'",
        "parameters: free, bounded, count, flag, mode, label"}},
      {script("<Param name=\"x\" type=\"RichInt\" value=\"3\"/>", "no_params"),
       {"has no parameter 'x'", "it takes no parameters"}},
      {script("<Param name=\"count\" type=\"RichInt\"/>"),
       {"s.mlx:4: ", "<Param> without a value attribute"}},
      {script("<Param name=\"count\" type=\"RichFloat\" value=\"3\"/>"),
       {"s.mlx:4: ", "parameter 'count' has type RichFloat; expected RichInt (int in [1, 9])"}},
      {script("<Param name=\"bounded\" type=\"RichInt\" value=\"1\"/>"),
       {"has type RichInt; expected RichFloat or RichAbsPerc or RichDynamicFloat"}},
      {script("<Param name=\"mode\" type=\"RichString\" value=\"alpha\"/>"),
       {"expected RichEnum (enum: alpha | beta | gamma)"}},
      {script("<Param name=\"count\" type=\"RichInt\" value=\"10\"/>"),
       {"s.mlx:4: ", "filter all_types: parameter 'count' = '10' is out of range [1, 9]"}},
      {script("<Param name=\"count\" type=\"RichInt\" value=\"2.5\"/>"), {"is not an integer"}},
      {script("<Param name=\"bounded\" type=\"RichAbsPerc\" value=\"3\" min=\"0\" max=\"4\"/>"),
       {"'bounded' = '3' is out of range [0, 2]"}},
      {script("<Param name=\"bounded\" type=\"RichAbsPerc\" value=\"1.5\" min=\"0\" max=\"1\"/>"),
       {"'bounded' = '1.5' is outside the script's own range [0, 1]"}},
      {script("<Param name=\"bounded\" type=\"RichAbsPerc\" value=\"1\" min=\"zero\" max=\"1\"/>"),
       {"min=\"zero\", which is not a number"}},
      {script("<Param name=\"free\" type=\"RichFloat\" value=\"fast\"/>"), {"is not a number"}},
      {script("<Param name=\"flag\" type=\"RichBool\" value=\"maybe\"/>"),
       {"'flag' = 'maybe' is not one of: true, false"}},
      {script("<Param name=\"mode\" type=\"RichEnum\" value=\"3\"/>"),
       {"s.mlx:4: ",
        "'mode' = '3' is not an index of the choices (0 = alpha, 1 = beta, 2 = gamma)"}},
      {script("<Param name=\"mode\" type=\"RichEnum\" value=\"beta\"/>"),
       {"is not an index of the choices (0 = alpha, 1 = beta, 2 = gamma)"}},
      {script("<Param name=\"mode\" type=\"RichEnum\" value=\"1\" enum_val1=\"delta\"/>"),
       {"names the choice 'delta' (enum_val1), which is not one of: alpha, beta, gamma"}},
      // The script's own count of its choices bounds the index.
      {script("<Param name=\"mode\" type=\"RichEnum\" value=\"2\" enum_cardinality=\"2\" "
              "enum_val0=\"alpha\" enum_val1=\"beta\" enum_val2=\"gamma\"/>"),
       {"'mode' = '2' is not an index below its enum_cardinality 2"}},
      {script("<Param name=\"mode\" type=\"RichEnum\" value=\"0\" enum_cardinality=\"many\"/>"),
       {"enum_cardinality=\"many\", which is not a count"}},
      {script("<Param name=\"count\" type=\"RichInt\" value=\"3\"/>\n"
              "<Param name=\"count\" type=\"RichInt\" value=\"4\"/>"),
       {"s.mlx:5: ", "parameter 'count' given twice"}},
  };
  for (const auto& c : cases) {
    INFO(c.text);
    const std::string what = errorOf(c.text);
    INFO(what);
    REQUIRE_FALSE(what.empty());
    CHECK(what.find('\n') == std::string::npos);
    for (const auto& needle : c.needles) CHECK(what.find(needle) != std::string::npos);
  }
}

TEST_CASE(
    "what a pipeline's check finds in a script's step names the script and its <filter> "
    "line",
    "[pipeline][mlx]") {
  Document doc;
  doc.mesh = makeRectangle(1.0, 1.0, 2, 2);
  doc.rest = doc.mesh.positions();
  const auto stepsOf = [](const std::string& body) {
    return parseFilterScript(
        "<!DOCTYPE FilterScript>\n<FilterScript>\n" + body + "</FilterScript>\n", "s.mlx",
        Registry::builtin());
  };
  // A parameter only the filter's own check requires (render's file).
  {
    Pipeline pipeline;
    for (const Step& step : stepsOf(" <filter name=\"measure\"/>\n <filter name=\"render\"/>\n"))
      pipeline.add(step);
    CHECK_THROWS_MATCHES(
        pipeline.check(doc), InvalidParameter,
        Catch::Matchers::Message("s.mlx:4: filter render: parameter 'file' is required (the PNG "
                                 "to write)"));
  }
  // A property nothing before the step produces: the same type, the line in front.
  {
    Pipeline pipeline;
    for (const Step& step :
         stepsOf(" <filter name=\"render\">\n  <Param name=\"file\" type=\"RichString\" "
                 "value=\"x.png\"/>\n  <Param name=\"property\" type=\"RichEnum\" value=\"1\" "
                 "enum_val1=\"distortion\" enum_cardinality=\"4\"/>\n </filter>\n"))
      pipeline.add(step);
    CHECK_THROWS_AS(pipeline.check(doc), MissingProperty);
    CHECK_THROWS_WITH(pipeline.check(doc), Catch::Matchers::StartsWith("s.mlx:3: step 1 "));
  }
  // The same steps built in code: no origin, the message as it was.
  Pipeline inCode;
  inCode.add("render");
  CHECK_THROWS_WITH(inCode.check(doc),
                    Catch::Matchers::StartsWith("filter render: parameter 'file' is required"));
}

TEST_CASE("readFilterScript reads a file and names a missing one", "[pipeline][mlx]") {
  const fs::path dir = fs::temp_directory_path() / ("diffreg-mlx-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string path = (dir / "defaults.mlx").string();
  std::ofstream(path) << defaultFilterScript();
  CHECK(readFilterScript(path).size() == Registry::builtin().names().size());
  try {
    readFilterScript((dir / "missing.mlx").string());
    FAIL("no error");
  } catch (const IoError& e) {
    CHECK(std::string(e.what()).find("missing.mlx': no such file") != std::string::npos);
  }
  std::ofstream(dir / "bad.mlx") << "<FilterScript>\n <filter name=\"deform\">\n";
  try {
    readFilterScript((dir / "bad.mlx").string());
    FAIL("no error");
  } catch (const InvalidParameter& e) {
    CHECK(std::string(e.what()).rfind((dir / "bad.mlx").string() + ":2: malformed XML", 0) == 0);
  }
  fs::remove_all(dir);
}

TEST_CASE("a pipeline read from .mlx is the pipeline built in code", "[pipeline][mlx]") {
  Pipeline inCode;
  inCode.add("diffuse_weights", {{"t", "0.02"}, {"order", "first"}})
      .add("deform", {{"energy", "asap"}, {"regularization", "nonuniform"}})
      .add("measure");
  Pipeline fromScript;
  for (const Step& step : parseFilterScript(writeFilterScript(inCode.steps()), "p.mlx"))
    fromScript.add(step.filter, step.values);
  REQUIRE(fromScript.steps().size() == 3);
  const Registry& registry = Registry::builtin();
  for (size_t i = 0; i < 3; ++i) {
    const Step& a = inCode.steps()[i];
    const Step& b = fromScript.steps()[i];
    CHECK(a.filter == b.filter);
    CHECK(canonical(registry, a.filter, a.values) == canonical(registry, b.filter, b.values));
  }
  // The checks before work see the same thing: both need handles.
  Document doc;
  doc.mesh = makeRectangle(1.0, 1.0, 2, 2);
  doc.rest = doc.mesh.positions();
  CHECK_THROWS_WITH(fromScript.check(doc), Catch::Contains("needs handles"));
}
