// Strict XML reading for the files MeshLab writes (.mlx filter scripts, .pp picked points), on
// pugixml: elements, attributes, text, comments, processing instructions, CDATA and a DOCTYPE
// line; the five predefined entities and numeric character references. No namespaces, no
// entities declared in the DOCTYPE, no validation. Every error is one line "source:line: ...".
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace diffreg {

struct XmlElement {
  std::string name;
  std::vector<std::pair<std::string, std::string>> attributes;  ///< in file order, decoded
  std::vector<XmlElement> children;                             ///< child elements only
  std::string text;  ///< character data directly inside the element, decoded and concatenated
  int line = 0;      ///< line of the start tag (1-based)

  /// The attribute's value, or nullptr when the element has no such attribute.
  const std::string* attribute(const std::string& key) const;
};

struct XmlDocument {
  std::string doctype;  ///< the name after <!DOCTYPE, "" when there is none
  XmlElement root;
};

/// Parses XML text. `source` names it in messages (usually the file path).
/// \throw InvalidParameter "source:line: malformed XML: ..." for any syntax error (unterminated
///        tag, mismatched end tag, duplicate attribute, bad entity, missing or second root, ...).
XmlDocument parseXml(const std::string& text, const std::string& source);

/// Reads and parses an XML file.
/// \throw IoError when the file is missing, a directory or unreadable.
/// \throw InvalidParameter as parseXml, naming `path`.
XmlDocument readXml(const std::string& path, const std::string& what = "XML file");

/// `text` escaped for an attribute value in double quotes (& < > " and control characters).
std::string xmlEscape(const std::string& text);

}  // namespace diffreg
