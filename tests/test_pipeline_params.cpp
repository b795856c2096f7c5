// Parameter tables, ParamMap validation and canonical text, filter specs and the Registry.
#include <diffreg/pipeline/filter.h>
#include <diffreg/pipeline/params.h>

#include <diffreg/core/error.h>

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdlib>
#include <random>

using namespace diffreg;

namespace {

std::vector<ParamSpec> table() {
  std::vector<ParamSpec> specs(5);
  specs[0] = {"t", ParamType::Float, "0.01", 1e-12, 1e6, {}, "time"};
  specs[1] = {"steps", ParamType::Int, "100", 1, 100000, {}, "steps"};
  specs[2] = {"flag", ParamType::Bool, "false", -1e300, 1e300, {}, "a switch"};
  specs[3] = {"order", ParamType::Enum, "second",
              -1e300,  1e300,           {"first", "second", "implicit_euler"},
              "scheme"};
  specs[4] = {"label", ParamType::String, "", -1e300, 1e300, {}, "free text"};
  return specs;
}

ParamMap make(const std::map<std::string, std::string>& values) {
  return ParamMap("f", table(), values);
}

std::string errorOf(const std::map<std::string, std::string>& values) {
  try {
    make(values);
  } catch (const InvalidParameter& e) {
    return e.what();
  }
  return "";
}

class Dummy : public Filter {
 public:
  Dummy(std::string name, std::vector<ParamSpec> specs = {})
      : name_(std::move(name)), specs_(std::move(specs)) {}
  std::string name() const override { return name_; }
  std::string description() const override { return "test filter"; }
  std::vector<ParamSpec> params() const override { return specs_; }
  FilterResult apply(Document&, const ParamMap&) const override { return {}; }

 private:
  std::string name_;
  std::vector<ParamSpec> specs_;
};

}  // namespace

TEST_CASE("ParamMap fills in every default as canonical text") {
  const ParamMap p = make({});
  REQUIRE(p.text().size() == 5);
  CHECK(p.text().at("t") == "0.01");
  CHECK(p.text().at("steps") == "100");
  CHECK(p.text().at("flag") == "false");
  CHECK(p.text().at("order") == "second");
  CHECK(p.text().at("label") == "");
  CHECK(p.getFloat("t") == 0.01);
  CHECK(p.getInt("steps") == 100);
  CHECK_FALSE(p.getBool("flag"));
  CHECK(p.getString("order") == "second");
}

TEST_CASE("ParamMap parses each type and stores canonical text") {
  const ParamMap p = make(
      {{"t", "1e-3"}, {"steps", "+7"}, {"flag", "YES"}, {"order", "first"}, {"label", "a b=c"}});
  CHECK(p.getFloat("t") == 0.001);
  CHECK(p.text().at("t") == "0.001");
  CHECK(p.getInt("steps") == 7);
  CHECK(p.text().at("steps") == "7");
  CHECK(p.getBool("flag"));
  CHECK(p.text().at("flag") == "true");
  CHECK(p.getString("order") == "first");
  CHECK(p.getString("label") == "a b=c");

  for (const char* yes : {"true", "1", "yes", "True"}) CHECK(make({{"flag", yes}}).getBool("flag"));
  for (const char* no : {"false", "0", "no", "NO"})
    CHECK_FALSE(make({{"flag", no}}).getBool("flag"));
}

TEST_CASE("ParamMap canonical text reads back to the same map") {
  const ParamMap p = make({{"t", "0.123456789012345678"}, {"steps", "00042"}, {"flag", "1"}});
  const ParamMap q = make(p.text());
  CHECK(q.text() == p.text());
  CHECK(q.getFloat("t") == p.getFloat("t"));
}

TEST_CASE("Float and Int ranges are inclusive") {
  CHECK(make({{"t", "1e-12"}}).getFloat("t") == 1e-12);
  CHECK(make({{"t", "1e6"}}).getFloat("t") == 1e6);
  CHECK(make({{"steps", "1"}}).getInt("steps") == 1);
  CHECK(make({{"steps", "100000"}}).getInt("steps") == 100000);
}

TEST_CASE("ParamMap errors are one line naming filter, parameter and value") {
  CHECK(errorOf({{"t", "abc"}}) == "filter f: parameter 't' = 'abc' is not a number");
  CHECK(errorOf({{"t", "0.01x"}}) == "filter f: parameter 't' = '0.01x' is not a number");
  CHECK(errorOf({{"t", ""}}) == "filter f: parameter 't' = '' is not a number");
  CHECK(errorOf({{"t", " 0.01"}}) == "filter f: parameter 't' = ' 0.01' is not a number");
  CHECK(errorOf({{"t", "nan"}}) == "filter f: parameter 't' = 'nan' is not a finite number");
  CHECK(errorOf({{"t", "inf"}}) == "filter f: parameter 't' = 'inf' is not a finite number");
  CHECK(errorOf({{"t", "1e999"}}) == "filter f: parameter 't' = '1e999' is not a finite number");
  CHECK(errorOf({{"t", "-1"}}) == "filter f: parameter 't' = '-1' is out of range [1e-12, 1e6]");
  CHECK(errorOf({{"t", "2e6"}}) == "filter f: parameter 't' = '2e6' is out of range [1e-12, 1e6]");
  CHECK(errorOf({{"steps", "3.5"}}) == "filter f: parameter 'steps' = '3.5' is not an integer");
  CHECK(errorOf({{"steps", "1e3"}}) == "filter f: parameter 'steps' = '1e3' is not an integer");
  CHECK(errorOf({{"steps", "0"}}) ==
        "filter f: parameter 'steps' = '0' is out of range [1, 100000]");
  CHECK(errorOf({{"steps", "99999999999999999999"}}) ==
        "filter f: parameter 'steps' = '99999999999999999999' is out of range [1, 100000]");
  CHECK(errorOf({{"flag", "maybe"}}) ==
        "filter f: parameter 'flag' = 'maybe' is not one of: true, false, 1, 0, yes, no");
  CHECK(errorOf({{"order", "third"}}) ==
        "filter f: parameter 'order' = 'third' is not one of: first, second, implicit_euler");
  CHECK(errorOf({{"order", "Second"}}) ==
        "filter f: parameter 'order' = 'Second' is not one of: first, second, implicit_euler");
  CHECK(errorOf({{"tt", "1"}}) ==
        "filter f has no parameter 'tt' (parameters: t, steps, flag, order, label)");
  CHECK_THROWS_WITH(ParamMap("g", {}, {{"x", "1"}}),
                    "filter g has no parameter 'x' (it takes no parameters)");
  // A NUL byte would end the number and the message: refused, shown.
  using namespace std::string_literals;
  CHECK(errorOf({{"t", "0.5\0junk"s}}) ==
        "filter f: parameter 't' = '0.5\\x00junk' has a NUL byte");
  CHECK(errorOf({{"label", "a\0b"s}}) == "filter f: parameter 'label' = 'a\\x00b' has a NUL byte");
}

TEST_CASE("Reading an undeclared parameter is a logic error, not a user error") {
  const ParamMap p = make({});
  CHECK_THROWS_AS(p.getFloat("nope"), std::logic_error);
}

TEST_CASE("formatNumber gives the shortest text that reads back exactly") {
  CHECK(formatNumber(0.01) == "0.01");
  CHECK(formatNumber(1e6) == "1e6");
  CHECK(formatNumber(1e-12) == "1e-12");
  CHECK(formatNumber(100) == "100");
  CHECK(formatNumber(0.001) == "0.001");
  CHECK(formatNumber(1e-4) == "0.0001");
  CHECK(formatNumber(1e-5) == "1e-5");
  CHECK(formatNumber(1e5) == "1e5");
  CHECK(formatNumber(123456) == "123456");
  CHECK(formatNumber(-2.5) == "-2.5");
  CHECK(formatNumber(0.1 + 0.2) == "0.30000000000000004");
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> mantissa(-1.0, 1.0);
  std::uniform_int_distribution<int> exponent(-300, 300);
  for (int i = 0; i < 1000; ++i) {
    const double v = std::ldexp(mantissa(rng), exponent(rng));
    REQUIRE(std::strtod(formatNumber(v).c_str(), nullptr) == v);
  }
}

TEST_CASE("parseFilterSpec splits a name and key=value tokens") {
  const auto [name, values] = parseFilterSpec("  diffuse_weights t=0.01\torder=second  ");
  CHECK(name == "diffuse_weights");
  CHECK(values == std::map<std::string, std::string>{{"t", "0.01"}, {"order", "second"}});

  const auto quoted = parseFilterSpec("render path='my dir/out.png' title=\"a b\" empty=");
  CHECK(quoted.second.at("path") == "my dir/out.png");
  CHECK(quoted.second.at("title") == "a b");
  CHECK(quoted.second.at("empty") == "");
  CHECK(parseFilterSpec("measure").second.empty());
}

TEST_CASE("parseFilterSpec rejects malformed specs") {
  CHECK_THROWS_WITH(parseFilterSpec("diffuse_weights t 0.01"),
                    "filter diffuse_weights: 't' is not of the form key=value");
  CHECK_THROWS_WITH(parseFilterSpec("diffuse_weights =3"),
                    "filter diffuse_weights: '=3' is not of the form key=value");
  CHECK_THROWS_WITH(parseFilterSpec("diffuse_weights t=1 t=2"),
                    "filter diffuse_weights: parameter 't' given twice");
  CHECK_THROWS_AS(parseFilterSpec("   "), InvalidParameter);
  CHECK_THROWS_AS(parseFilterSpec("t=0.01"), InvalidParameter);
  CHECK_THROWS_AS(parseFilterSpec("f x='open"), InvalidParameter);
  CHECK_THROWS_WITH(parseFilterSpec(std::string("f t=1\0x", 7)),
                    "filter 'f t=1\\x00x': the specification has a NUL byte");
}

TEST_CASE("Registry: sorted names, lookup, duplicates and bad tables") {
  Registry registry;
  registry.add(std::make_unique<Dummy>("zeta"));
  registry.add(std::make_unique<Dummy>("alpha", table()));
  CHECK(registry.names() == std::vector<std::string>{"alpha", "zeta"});
  CHECK(registry.has("zeta"));
  CHECK_FALSE(registry.has("beta"));
  CHECK(registry.get("alpha").params().size() == 5);
  CHECK_THROWS_WITH(registry.get("beta"), "unknown filter 'beta' (filters: alpha, zeta)");
  CHECK_THROWS_AS(registry.get("beta"), InvalidParameter);

  CHECK_THROWS_AS(registry.add(std::make_unique<Dummy>("zeta")), std::logic_error);
  CHECK_THROWS_AS(registry.add(nullptr), std::logic_error);
  CHECK_THROWS_AS(registry.add(std::make_unique<Dummy>("has space")), std::logic_error);
  auto badDefault = table();
  badDefault[0].defaultValue = "-1";
  CHECK_THROWS_AS(registry.add(std::make_unique<Dummy>("bad", badDefault)), std::logic_error);
  auto twice = table();
  twice[1].name = "t";
  CHECK_THROWS_AS(registry.add(std::make_unique<Dummy>("twice", twice)), std::logic_error);
  CHECK(registry.names().size() == 2);
}
