// parseJsonStrictly (modules/core/json.h): one JSON value, no key twice in an object, no NUL.
#include <diffreg/core/json.h>

#include <catch2/catch.hpp>

#include <stdexcept>
#include <string>

using diffreg::parseJsonStrictly;

namespace {

std::string errorOf(const std::string& text) {
  try {
    parseJsonStrictly(text);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(accepted)";
}

}  // namespace

TEST_CASE("parseJsonStrictly reads what nlohmann reads", "[core][json]") {
  const auto j = parseJsonStrictly(R"({"a": [1, {"b": 2, "c": {"b": 3}}], "b": "x"})");
  CHECK(j.at("a").at(1).at("c").at("b") == 3);
  // The same key in different objects, and an array of objects with the same keys, are fine.
  CHECK(parseJsonStrictly(R"([{"k": 1}, {"k": 2}])").size() == 2);
}

TEST_CASE("parseJsonStrictly refuses a key twice in one object", "[core][json]") {
  CHECK(errorOf(R"({"handles": [], "handles": []})") == "key 'handles' twice in one object");
  CHECK(errorOf(R"({"a": {"x": 1, "y": 2, "x": 3}})") == "key 'x' twice in one object");
  CHECK(errorOf(R"([{"k": 1, "k": 1}])") == "key 'k' twice in one object");
}

TEST_CASE("parseJsonStrictly refuses a NUL byte, which nlohmann reads as the end", "[core][json]") {
  const std::string text = std::string(R"({"a": 1})") + '\0' + "garbage";
  REQUIRE(nlohmann::json::parse(text).at("a") == 1);  // what the default parser does
  CHECK(errorOf(text) == "a NUL byte at offset 8");
}

TEST_CASE("parseJsonStrictly refuses \\u0000 in keys and strings, where messages would end",
          "[core][json]") {
  CHECK(errorOf(R"({"nam\u0000e": 1})") == "a string holds the character \\u0000 (NUL)");
  CHECK(errorOf(R"({"energy": "arap\u0000x"})") == "a string holds the character \\u0000 (NUL)");
  CHECK(errorOf(R"(["a", ["b\u0000"]])") == "a string holds the character \\u0000 (NUL)");
  CHECK(parseJsonStrictly(R"({"a\u0001": "b\u00e9"})").size() == 1);  // other escapes stay
}

TEST_CASE("parseJsonStrictly's messages drop nlohmann's prefix", "[core][json]") {
  const std::string e = errorOf("{\"a\": }");
  CHECK(e.rfind("parse error at line 1, column 7", 0) == 0);
  CHECK(e.find("json.exception") == std::string::npos);
  CHECK(errorOf("[1e400]").find("number overflow") != std::string::npos);
}
