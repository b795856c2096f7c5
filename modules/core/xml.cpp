#include "core/xml.h"

#include "core/error.h"
#include "core/file.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace diffreg {
namespace {

constexpr int kMaxDepth = 256;

bool isSpace(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

bool isNameStart(char c) {
  const auto u = static_cast<unsigned char>(c);
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || c == '_' || c == ':' || u >= 0x80;
}

bool isNameChar(char c) {
  return isNameStart(c) || (c >= '0' && c <= '9') || c == '-' || c == '.';
}

/// Appends the UTF-8 encoding of `code` to `out`.
void appendUtf8(std::string& out, unsigned long code) {
  if (code < 0x80) {
    out += static_cast<char>(code);
  } else if (code < 0x800) {
    out += static_cast<char>(0xC0 | (code >> 6));
    out += static_cast<char>(0x80 | (code & 0x3F));
  } else if (code < 0x10000) {
    out += static_cast<char>(0xE0 | (code >> 12));
    out += static_cast<char>(0x80 | ((code >> 6) & 0x3F));
    out += static_cast<char>(0x80 | (code & 0x3F));
  } else {
    out += static_cast<char>(0xF0 | (code >> 18));
    out += static_cast<char>(0x80 | ((code >> 12) & 0x3F));
    out += static_cast<char>(0x80 | ((code >> 6) & 0x3F));
    out += static_cast<char>(0x80 | (code & 0x3F));
  }
}

class Parser {
 public:
  Parser(const std::string& text, const std::string& source) : s_(text), source_(source) {}

  XmlDocument parse() {
    XmlDocument doc;
    if (s_.compare(0, 3, "\xEF\xBB\xBF") == 0) pos_ = 3;  // UTF-8 byte order mark
    bool haveRoot = false;
    while (true) {
      skipSpace();
      if (atEnd()) break;
      if (peek() != '<') {
        fail(haveRoot ? "text after the root element <" + doc.root.name + ">"
                      : "text before the root element");
      }
      if (starts("<?")) {
        skipPast("?>", "processing instruction");
      } else if (starts("<!--")) {
        skipComment();
      } else if (starts("<!DOCTYPE")) {
        if (haveRoot) fail("<!DOCTYPE> after the root element");
        if (!doc.doctype.empty()) fail("a second <!DOCTYPE>");
        doc.doctype = parseDoctype();
      } else if (starts("<!")) {
        fail("unexpected markup '" + s_.substr(pos_, 9) + "'");
      } else {
        if (haveRoot) fail("a second root element <" + peekName() + "> after <" + doc.root.name + ">");
        doc.root = parseElement(0);
        haveRoot = true;
      }
    }
    if (!haveRoot) fail("no root element");
    return doc;
  }

 private:
  [[noreturn]] void fail(const std::string& message) const { failAt(pos_, message); }
  [[noreturn]] void failAt(size_t pos, const std::string& message) const {
    throw InvalidParameter(source_ + ":" + std::to_string(lineAt(pos)) +
                           ": malformed XML: " + message);
  }

  /// 1-based line of byte offset `pos`, counted incrementally from the last query.
  int lineAt(size_t pos) const {
    pos = std::min(pos, s_.size());
    if (pos < linePos_) {
      linePos_ = 0;
      line_ = 1;
    }
    for (; linePos_ < pos; ++linePos_)
      if (s_[linePos_] == '\n') ++line_;
    return line_;
  }

  bool atEnd() const { return pos_ >= s_.size(); }
  char peek() const { return atEnd() ? '\0' : s_[pos_]; }
  bool starts(const char* prefix) const { return s_.compare(pos_, std::strlen(prefix), prefix) == 0; }
  void skipSpace() {
    while (!atEnd() && isSpace(s_[pos_])) ++pos_;
  }

  void skipPast(const char* terminator, const char* what) {
    const size_t start = pos_;
    const size_t end = s_.find(terminator, pos_);
    if (end == std::string::npos) failAt(start, std::string("unterminated ") + what);
    pos_ = end + std::strlen(terminator);
  }

  void skipComment() {
    const size_t start = pos_;
    pos_ += 4;
    const size_t end = s_.find("--", pos_);
    if (end == std::string::npos) failAt(start, "unterminated comment");
    if (s_.compare(end, 3, "-->") != 0) failAt(end, "'--' inside a comment");
    pos_ = end + 3;
  }

  std::string peekName() const {
    size_t p = pos_ + 1;
    while (p < s_.size() && isNameChar(s_[p])) ++p;
    return s_.substr(pos_ + 1, p - pos_ - 1);
  }

  std::string parseName(const char* what) {
    if (atEnd() || !isNameStart(peek())) {
      fail(std::string("expected ") + what +
           (atEnd() ? ", found the end of the file" : ", found '" + std::string(1, peek()) + "'"));
    }
    const size_t start = pos_;
    while (!atEnd() && isNameChar(s_[pos_])) ++pos_;
    return s_.substr(start, pos_ - start);
  }

  std::string parseDoctype() {
    const size_t start = pos_;
    pos_ += 9;  // "<!DOCTYPE"
    if (atEnd() || !isSpace(peek())) fail("expected a space after <!DOCTYPE");
    skipSpace();
    const std::string name = parseName("a document type name");
    // Skip any external id and internal subset up to the closing '>'.
    int brackets = 0;
    char quote = 0;
    for (; !atEnd(); ++pos_) {
      const char c = s_[pos_];
      if (quote) {
        if (c == quote) quote = 0;
      } else if (c == '"' || c == '\'') {
        quote = c;
      } else if (c == '[') {
        ++brackets;
      } else if (c == ']') {
        --brackets;
      } else if (c == '>' && brackets <= 0) {
        ++pos_;
        return name;
      }
    }
    failAt(start, "unterminated <!DOCTYPE");
  }

  /// Decodes the entity starting at s_[pos_] == '&' and appends it to `out`.
  void parseEntity(std::string& out) {
    const size_t start = pos_;
    const size_t semi = s_.find(';', pos_);
    if (semi == std::string::npos || semi - pos_ > 12) failAt(start, "'&' not starting an entity (write &amp;)");
    const std::string name = s_.substr(pos_ + 1, semi - pos_ - 1);
    pos_ = semi + 1;
    if (name == "lt") {
      out += '<';
    } else if (name == "gt") {
      out += '>';
    } else if (name == "amp") {
      out += '&';
    } else if (name == "quot") {
      out += '"';
    } else if (name == "apos") {
      out += '\'';
    } else if (name.size() > 1 && name[0] == '#') {
      const bool hex = name[1] == 'x' || name[1] == 'X';
      const std::string digits = name.substr(hex ? 2 : 1);
      char* end = nullptr;
      const unsigned long code = std::strtoul(digits.c_str(), &end, hex ? 16 : 10);
      if (digits.empty() || *end != '\0' || !std::isxdigit(static_cast<unsigned char>(digits[0])) ||
          code == 0 || code > 0x10FFFF) {
        failAt(start, "bad character reference '&" + name + ";'");
      }
      appendUtf8(out, code);
    } else {
      failAt(start, "unknown entity '&" + name + ";'");
    }
  }

  std::string parseAttributeValue() {
    const char quote = peek();
    if (quote != '"' && quote != '\'') fail("expected a quoted attribute value");
    const size_t start = pos_++;
    std::string value;
    while (true) {
      if (atEnd()) failAt(start, "unterminated attribute value");
      const char c = s_[pos_];
      if (c == quote) {
        ++pos_;
        return value;
      }
      if (c == '<') failAt(start, "'<' inside an attribute value (unterminated quote?)");
      if (c == '&') {
        parseEntity(value);
      } else {
        // Attribute-value normalisation: white space characters become spaces.
        value += (c == '\n' || c == '\t' || c == '\r') ? ' ' : c;
        ++pos_;
      }
    }
  }

  XmlElement parseElement(int depth) {
    if (depth > kMaxDepth) fail("elements nested deeper than " + std::to_string(kMaxDepth));
    XmlElement element;
    const size_t start = pos_;
    element.line = lineAt(pos_);
    ++pos_;  // '<'
    element.name = parseName("an element name");
    // Attributes, then '>' or '/>'.
    while (true) {
      const size_t before = pos_;
      skipSpace();
      if (atEnd()) failAt(start, "unterminated start tag <" + element.name + ">");
      if (starts("/>")) {
        pos_ += 2;
        return element;
      }
      if (peek() == '>') {
        ++pos_;
        break;
      }
      if (peek() == '<') failAt(start, "unterminated start tag <" + element.name + ">");
      if (before == pos_) fail("expected a space, '>' or '/>' in <" + element.name + ">");
      const std::string key = parseName("an attribute name");
      skipSpace();
      if (peek() != '=') fail("expected '=' after attribute '" + key + "'");
      ++pos_;
      skipSpace();
      std::string value = parseAttributeValue();
      if (element.attribute(key)) fail("attribute '" + key + "' given twice in <" + element.name + ">");
      element.attributes.emplace_back(key, std::move(value));
    }
    // Content up to the matching end tag.
    while (true) {
      if (atEnd()) failAt(start, "<" + element.name + "> is never closed");
      const char c = s_[pos_];
      if (c == '&') {
        parseEntity(element.text);
      } else if (c != '<') {
        element.text += c;
        ++pos_;
      } else if (starts("</")) {
        pos_ += 2;
        const std::string name = parseName("an element name after '</'");
        skipSpace();
        if (peek() != '>') fail("expected '>' to end </" + name + ">");
        ++pos_;
        if (name != element.name) {
          failAt(pos_ - 1, "</" + name + "> does not close <" + element.name + "> (line " +
                               std::to_string(element.line) + ")");
        }
        return element;
      } else if (starts("<!--")) {
        skipComment();
      } else if (starts("<![CDATA[")) {
        const size_t open = pos_;
        const size_t end = s_.find("]]>", pos_ + 9);
        if (end == std::string::npos) failAt(open, "unterminated CDATA section");
        element.text += s_.substr(pos_ + 9, end - pos_ - 9);
        pos_ = end + 3;
      } else if (starts("<?")) {
        skipPast("?>", "processing instruction");
      } else if (starts("<!")) {
        fail("unexpected markup inside <" + element.name + ">");
      } else {
        element.children.push_back(parseElement(depth + 1));
      }
    }
  }

  const std::string& s_;
  const std::string& source_;
  size_t pos_ = 0;
  mutable size_t linePos_ = 0;
  mutable int line_ = 1;
};

}  // namespace

const std::string* XmlElement::attribute(const std::string& key) const {
  for (const auto& [k, v] : attributes)
    if (k == key) return &v;
  return nullptr;
}

XmlDocument parseXml(const std::string& text, const std::string& source) {
  return Parser(text, source).parse();
}

XmlDocument readXml(const std::string& path, const std::string& what) {
  return parseXml(readFileLimited(path, what, limits::textBytes), path);
}

std::string xmlEscape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "&#%d;", c);
          out += buf;
        } else {
          out += c;
        }
    }
  }
  return out;
}

}  // namespace diffreg
