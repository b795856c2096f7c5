#include <diffreg/core/text.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace diffreg {
namespace {

/// Length of the valid UTF-8 sequence starting at s[i], 0 when there is none.
size_t sequence(const std::string& s, size_t i) {
  const auto byte = [&](size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned char c = byte(i);
  if (c < 0x80) return 1;
  size_t n = 0;
  unsigned min = 0, code = 0;
  if (c >= 0xc2 && c <= 0xdf)
    n = 2, min = 0x80, code = c & 0x1f;
  else if (c >= 0xe0 && c <= 0xef)
    n = 3, min = 0x800, code = c & 0x0f;
  else if (c >= 0xf0 && c <= 0xf4)
    n = 4, min = 0x10000, code = c & 0x07;
  else
    return 0;
  if (i + n > s.size()) return 0;
  for (size_t k = 1; k < n; ++k) {
    if ((byte(i + k) & 0xc0) != 0x80) return 0;
    code = (code << 6) | (byte(i + k) & 0x3f);
  }
  if (code < min || code > 0x10ffff || (code >= 0xd800 && code <= 0xdfff)) return 0;
  return n;
}

}  // namespace

std::string escapeNonUtf8(const std::string& bytes) {
  std::string out;
  out.reserve(bytes.size());
  for (size_t i = 0; i < bytes.size();) {
    const size_t n = sequence(bytes, i);
    if (n == 0) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", static_cast<unsigned char>(bytes[i]));
      out += buf;
      ++i;
      continue;
    }
    if (bytes[i] == '\\' && i + 1 < bytes.size() && bytes[i + 1] == 'x') out += '\\';
    out.append(bytes, i, n);
    i += n;
  }
  return out;
}

bool printableAscii(std::string_view name) {
  for (const unsigned char c : name)
    if (c < 0x20 || c > 0x7e) return false;
  return !name.empty();
}

std::string terminalLine(const std::string& text, size_t maxBytes) {
  std::string out;
  out.reserve(std::min(text.size(), maxBytes) + 32);
  size_t i = 0;
  while (i < text.size() && out.size() < maxBytes) {
    const size_t n = sequence(text, i);
    const auto c = static_cast<unsigned char>(text[i]);
    // U+0080..U+009F (C1 controls) are 0xc2 0x80..0x9f in UTF-8; the direction marks and
    // overrides (U+200E, U+200F, U+202A..U+202E, U+2066..U+2069) and the line and paragraph
    // separators (U+2028, U+2029), which reorder or break what a terminal shows, 0xe2 ...
    const auto b = [&](size_t k) { return static_cast<unsigned char>(text[i + k]); };
    const bool c1 = n == 2 && c == 0xc2 && b(1) < 0xa0;
    const bool layout =
        n == 3 && c == 0xe2 &&
        ((b(1) == 0x80 && ((b(2) >= 0x8e && b(2) <= 0x8f) || (b(2) >= 0xa8 && b(2) <= 0xae))) ||
         (b(1) == 0x81 && b(2) >= 0xa6 && b(2) <= 0xa9));
    if (n == 1 && (c == '\n' || c == '\r' || c == '\t')) {
      out += ' ';
    } else if (n == 0 || (n == 1 && (c < 0x20 || c == 0x7f)) || c1 || layout) {
      for (size_t k = 0; k < std::max<size_t>(n, 1); ++k) {
        char buf[8];
        std::snprintf(buf, sizeof buf, "\\x%02x", static_cast<unsigned char>(text[i + k]));
        out += buf;
      }
    } else {
      out.append(text, i, n);
    }
    i += std::max<size_t>(n, 1);
  }
  if (i < text.size()) out += "... (" + std::to_string(text.size() - i) + " more bytes)";
  return out;
}

std::string formatNumber(double value) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  // Shortest round-trip text in %g form, with a tidy exponent ("1e+06" -> "1e6").
  char buf[64];
  for (int precision = 1; precision <= 17; ++precision) {
    std::snprintf(buf, sizeof buf, "%.*g", precision, value);
    if (std::strtod(buf, nullptr) == value) break;
  }
  std::string text = buf;
  const auto e = text.find('e');
  if (e == std::string::npos) return text;
  std::string exponent = text.substr(e + 1);
  const std::string sign = exponent[0] == '-' ? "-" : "";
  exponent.erase(0, 1);
  while (exponent.size() > 1 && exponent[0] == '0') exponent.erase(0, 1);
  text = text.substr(0, e) + "e" + sign + exponent;
  // Plain decimals when they are no longer ("100", "0.001" rather than "1e2", "1e-3").
  if (std::abs(value) >= 1e-5 && std::abs(value) < 1e17) {
    for (int decimals = 0; decimals <= 22; ++decimals) {
      std::snprintf(buf, sizeof buf, "%.*f", decimals, value);
      if (std::strtod(buf, nullptr) == value) {
        if (std::strlen(buf) <= text.size()) text = buf;
        break;
      }
    }
  }
  return text;
}

std::string nulShown(const std::string& text) {
  std::string shown;
  for (char c : text) shown += c == '\0' ? std::string("\\x00") : std::string(1, c);
  return shown;
}

}  // namespace diffreg
