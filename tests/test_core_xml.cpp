// The XML reading behind .mlx scripts and .pp picked points (pugixml): the subset MeshLab writes is
// read faithfully, and every malformed input is one line naming the source and the line.
#include <diffreg/core/error.h>
#include <diffreg/core/xml.h>

#include <catch2/catch.hpp>

#include <algorithm>
#include <string>

using namespace diffreg;

TEST_CASE("parseXml reads elements, attributes, entities, comments and the doctype",
          "[core][xml]") {
  const std::string text =
      "\xEF\xBB\xBF<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<!DOCTYPE FilterScript>\n"
      "<!-- a comment -->\n"
      "<FilterScript>\n"
      " <filter name=\"a &amp; b\">\n"
      "  <Param value='1&lt;2' type=\"RichString\" name=\"s\" tooltip=\"&quot;q&quot; &#65;&#x42;\"/>\n"
      "  <!-- <Param name=\"hidden\"/> -->\n"
      "  <Param name = \"t\"\n"
      "         value=\"x&#10;y\" />\n"
      " </filter>\n"
      " <note>text &gt; <![CDATA[<raw & text>]]></note>\n"
      "</FilterScript>\n"
      "<!-- trailing comment -->\n";
  const XmlDocument doc = parseXml(text, "s.mlx");
  CHECK(doc.doctype == "FilterScript");
  CHECK(doc.root.name == "FilterScript");
  CHECK(doc.root.line == 4);
  REQUIRE(doc.root.children.size() == 2);
  const XmlElement& filter = doc.root.children[0];
  CHECK(filter.line == 5);
  REQUIRE(filter.attribute("name"));
  CHECK(*filter.attribute("name") == "a & b");
  CHECK(filter.attribute("missing") == nullptr);
  REQUIRE(filter.children.size() == 2);  // the commented-out Param is not an element
  const XmlElement& s = filter.children[0];
  CHECK(s.line == 6);
  CHECK(*s.attribute("value") == "1<2");
  CHECK(*s.attribute("tooltip") == "\"q\" AB");
  REQUIRE(s.attributes.size() == 4);
  CHECK(s.attributes[0].first == "value");  // file order kept
  CHECK(s.attributes[3].first == "tooltip");
  CHECK(filter.children[1].line == 8);
  CHECK(*filter.children[1].attribute("value") == "x\ny");  // a character reference survives
  CHECK(doc.root.children[1].text == "text > <raw & text>");
}

TEST_CASE("xmlEscape output reads back as the same attribute value", "[core][xml]") {
  const std::string value = "a \"b\" & <c> 'd'\nline\ttab";
  const XmlDocument doc = parseXml("<r v=\"" + xmlEscape(value) + "\"/>", "mem");
  CHECK(*doc.root.attribute("v") == value);
  CHECK(xmlEscape(value).find_first_of("<>\"\n") == std::string::npos);
}

TEST_CASE("malformed XML is one line naming the source and the line", "[core][xml]") {
  const std::pair<std::string, std::string> cases[] = {
      {"<a>\n<b>\n</a>", "s.xml:3: malformed XML: </a> does not close <b> (line 2)"},
      {"<a>\n <b x=\"1\"\n", "s.xml:2: malformed XML: unterminated start tag <b>"},
      {"<a>\n <b x=\"1/>\n</a>\n", "s.xml:2: malformed XML: '<' inside an attribute value"},
      {"<a>\n<b/>\n", "s.xml:1: malformed XML: <a> is never closed"},
      {"<a x=\"1\" x=\"2\"/>", "attribute 'x' given twice"},
      {"<a x=1/>", "expected a quoted attribute value"},
      {"<a>\n\n&nbsp;</a>", "s.xml:3: malformed XML: unknown entity '&nbsp;'"},
      {"<a>AT&T</a>", "'&' not starting an entity"},
      {"<a v=\"&#0;\"/>", "bad character reference"},
      {"<a/>\n<b/>", "s.xml:2: malformed XML: a second root element <b> after <a>"},
      {"<a/>\ntext", "s.xml:2: malformed XML: text after the root element <a>"},
      {"", "s.xml:1: malformed XML: no root element"},
      {"   \n<!-- only a comment -->", "no root element"},
      {"<!-- open", "unterminated comment"},
      {"<a><!-- x -- y --></a>", "'--' inside a comment"},
      {"<a><![CDATA[x</a>", "unterminated CDATA section"},
      {"<!DOCTYPE x", "unterminated <!DOCTYPE"},
      {"<1a/>", "expected an element name"},
      {"<a b=\"1\"c=\"2\"/>", "expected a space, '>' or '/>' in <a>"},
      {"<a></b >", "</b> does not close <a>"},
  };
  for (const auto& [text, expected] : cases) {
    INFO(text);
    try {
      parseXml(text, "s.xml");
      FAIL("no error");
    } catch (const InvalidParameter& e) {
      const std::string what = e.what();
      CHECK(what.find(expected) != std::string::npos);
      CHECK(what.rfind("s.xml:", 0) == 0);
      CHECK(what.find('\n') == std::string::npos);
    }
  }
}

TEST_CASE("deep nesting is an error, not a stack overflow", "[core][xml]") {
  std::string text;
  for (int i = 0; i < 100000; ++i) text += "<a>";
  CHECK_THROWS_AS(parseXml(text, "deep.xml"), InvalidParameter);
}

TEST_CASE("readXml names a missing file", "[core][xml]") {
  try {
    readXml("/nonexistent/dir/x.mlx", "filter script");
    FAIL("no error");
  } catch (const IoError& e) {
    CHECK(std::string(e.what()) ==
          "cannot open filter script '/nonexistent/dir/x.mlx': no such file");
  }
}
