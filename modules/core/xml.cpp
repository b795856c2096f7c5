#include <diffreg/core/xml.h>

#include <diffreg/core/error.h>
#include <diffreg/core/file.h>

#include <pugixml.hpp>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <optional>
#include <vector>

// pugixml does the parsing. It is lenient where MeshLab's files must not be (it accepts
// duplicate attributes, unknown entities, '<' inside attribute values, a second root element),
// and it reports errors as a byte offset with a generic text. So the document is parsed in
// place without entity or whitespace processing: every name and value then points into the
// buffer, which gives the line of each element and of each bad entity; the checks pugixml does
// not make are done on the result, and each pugixml error is restated as before ("<b> is never
// closed", "</a> does not close <b> (line 2)", ...) from the text around its offset.
namespace diffreg {
namespace {

constexpr int kMaxDepth = 256;

/// A syntax error: where it was detected (to report the first one), where to report it.
struct Problem {
  size_t at;
  size_t pos;
  std::string message;
};

bool isSpace(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

bool isNameStart(char c) {
  const auto u = static_cast<unsigned char>(c);
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || c == '_' || c == ':' || u >= 0x80;
}

bool isNameChar(char c) { return isNameStart(c) || (c >= '0' && c <= '9') || c == '-' || c == '.'; }

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

size_t countOf(const char* text, size_t size, const char* needle) {
  size_t n = 0;
  for (const char* p = text;
       (p = static_cast<const char*>(std::memchr(p, needle[0], text + size - p))); ++p) {
    if (std::strncmp(p, needle, std::strlen(needle)) == 0) ++n;
  }
  return n;
}

/// The next node after `node` in document order; an empty node at the end.
pugi::xml_node nextNode(pugi::xml_node node) {
  if (node.first_child()) return node.first_child();
  for (; node; node = node.parent())
    if (node.next_sibling()) return node.next_sibling();
  return {};
}

class Reader {
 public:
  Reader(const std::string& text, const std::string& source)
      : s_(text), source_(source), buffer_(text.begin(), text.end()) {
    // A space after the text: pugixml sets the last byte aside while parsing in place, and a
    // name cut off by the end of the text (`<a>\n<b`) then still reads as one.
    buffer_.push_back(' ');
    buffer_.push_back('\0');
    // A UTF-8 byte order mark becomes white space outside the root element.
    if (text.compare(0, 3, "\xEF\xBB\xBF") == 0) std::fill_n(buffer_.begin(), 3, ' ');
  }

  XmlDocument read() {
    // UTF-8 only (no conversion, which would move the text), a fragment so that text outside
    // the root element is kept as a node and refused below.
    const unsigned options = pugi::parse_minimal | pugi::parse_comments | pugi::parse_cdata |
                             pugi::parse_doctype | pugi::parse_ws_pcdata | pugi::parse_fragment;
    const pugi::xml_parse_result result =
        doc_.load_buffer_inplace(buffer_.data(), s_.size() + 1, options, pugi::encoding_utf8);
    // pugixml stops at the first error it detects, but it misses some that come before it (a
    // bad entity, '<' in an attribute value): the first of both is the one reported.
    std::optional<Problem> first;
    if (!s_.empty() && s_.back() == '<')
      first =
          Problem{s_.size() - 1, s_.size(), "expected an element name, found the end of the file"};
    if (!result) {
      try {
        restate(result);
      } catch (Problem& p) {
        p.at = static_cast<size_t>(result.offset);
        if (!first || p.at < first->at) first = std::move(p);
      }
    }
    try {
      XmlDocument doc = convertDocument();
      if (!first) return doc;
    } catch (Problem& p) {
      if (!first || p.at < first->at) first = std::move(p);
    }
    throw InvalidParameter(source_ + ":" + std::to_string(lineAt(first->pos)) +
                           ": malformed XML: " + first->message);
  }

  XmlDocument convertDocument() {
    XmlDocument out;
    bool haveRoot = false;
    for (pugi::xml_node node : doc_.children()) {
      switch (node.type()) {
        case pugi::node_element:
          if (haveRoot) {
            failAt(offsetOf(node.name()) - 1, "a second root element <" + std::string(node.name()) +
                                                  "> after <" + out.root.name + ">");
          }
          out.root = convert(node, 0);
          haveRoot = true;
          break;
        case pugi::node_pcdata:
        case pugi::node_cdata: {
          const char* v = node.value();
          const char* p = v;
          while (*p && isSpace(*p)) ++p;
          if (*p || node.type() == pugi::node_cdata) {
            failAt(offsetOf(node.type() == pugi::node_cdata ? v : p) -
                       (node.type() == pugi::node_cdata ? 9 : 0),
                   haveRoot ? "text after the root element <" + out.root.name + ">"
                            : "text before the root element");
          }
          break;
        }
        case pugi::node_comment:
          checkComment(node);
          break;
        case pugi::node_doctype: {
          const size_t start = s_.rfind("<!DOCTYPE", offsetOf(node.value()));
          if (haveRoot) failAt(start, "<!DOCTYPE> after the root element");
          if (!out.doctype.empty()) failAt(start, "a second <!DOCTYPE>");
          if (!isSpace(s_[start + 9])) failAt(start + 9, "expected a space after <!DOCTYPE");
          out.doctype = doctypeName(node.value());
          if (out.doctype.empty()) {
            failAt(offsetOf(node.value()), "expected a document type name, found '" +
                                               std::string(1, s_[offsetOf(node.value())]) + "'");
          }
          break;
        }
        default:
          break;
      }
    }
    if (!haveRoot) failAt(s_.size(), "no root element");
    return out;
  }

  [[noreturn]] static void failAt(size_t pos, std::string message) {
    throw Problem{pos, pos, std::move(message)};
  }

  /// 1-based line of byte offset `pos`, counted incrementally from the last query.
  int lineAt(size_t pos) {
    pos = std::min(pos, s_.size());
    if (pos < linePos_) {
      linePos_ = 0;
      line_ = 1;
    }
    for (; linePos_ < pos; ++linePos_)
      if (s_[linePos_] == '\n') ++line_;
    return line_;
  }

  /// Byte offset in the text of a name or value pugixml parsed in place (the end of the text
  /// for an empty one, which pugixml does not point into the buffer).
  size_t offsetOf(const char* p) const {
    const std::less_equal<const char*> le;
    if (!(le(buffer_.data(), p) && le(p, buffer_.data() + s_.size()))) return s_.size();
    return static_cast<size_t>(p - buffer_.data());
  }

  static std::string doctypeName(const char* value) {
    const char* end = value;
    while (*end && isNameChar(*end)) ++end;
    return std::string(value, end);
  }

  /// Comments may not contain "--" (pugixml only looks for the closing "-->").
  void checkComment(pugi::xml_node node) {
    const char* v = node.value();
    const size_t n = std::strlen(v);
    if (const char* dashes = std::strstr(v, "--"))
      failAt(offsetOf(dashes), "'--' inside a comment");
    if (n > 0 && v[n - 1] == '-') failAt(offsetOf(v + n - 1), "'--' inside a comment");
  }

  /// Decodes the character data or attribute value `raw` (in the buffer) into `out`.
  void decode(const char* raw, bool attribute, std::string& out) {
    for (const char* p = raw; *p;) {
      if (*p != '&') {
        // Attribute-value normalisation: white space characters become spaces.
        out += attribute && (*p == '\n' || *p == '\t' || *p == '\r') ? ' ' : *p;
        ++p;
        continue;
      }
      const char* semi = std::strchr(p, ';');
      if (!semi || semi - p > 12) failAt(offsetOf(p), "'&' not starting an entity (write &amp;)");
      const std::string name(p + 1, semi);
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
        if (digits.empty() || *end != '\0' ||
            !std::isxdigit(static_cast<unsigned char>(digits[0])) || code == 0 || code > 0x10FFFF) {
          failAt(offsetOf(p), "bad character reference '&" + name + ";'");
        }
        appendUtf8(out, code);
      } else {
        failAt(offsetOf(p), "unknown entity '&" + name + ";'");
      }
      p = semi + 1;
    }
  }

  /// `node` (at `depth`, the root at 0) and its subtree as an XmlElement.
  XmlElement convert(pugi::xml_node node, int depth) {
    if (depth > kMaxDepth) {
      failAt(offsetOf(node.name()) - 1, "elements nested deeper than " + std::to_string(kMaxDepth));
    }
    XmlElement element;
    element.name = node.name();
    element.line = lineAt(offsetOf(node.name()) - 1);
    for (pugi::xml_attribute a : node.attributes()) {
      const std::string key = a.name();
      if (element.attribute(key)) {
        failAt(offsetOf(a.name()), "attribute '" + key + "' given twice in <" + element.name + ">");
      }
      if (std::strchr(a.value(), '<'))
        failAt(offsetOf(a.value()) - 1, "'<' inside an attribute value (unterminated quote?)");
      std::string value;
      decode(a.value(), true, value);
      element.attributes.emplace_back(key, std::move(value));
    }
    for (pugi::xml_node child : node.children()) {
      switch (child.type()) {
        case pugi::node_element:
          element.children.push_back(convert(child, depth + 1));
          break;
        case pugi::node_pcdata:
          decode(child.value(), false, element.text);
          break;
        case pugi::node_cdata:
          element.text += child.value();
          break;
        case pugi::node_comment:
          checkComment(child);
          break;
        default:
          break;
      }
    }
    return element;
  }

  /// The element started last in the (partial) document, and the elements open around it,
  /// outermost first.
  std::vector<pugi::xml_node> lastElementPath() const {
    std::vector<pugi::xml_node> path;
    pugi::xml_node node = doc_;
    while (true) {
      pugi::xml_node last = node.last_child();
      while (last && last.type() != pugi::node_element) last = last.previous_sibling();
      if (!last) return path;
      path.push_back(last);
      node = last;
    }
  }

  /// The innermost element still open at byte offset `pos` (before an end tag or at the end of
  /// the text): one of the elements on the path to the last one started, found by counting the
  /// end tags between that element's start and `pos`.
  pugi::xml_node openElementAt(size_t pos) const {
    const std::vector<pugi::xml_node> path = lastElementPath();
    if (path.empty()) return {};
    const pugi::xml_node last = path.back();
    const size_t start = offsetOf(last.name());
    size_t closed = countOf(s_.data() + start, pos - std::min(pos, start), "</");
    // "</" inside attribute values, comments, CDATA or processing instructions is no end tag.
    size_t tagEnd = start + std::strlen(last.name());
    for (pugi::xml_attribute a : last.attributes()) {
      closed -= countOf(a.value(), std::strlen(a.value()), "</");
      tagEnd = offsetOf(a.value()) + std::strlen(a.value()) + 1;
    }
    for (pugi::xml_node node = nextNode(last); node; node = nextNode(node)) {
      if (node.type() != pugi::node_element && offsetOf(node.value()) < pos)
        closed -= countOf(node.value(), std::strlen(node.value()), "</");
    }
    const size_t gt = s_.find('>', tagEnd);
    if (gt != std::string::npos && gt > 0 && s_[gt - 1] == '/') ++closed;  // <last/>
    if (closed >= path.size()) return {};
    return path[path.size() - 1 - closed];
  }

  /// The first problem in the start tag of `element` (pugixml found one).
  [[noreturn]] void failInStartTag(pugi::xml_node element) {
    const std::string name = element.name();
    const size_t start = offsetOf(element.name()) - 1;
    size_t pos = start + 1 + name.size();
    const auto atEnd = [&] { return pos >= s_.size(); };
    while (true) {
      const size_t before = pos;
      while (!atEnd() && isSpace(s_[pos])) ++pos;
      if (atEnd() || s_[pos] == '<') failAt(start, "unterminated start tag <" + name + ">");
      if (s_[pos] == '>' || s_.compare(pos, 2, "/>") == 0) break;
      if (before == pos) failAt(pos, "expected a space, '>' or '/>' in <" + name + ">");
      if (!isNameStart(s_[pos]))
        failAt(pos, "expected an attribute name, found '" + std::string(1, s_[pos]) + "'");
      const size_t keyStart = pos;
      while (!atEnd() && isNameChar(s_[pos])) ++pos;
      const std::string key = s_.substr(keyStart, pos - keyStart);
      while (!atEnd() && isSpace(s_[pos])) ++pos;
      if (atEnd() || s_[pos] != '=') failAt(pos, "expected '=' after attribute '" + key + "'");
      ++pos;
      while (!atEnd() && isSpace(s_[pos])) ++pos;
      if (atEnd() || (s_[pos] != '"' && s_[pos] != '\'')) {
        failAt(pos, "expected a quoted attribute value");
      }
      const size_t quote = pos++;
      while (!atEnd() && s_[pos] != s_[quote] && s_[pos] != '<') ++pos;
      if (atEnd()) failAt(quote, "unterminated attribute value");
      if (s_[pos] == '<') failAt(quote, "'<' inside an attribute value (unterminated quote?)");
      ++pos;
    }
    failAt(pos, "malformed start tag <" + name + ">");
  }

  std::string nameAt(size_t pos) const {
    size_t end = pos;
    while (end < s_.size() && isNameChar(s_[end])) ++end;
    return s_.substr(pos, end - pos);
  }

  [[noreturn]] void failUnexpectedMarkup(size_t lt) const {
    const pugi::xml_node open = openElementAt(lt);
    if (open) failAt(lt, "unexpected markup inside <" + std::string(open.name()) + ">");
    failAt(lt, "unexpected markup '" + s_.substr(lt, 9) + "'");
  }

  [[noreturn]] void failEndTagName(size_t pos) const {
    failAt(pos,
           std::string("expected an element name after '</', found ") +
               (pos >= s_.size() ? "the end of the file" : "'" + std::string(1, s_[pos]) + "'"));
  }

  /// Restates pugixml's error in the reader's own terms, at the place the problem starts.
  [[noreturn]] void restate(const pugi::xml_parse_result& result) {
    const size_t off = std::min(static_cast<size_t>(result.offset), s_.size());
    const auto before = [&](const char* markup) { return s_.rfind(markup, off); };
    switch (result.status) {
      case pugi::status_bad_comment: {
        const size_t start = before("<!--");
        if (start == std::string::npos) failUnexpectedMarkup(before("<!"));
        const size_t dashes = s_.find("--", start + 4);
        if (dashes == std::string::npos) failAt(start, "unterminated comment");
        failAt(dashes, "'--' inside a comment");
      }
      case pugi::status_bad_cdata: {
        const size_t start = before("<![CDATA[");
        if (start == std::string::npos) failUnexpectedMarkup(before("<!"));
        failAt(start, "unterminated CDATA section");
      }
      case pugi::status_bad_doctype:
        failAt(before("<!DOCTYPE"), "unterminated <!DOCTYPE");
      case pugi::status_bad_pi: {
        const size_t start = before("<?");
        if (s_.find("?>", start) == std::string::npos)
          failAt(start, "unterminated processing instruction");
        failAt(start, "malformed processing instruction");
      }
      case pugi::status_bad_start_element:
      case pugi::status_bad_attribute: {
        const std::vector<pugi::xml_node> path = lastElementPath();
        if (!path.empty()) failInStartTag(path.back());
        break;
      }
      case pugi::status_unrecognized_tag: {
        const size_t lt = off > 0 && s_[off - 1] == '<' ? off - 1 : s_.rfind('<', off);
        if (lt == std::string::npos) break;
        if (lt + 1 < s_.size() && s_[lt + 1] == '!') failUnexpectedMarkup(lt);
        failAt(lt + 1,
               lt + 1 >= s_.size()
                   ? std::string("expected an element name, found the end of the file")
                   : "expected an element name, found '" + std::string(1, s_[lt + 1]) + "'");
      }
      case pugi::status_bad_end_element: {
        const size_t name = before("</") + 2;
        if (nameAt(name).empty()) failEndTagName(name);
        failAt(off, "expected '>' to end </" + nameAt(name) + ">");
      }
      case pugi::status_end_element_mismatch: {
        const bool endTag = off >= 2 && s_.compare(off - 2, 2, "</") == 0;
        if (endTag) {
          const std::string closing = nameAt(off);
          if (closing.empty()) failEndTagName(off);
          size_t gt = off + closing.size();
          while (gt < s_.size() && isSpace(s_[gt])) ++gt;
          if (gt >= s_.size() || s_[gt] != '>')
            failAt(gt, "expected '>' to end </" + closing + ">");
        }
        const pugi::xml_node open = openElementAt(endTag ? off - 2 : s_.size());
        if (!open) break;
        const std::string name = open.name();
        const size_t openStart = offsetOf(open.name()) - 1;
        if (!endTag) failAt(openStart, "<" + name + "> is never closed");
        failAt(off, "</" + nameAt(off) + "> does not close <" + name + "> (line " +
                        std::to_string(lineAt(openStart)) + ")");
      }
      default:
        break;
    }
    failAt(off, std::string(result.description()));
  }

  const std::string& s_;
  const std::string& source_;
  std::vector<char> buffer_;  ///< the text, parsed in place: names and values point into it
  pugi::xml_document doc_;
  size_t linePos_ = 0;
  int line_ = 1;
};

}  // namespace

const std::string* XmlElement::attribute(const std::string& key) const {
  for (const auto& [k, v] : attributes)
    if (k == key) return &v;
  return nullptr;
}

XmlDocument parseXml(const std::string& text, const std::string& source) {
  return Reader(text, source).read();
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
