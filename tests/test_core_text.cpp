// escapeNonUtf8 (modules/core/text.h): any byte string becomes valid UTF-8, reversibly;
// terminalLine: any message becomes one bounded, inert terminal line.
#include <diffreg/core/text.h>

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <random>
#include <string>

using diffreg::escapeNonUtf8;
using diffreg::terminalLine;

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

TEST_CASE("terminalLine escapes what a terminal would act on and bounds the length",
          "[core][text]") {
  // An ESC starts a terminal escape sequence; line breaks would make a second line.
  CHECK(terminalLine("no\x1b[31m.obj") == "no\\x1b[31m.obj");
  CHECK(terminalLine("a\nb\r\tc") == "a b  c");
  CHECK(terminalLine(std::string("nul\0byte", 8)) == "nul\\x00byte");
  CHECK(terminalLine("del\x7f") == "del\\x7f");
  // C1 controls (U+009B is a one-byte CSI on some terminals) and bytes that are not UTF-8.
  CHECK(terminalLine("csi\xc2\x9b") == "csi\\xc2\\x9b");
  CHECK(terminalLine("bad\xff\xfe") == "bad\\xff\\xfe");
  // A right-to-left override would show "gpj.exe" as "exe.jpg"; a line separator breaks lines.
  CHECK(terminalLine("a\xe2\x80\xae"
                     "b") ==
        "a\\xe2\\x80\\xae"
        "b");
  CHECK(terminalLine("a\xe2\x81\xa6"
                     "b\xe2\x80\xa8"
                     "c") ==
        "a\\xe2\\x81\\xa6"
        "b\\xe2\\x80\\xa8"
        "c");
  CHECK(terminalLine("\xe2\x80\x94") == "\xe2\x80\x94");  // an em dash stays
  // Printable UTF-8 is kept as it is.
  CHECK(terminalLine("Zhu, Li, Zhang, Song \xce\xb2 = 0.5 \xe2\x80\x94 ok") ==
        "Zhu, Li, Zhang, Song \xce\xb2 = 0.5 \xe2\x80\x94 ok");
  // Long text is cut at a character boundary, and says how much is left out.
  const std::string quoted = "parameter 'reference': '" + std::string(15'000'000, 'x') + "'";
  const std::string line = terminalLine(quoted, 100);
  CHECK(line.size() < 140);
  CHECK(line.rfind("parameter 'reference': 'xxx", 0) == 0);
  CHECK(line.find("... (" + std::to_string(quoted.size() - 100) + " more bytes)") !=
        std::string::npos);
  const std::string greek = terminalLine(std::string(60, 'a') + std::string(40, '\xce'), 61);
  CHECK(greek.find("\\xce") == 60);  // the cut counts the escapes it writes
  const std::string beta = std::string(99, 'a') + "\xce\xb2";
  CHECK(terminalLine(beta, 100) == beta);  // a character is never split
}

TEST_CASE("printableAscii takes printable ASCII, spaces included, and nothing else",
          "[core][text]") {
  using diffreg::printableAscii;
  CHECK(printableAscii("diffreg:weight"));
  CHECK(printableAscii("my weight"));
  CHECK(printableAscii("~!"));
  CHECK_FALSE(printableAscii(""));
  CHECK_FALSE(printableAscii("w\xe9ight"));
  CHECK_FALSE(printableAscii("a\tb"));
  CHECK_FALSE(printableAscii("esc\x1b[31m"));
  CHECK_FALSE(printableAscii("del\x7f"));
}
