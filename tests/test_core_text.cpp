// escapeNonUtf8 (modules/core/text.h): any byte string becomes valid UTF-8, reversibly.
#include <diffreg/core/text.h>

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <random>
#include <string>

using diffreg::escapeNonUtf8;

TEST_CASE("escapeNonUtf8 keeps UTF-8 and escapes every other byte", "[core][text]") {
  CHECK(escapeNonUtf8("bar.obj") == "bar.obj");
  CHECK(escapeNonUtf8("k\xc3\xa4se \xe2\x82\xac") == "k\xc3\xa4se \xe2\x82\xac");  // käse €
  CHECK(escapeNonUtf8("bar\xff.obj") == "bar\\xff.obj");
  CHECK(escapeNonUtf8("\xc3") == "\\xc3");                    // truncated sequence
  CHECK(escapeNonUtf8("\xc0\xaf") == "\\xc0\\xaf");           // overlong '/'
  CHECK(escapeNonUtf8("\xed\xa0\x80") == "\\xed\\xa0\\x80");  // a surrogate
  CHECK(escapeNonUtf8("a\\xff") == "a\\\\xff");               // an escape-like name stays apart
}

TEST_CASE("escapeNonUtf8 output always serializes as JSON", "[core][text]") {
  std::mt19937 rng(3);
  for (int i = 0; i < 2000; ++i) {
    std::string bytes(rng() % 24, '\0');
    for (char& c : bytes) c = static_cast<char>(rng() % 256);
    const std::string text = escapeNonUtf8(bytes);
    CHECK_NOTHROW(nlohmann::json(text).dump());
  }
}
