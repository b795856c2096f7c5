#include <diffreg/mesh/parse.h>

#include <diffreg/core/error.h>
#include <diffreg/core/log.h>
#include <diffreg/core/text.h>
#include <diffreg/mesh/halfedges.h>
#include <diffreg/mesh/polygon.h>

#include <OpenMesh/Core/IO/importer/ImporterT.hh>
#include <OpenMesh/Core/System/omstream.hh>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iterator>
#include <map>
#include <numeric>
#include <optional>
#include <set>

namespace diffreg {
namespace {

std::string quote(std::string_view s) {
  if (s.size() > 40) return "'" + std::string(s.substr(0, 40)) + "...'";
  return "'" + std::string(s) + "'";
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

enum class Parsed { Ok, Bad, Overflow };

/// Parses all of `s` as a double; values beyond the range of double are Overflow, values
/// below its smallest magnitude read as 0 (or a subnormal).
Parsed parseDouble(std::string_view s, double& v) {
  // One sign: "+1" reads as 1, "+-1" is no number (from_chars would take the '-').
  if (s.size() > 1 && s[0] == '+' && s[1] != '-') s.remove_prefix(1);
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  if (r.ptr != s.data() + s.size() || s.empty()) return Parsed::Bad;
  if (r.ec == std::errc::result_out_of_range) {
    v = std::strtod(std::string(s).c_str(), nullptr);
    return std::isinf(v) ? Parsed::Overflow : Parsed::Ok;
  }
  return r.ec == std::errc() ? Parsed::Ok : Parsed::Bad;
}

std::optional<long long> parseInt(std::string_view s) {
  if (s.size() > 1 && s[0] == '+' && s[1] != '-') s.remove_prefix(1);  // one sign, as above
  long long v = 0;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  if (r.ec != std::errc() || r.ptr != s.data() + s.size()) return std::nullopt;
  return v;
}

bool isNumber(std::string_view s) {
  double v = 0.0;
  return parseDouble(s, v) != Parsed::Bad;
}

/// A coordinate of vertex `vertex` (as numbered in messages); `where()` gives "source:line",
/// called only for a message.
template <class Where>
double coordinate(std::string_view token, const Where& where, long long vertex) {
  double v = 0.0;
  const Parsed p = parseDouble(token, v);
  if (p == Parsed::Ok && std::isfinite(v)) return v;
  const std::string name = "vertex " + std::to_string(vertex);
  if (p == Parsed::Bad) {
    throw InvalidMesh(where() + ": expected a coordinate of " + name + ", got " + quote(token));
  }
  if (p == Parsed::Overflow) {
    throw InvalidMesh(where() + ": " + name + " has a non-finite coordinate (" + quote(token) +
                      " is beyond the range of double)");
  }
  throw InvalidMesh(where() + ": " + name + " has a non-finite coordinate");
}

/// The C locale's white space, without a call per character.
inline bool isSpace(char c) {
  return c == ' ' || c == '\n' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

/// Lines and whitespace-separated tokens of a text file with line numbers ('#' starts a
/// comment when `comments`). Nothing is copied: tokens point into the text.
class Scanner {
 public:
  Scanner(std::string_view text, std::string source, bool comments = true)
      : text_(text), source_(std::move(source)), comments_(comments) {}

  /// The tokens of the next line that has any; false at the end of the text.
  bool line(std::vector<std::string_view>& tokens) {
    tokens.clear();
    while (tokens.empty() && pos_ < text_.size()) {
      size_t end = text_.find('\n', pos_);
      if (end == std::string_view::npos) end = text_.size();
      std::string_view l = text_.substr(pos_, end - pos_);
      line_ = nextLine_++;
      pos_ = end + 1;
      if (comments_) l = l.substr(0, l.find('#'));
      split(l, tokens);
    }
    return !tokens.empty();
  }

  /// The next token (across lines); false at the end of the text.
  bool token(std::string_view& out) {
    for (;;) {
      while (pos_ < text_.size() && isSpace(text_[pos_])) {
        if (text_[pos_] == '\n') ++nextLine_;
        ++pos_;
      }
      if (pos_ >= text_.size()) return false;
      if (comments_ && text_[pos_] == '#') {
        const size_t end = text_.find('\n', pos_);
        pos_ = end == std::string_view::npos ? text_.size() : end;
        continue;
      }
      const size_t start = pos_;
      while (pos_ < text_.size() && !isSpace(text_[pos_]) &&
             !(comments_ && text_[pos_] == '#'))
        ++pos_;
      out = text_.substr(start, pos_ - start);
      line_ = nextLine_;
      return true;
    }
  }

  /// Bytes not read yet.
  size_t remaining() const { return pos_ < text_.size() ? text_.size() - pos_ : 0; }
  size_t position() const { return std::min(pos_, text_.size()); }
  /// "source:line" of the last line or token returned.
  std::string where() const { return source_ + ":" + std::to_string(line_); }
  int lineNumber() const { return line_; }
  const std::string& source() const { return source_; }

  static void split(std::string_view l, std::vector<std::string_view>& tokens) {
    size_t i = 0;
    while (i < l.size()) {
      while (i < l.size() && isSpace(l[i])) ++i;
      const size_t start = i;
      while (i < l.size() && !isSpace(l[i])) ++i;
      if (i > start) tokens.push_back(l.substr(start, i - start));
    }
  }

 private:
  std::string_view text_;
  std::string source_;
  bool comments_;
  size_t pos_ = 0;
  int line_ = 0, nextLine_ = 1;
};

/// Corners reserved for a face before its indices are read: one allocation for the faces of
/// common files instead of one per doubling; longer lists grow as their indices are read.
constexpr long long kFaceReserve = 8;

/// Throws unless `count` elements of at least `bytesEach` bytes fit into `remaining` bytes.
void checkCount(const std::string& where, const std::string& what, long long count,
                std::uint64_t bytesEach, std::uint64_t remaining) {
  if (count < 0)
    throw InvalidMesh(where + ": negative " + what + " count " + std::to_string(count));
  if (static_cast<std::uint64_t>(count) > remaining / std::max<std::uint64_t>(bytesEach, 1)) {
    throw InvalidMesh(where + ": the file says " + std::to_string(count) + " " + what +
                      ", more than its remaining " + std::to_string(remaining) +
                      " bytes can hold (truncated or corrupt)");
  }
}

long long count(const std::string& where, std::string_view token, const std::string& what) {
  const auto n = parseInt(token);
  if (!n) throw InvalidMesh(where + ": expected the " + what + " count, got " + quote(token));
  return *n;
}

/// `text` without a leading UTF-8 byte order mark, which some editors write at the start of
/// text files (it would otherwise stick to the file's first word).
std::string_view withoutBom(std::string_view text) {
  constexpr std::string_view bom = "\xEF\xBB\xBF";
  if (text.substr(0, bom.size()) == bom) text.remove_prefix(bom.size());
  return text;
}

}  // namespace

// ---------------------------------------------------------------------------------------
// OBJ

namespace {

/// The OBJ statements besides v and f (texture and normal vertices, groups, materials, free-form
/// geometry, display attributes): read past without a warning.
bool ignoredObjStatement(std::string_view keyword) {
  if (keyword.size() == 2 && keyword[0] == 'v')  // vt, vn and vp: the common case first
    return keyword[1] == 't' || keyword[1] == 'n' || keyword[1] == 'p';
  static constexpr std::string_view kIgnored[] = {
      "g",          "o",         "s",        "usemtl",   "mtllib", "l",      "p",
      "cstype",     "deg",       "curv",     "curv2",    "surf",   "parm",   "trim",
      "hole",       "scrv",      "sp",       "end",      "con",    "bmat",   "step",
      "mg",         "bevel",     "c_interp", "d_interp", "lod",    "maplib", "usemap",
      "shadow_obj", "trace_obj", "ctech",    "stech",    "call",   "csh"};
  return std::find(std::begin(kIgnored), std::end(kIgnored), keyword) != std::end(kIgnored);
}

/// `word` for a message: at most 40 bytes, quoted, bytes other than printable ASCII as \xNN
/// (a non-breaking space or a stray control character would not show).
std::string visible(std::string_view word) {
  std::string out;
  for (const char c : word.substr(0, 40)) {
    const auto b = static_cast<unsigned char>(c);
    if (b > 0x20 && b < 0x7f) {
      out += c;
    } else {
      char hex[5];
      std::snprintf(hex, sizeof hex, "\\x%02x", b);
      out += hex;
    }
  }
  return "'" + out + (word.size() > 40 ? "...'" : "'");
}

/// parseObj's common case in one pass over the bytes, without a list of tokens per line: the
/// same points, faces and line numbers as the general reading below, or nothing at the first
/// line it would report (or could not read as it does), which is then read again that way.
std::optional<RawMesh> parseObjFast(std::string_view text) {
  RawMesh raw;
  raw.base = 1;
  const char* p = text.data();
  const char* const end = p + text.size();
  int line = 0;
  const auto skipSpace = [](const char* q, const char* stop) {
    while (q < stop && isSpace(*q)) ++q;
    return q;
  };
  const auto tokenEnd = [](const char* q, const char* stop) {
    while (q < stop && !isSpace(*q)) ++q;
    return q;
  };
  while (p < end) {
    ++line;
    const char* eol = static_cast<const char*>(std::memchr(p, '\n', size_t(end - p)));
    if (!eol) eol = end;
    const char* hash = static_cast<const char*>(std::memchr(p, '#', size_t(eol - p)));
    const char* const stop = hash ? hash : eol;
    const char* q = skipSpace(p, stop);
    p = eol + 1;
    if (q == stop) continue;  // blank or a comment
    const char* const keywordEnd = tokenEnd(q, stop);
    if (keywordEnd != q + 1 || (*q != 'v' && *q != 'f')) {
      // Other statements are skipped; a line that starts with none is left to the token-wise
      // reading, which warns about it.
      if (ignoredObjStatement(std::string_view(q, size_t(keywordEnd - q)))) continue;
      return std::nullopt;
    }
    if (keywordEnd == stop) return std::nullopt;  // a bare "v" or "f"
    if (*q == 'v') {
      Eigen::Vector3d point;
      ++q;
      for (int c = 0; c < 3; ++c) {
        q = skipSpace(q, stop);
        const char* e = tokenEnd(q, stop);
        if (q == e || parseDouble(std::string_view(q, size_t(e - q)), point[c]) != Parsed::Ok ||
            !std::isfinite(point[c]))
          return std::nullopt;
        q = e;
      }
      raw.points.push_back(point);
    } else if (*q == 'f') {
      RawFace face{line, {}};
      face.ids.reserve(4);
      const long long n = static_cast<long long>(raw.points.size());
      for (q = skipSpace(q + 1, stop); q < stop; q = skipSpace(q, stop)) {
        const char* e = tokenEnd(q, stop);
        const char* slash = static_cast<const char*>(std::memchr(q, '/', size_t(e - q)));
        const char* const digitsEnd = slash ? slash : e;
        // Plain decimal digits (at most 18: no overflow) here; anything else by parseInt.
        const bool negative = *q == '-';
        long long id = 0;
        const char* d = q + (negative ? 1 : 0);
        if (d == digitsEnd || digitsEnd - d > 18) return std::nullopt;
        for (; d < digitsEnd; ++d) {
          const unsigned digit = static_cast<unsigned>(*d - '0');
          if (digit > 9) break;
          id = 10 * id + digit;
        }
        if (d != digitsEnd) {
          const auto parsed = parseInt(std::string_view(q, size_t(digitsEnd - q)));
          if (!parsed) return std::nullopt;
          id = *parsed;
        } else if (negative) {
          id = -id;
        }
        if (id == 0 || id < -n) return std::nullopt;
        face.ids.push_back(id > 0 ? id - 1 : n + id);
        q = e;
      }
      raw.faces.push_back(std::move(face));
    }
  }
  return raw;
}

/// parseObjByTokens without the byte order mark.
RawMesh parseObjLines(std::string_view text, const std::string& source);

}  // namespace

RawMesh parseObj(std::string_view text, const std::string& source) {
  text = withoutBom(text);
  if (auto raw = parseObjFast(text)) return std::move(*raw);
  return parseObjLines(text, source);
}

RawMesh detail::parseObjByTokens(std::string_view text, const std::string& source) {
  return parseObjLines(withoutBom(text), source);
}

namespace {

RawMesh parseObjLines(std::string_view text, const std::string& source) {
  Scanner s(text, source);
  RawMesh raw;
  raw.base = 1;
  std::vector<std::string_view> t;
  long long unknown = 0;  // lines that start with no OBJ statement
  int firstUnknownLine = 0;
  std::string_view firstUnknown;
  while (s.line(t)) {
    if (t[0] == "v") {
      const long long id = static_cast<long long>(raw.points.size()) + 1;
      if (t.size() < 4)
        throw InvalidMesh(s.where() + ": vertex " + std::to_string(id) + " needs 3 coordinates");
      Eigen::Vector3d p;
      for (int c = 0; c < 3; ++c) p[c] = coordinate(t[1 + c], [&] { return s.where(); }, id);
      raw.points.push_back(p);
    } else if (t[0] == "f") {
      RawFace face{s.lineNumber(), {}};
      face.ids.reserve(t.size() - 1);  // the tokens are on the line already
      const long long n = static_cast<long long>(raw.points.size());
      for (size_t i = 1; i < t.size(); ++i) {
        const auto id = parseInt(t[i].substr(0, t[i].find('/')));
        if (!id || *id == 0 || *id < -n) {
          throw InvalidMesh(s.where() + ": face " + std::to_string(raw.faces.size() + 1) +
                            " has a bad vertex reference " + quote(t[i]));
        }
        face.ids.push_back(*id > 0 ? *id - 1 : n + *id);
      }
      raw.faces.push_back(std::move(face));
    } else if (!ignoredObjStatement(t[0]) && unknown++ == 0) {
      firstUnknownLine = s.lineNumber();
      firstUnknown = t[0];
    }
  }
  if (unknown > 0) {
    warn(source + ": ignored " + std::to_string(unknown) +
         (unknown == 1 ? " line that starts" : " lines that start") +
         " with no OBJ statement (first: line " + std::to_string(firstUnknownLine) + ", " +
         visible(firstUnknown) + ")");
  }
  return raw;
}

}  // namespace

// ---------------------------------------------------------------------------------------
// OFF

namespace {

/// Reads big-endian 32-bit numbers (binary OFF) with bounds checks.
class BigEndian {
 public:
  BigEndian(std::string_view data, std::string source) : d_(data), source_(std::move(source)) {}
  std::uint32_t u32(const std::string& what) {
    if (d_.size() - pos_ < 4 || pos_ > d_.size()) {
      throw InvalidMesh(source_ + ": the file ends early, expected " + what);
    }
    std::uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v = (v << 8) | static_cast<unsigned char>(d_[pos_ + i]);
    pos_ += 4;
    return v;
  }
  std::int32_t i32(const std::string& what) { return static_cast<std::int32_t>(u32(what)); }
  float f32(const std::string& what) {
    const std::uint32_t v = u32(what);
    float f;
    std::memcpy(&f, &v, 4);
    return f;
  }
  std::uint64_t remaining() const { return d_.size() - pos_; }

 private:
  std::string_view d_;
  std::string source_;
  size_t pos_ = 0;
};

RawMesh parseBinaryOff(std::string_view data, const std::string& source) {
  BigEndian in(data, source);
  RawMesh raw;
  const long long nv = in.i32("the vertex count"), nf = in.i32("the face count");
  in.i32("the edge count");
  checkCount(source, "vertices", nv, 12, in.remaining());
  checkCount(source, "faces", nf, 4, in.remaining() - 12 * static_cast<std::uint64_t>(nv));
  raw.points.reserve(static_cast<size_t>(nv));  // 24 bytes for each 12 of the file
  for (long long i = 0; i < nv; ++i) {
    Eigen::Vector3d p;
    for (int c = 0; c < 3; ++c) p[c] = in.f32("a coordinate of vertex " + std::to_string(i));
    if (!p.allFinite()) {
      throw InvalidMesh(source + ": vertex " + std::to_string(i) + " has a non-finite coordinate");
    }
    raw.points.push_back(p);
  }
  for (long long k = 0; k < nf; ++k) {
    const std::string what = "face " + std::to_string(k);
    const long long n = in.i32("the vertex count of " + what);
    checkCount(source + ": " + what, "vertices", n, 4, in.remaining());
    RawFace face;
    face.ids.reserve(static_cast<size_t>(std::min<long long>(n, kFaceReserve)));
    for (long long j = 0; j < n; ++j) face.ids.push_back(in.i32("a vertex index of " + what));
    const long long colors = in.i32("the colour count of " + what);
    if (colors < 0 || colors > 4) {
      throw InvalidMesh(source + ": " + what + " has a bad colour count " + std::to_string(colors));
    }
    for (long long c = 0; c < colors; ++c) in.f32("a colour of " + what);
    raw.faces.push_back(std::move(face));
  }
  return raw;
}

}  // namespace

RawMesh parseOff(std::string_view text, const std::string& source) {
  text = withoutBom(text);
  Scanner s(text, source);
  std::vector<std::string_view> t;
  if (!s.line(t)) throw InvalidMesh(source + ": empty file");
  const std::string_view head = t[0];
  if (head.size() < 3 || head.substr(head.size() - 3) != "OFF") {
    throw InvalidMesh(s.where() + ": not an OFF file (no OFF header)");
  }
  const std::string_view prefix = head.substr(0, head.size() - 3);
  if (prefix.find('4') != std::string_view::npos || prefix.find('n') != std::string_view::npos) {
    throw InvalidMesh(s.where() + ": only 3D OFF files are supported (header " + quote(head) + ")");
  }
  if (t.size() > 1 && t[1] == "BINARY") {
    // The binary data starts after the header line.
    return parseBinaryOff(text.substr(s.position()), source);
  }
  std::vector<std::string_view> counts(t.begin() + 1, t.end());
  if (counts.empty() && s.line(t)) counts = t;
  if (counts.size() < 2) {
    throw InvalidMesh(s.where() + ": expected the vertex and face counts after the OFF header");
  }
  const long long nv = count(s.where(), counts[0], "vertex");
  const long long nf = count(s.where(), counts[1], "face");
  // A vertex takes at least "0 0 0\n", a face "3 0 1 2\n".
  checkCount(s.where(), "vertices", nv, 6, s.remaining());
  checkCount(s.where(), "faces", nf, 8, s.remaining() - 6 * static_cast<std::uint64_t>(nv));
  RawMesh raw;
  raw.points.reserve(static_cast<size_t>(nv));  // 24 bytes for each 6 of the file
  for (long long i = 0; i < nv; ++i) {
    if (!s.line(t)) {
      throw InvalidMesh(source + ": the file ends after " + std::to_string(i) + " of " +
                        std::to_string(nv) + " vertices");
    }
    if (t.size() < 3)
      throw InvalidMesh(s.where() + ": vertex " + std::to_string(i) + " needs 3 coordinates");
    Eigen::Vector3d p;
    for (int c = 0; c < 3; ++c) p[c] = coordinate(t[c], [&] { return s.where(); }, i);
    raw.points.push_back(p);
  }
  for (long long k = 0; k < nf; ++k) {
    if (!s.line(t)) {
      throw InvalidMesh(source + ": the file ends after " + std::to_string(k) + " of " +
                        std::to_string(nf) + " faces");
    }
    const auto size = parseInt(t[0]);
    if (!size || *size < 0 || static_cast<long long>(t.size()) < 1 + *size) {
      throw InvalidMesh(s.where() + ": face " + std::to_string(k) +
                        ": bad vertex count or too few indices");
    }
    RawFace face{s.lineNumber(), {}};
    face.ids.reserve(static_cast<size_t>(std::min<long long>(*size, kFaceReserve)));
    for (long long j = 0; j < *size; ++j) {
      const auto id = parseInt(t[1 + j]);
      if (!id) {
        throw InvalidMesh(s.where() + ": face " + std::to_string(k) +
                          ": expected a vertex index, got " + quote(t[1 + j]));
      }
      face.ids.push_back(*id);
    }
    raw.faces.push_back(std::move(face));
  }
  if (s.line(t))  // more faces than the header declares would be dropped unread
    throw InvalidMesh(s.where() + ": more data after the " + std::to_string(nf) +
                      " faces the header declares");
  return raw;
}

// ---------------------------------------------------------------------------------------
// PLY

namespace {

enum class PlyFormat { Ascii, Little, Big };

/// A scalar type: its size and kind, and its name as the header spells it (for messages).
struct PlyType {
  std::string name;
  int size = 0;          ///< bytes
  bool isFloat = false;  ///< float or double
  bool isSigned = true;
};

struct PlyProperty {
  std::string name;
  PlyType type;   ///< of the value, or of a list's items
  PlyType count;  ///< of a list's count (size 0: not a list)
  bool isList() const { return count.size > 0; }
};

struct PlyElement {
  std::string name;
  long long count = 0;
  std::vector<PlyProperty> props;
  int line = 0;
  /// The fewest bytes one element takes (binary: scalar sizes; ASCII: a digit and a space each).
  std::uint64_t minBytes(PlyFormat format) const {
    std::uint64_t b = 0;
    for (const auto& p : props)
      b += format == PlyFormat::Ascii ? 2 : (p.isList() ? p.count.size : p.type.size);
    return std::max<std::uint64_t>(b, 1);
  }
};

bool plyType(std::string_view t, PlyType& p) {
  static const struct {
    const char* a;
    const char* b;
    int size;
    bool isFloat, isSigned;
  } types[] = {{"char", "int8", 1, false, true},    {"uchar", "uint8", 1, false, false},
               {"short", "int16", 2, false, true},  {"ushort", "uint16", 2, false, false},
               {"int", "int32", 4, false, true},    {"uint", "uint32", 4, false, false},
               {"float", "float32", 4, true, true}, {"double", "float64", 8, true, true}};
  for (const auto& e : types) {
    if (t == e.a || t == e.b) {
      p.name = std::string(t);
      p.size = e.size;
      p.isFloat = e.isFloat;
      p.isSigned = e.isSigned;
      return true;
    }
  }
  return false;
}

/// Reads binary PLY values with bounds checks.
class BinaryReader {
 public:
  BinaryReader(std::string_view data, bool big, std::string source)
      : d_(data), big_(big), source_(std::move(source)) {}
  /// One value of `size` bytes, as double.
  double value(int size, bool isFloat, bool isSigned, const std::string& what) {
    if (d_.size() - pos_ < static_cast<size_t>(size)) {
      throw InvalidMesh(source_ + ": the file ends early, in " + what);
    }
    unsigned char b[8];
    std::memcpy(b, d_.data() + pos_, size);
    pos_ += size;
    if (big_) std::reverse(b, b + size);  // to little-endian (x86 hosts)
    if (isFloat && size == 4) {
      float f;
      std::memcpy(&f, b, 4);
      return f;
    }
    if (isFloat) {
      double v;
      std::memcpy(&v, b, 8);
      return v;
    }
    std::uint64_t u = 0;
    for (int i = size - 1; i >= 0; --i) u = (u << 8) | b[i];
    if (isSigned && size < 8 && (u >> (8 * size - 1)) & 1) {
      return static_cast<double>(static_cast<std::int64_t>(u) - (std::int64_t(1) << (8 * size)));
    }
    return static_cast<double>(u);
  }
  std::uint64_t remaining() const { return d_.size() - pos_; }

 private:
  std::string_view d_;
  bool big_;
  std::string source_;
  size_t pos_ = 0;
};

/// The header: format, elements and the offset of the data.
struct PlyHeader {
  PlyFormat format = PlyFormat::Ascii;
  std::vector<PlyElement> elements;
  size_t dataStart = 0;
  int dataLine = 0;
  /// What the header says vertex and face properties hold: (file property, mesh property),
  /// from "comment diffreg vertex|face quality NAME" and "... property NAME".
  std::vector<std::pair<std::string, std::string>> vertexNamed, faceNamed;
  /// The file properties and mesh properties named so far, vertex [0] and face [1].
  std::set<std::string> namedProperties[2], namedNames[2];
  /// Namings not taken (a name not printable ASCII, a second naming): their count and the
  /// first one's line, for one warning.
  int skippedNamings = 0;
  std::string firstSkipped;
};

/// Takes a header comment "diffreg vertex|face quality|property NAME" into `h`. One naming a
/// file property or a mesh property a second time, or with a name that is not printable
/// ASCII, is counted in `h.skippedNamings` instead.
void takeNamingComment(const std::vector<std::string_view>& t, const std::string& where,
                       PlyHeader& h) {
  const bool quality = t[3] == "quality", vertex = t[2] == "vertex";
  const std::string property = quality ? "quality" : std::string(t[4]), name(t[4]);
  // A property name is printable ASCII (as the writer and the .om reader have it).
  const int kind = vertex ? 0 : 1;
  static const std::string tooMany =
      "is one more than the " + std::to_string(kMaxNamedProperties) + " kept";
  const char* why = !printableAscii(t[4]) ? "is not printable ASCII"
                    : h.namedProperties[kind].count(property) || h.namedNames[kind].count(name)
                        ? "names a property named before"
                    : !quality && plyReservedName(vertex, property)
                        ? "names a property PLY readers take for something else"
                    : h.namedNames[kind].size() >= static_cast<size_t>(kMaxNamedProperties)
                        ? tooMany.c_str()
                        : nullptr;
  if (why) {
    if (h.skippedNamings++ == 0)
      h.firstSkipped = where + ": the " + std::string(t[2]) + (quality ? " quality" : " property") +
                       " naming " + visible(t[4]) + " " + why;
    return;
  }
  h.namedProperties[kind].insert(property);
  h.namedNames[kind].insert(name);
  (vertex ? h.vertexNamed : h.faceNamed).emplace_back(property, name);
}

PlyHeader parsePlyHeader(std::string_view text, const std::string& source) {
  PlyHeader h;
  size_t pos = 0;
  int line = 0;
  bool haveFormat = false;
  std::vector<std::string_view> t;
  for (;;) {
    if (pos >= text.size()) throw InvalidMesh(source + ": the PLY header has no end_header");
    size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view l = text.substr(pos, end - pos);
    pos = end + 1;
    ++line;
    const std::string where = source + ":" + std::to_string(line);
    t.clear();
    Scanner::split(l, t);
    if (line == 1) {
      if (t.size() != 1 || t[0] != "ply") throw InvalidMesh(where + ": not a PLY file (no 'ply')");
      continue;
    }
    if (t.size() == 5 && t[0] == "comment" && t[1] == "diffreg" &&
        (t[3] == "quality" || t[3] == "property") && (t[2] == "vertex" || t[2] == "face"))
      takeNamingComment(t, where, h);
    if (t.empty() || t[0] == "comment" || t[0] == "obj_info") continue;
    if (t[0] == "end_header") break;
    if (t[0] == "format") {
      // PLY 1.0 is the only version there is; another could mean anything.
      if (haveFormat) throw InvalidMesh(where + ": a second PLY format line");
      haveFormat = true;
      if (t.size() == 3 && t[2] == "1.0" && t[1] == "ascii") {
        h.format = PlyFormat::Ascii;
      } else if (t.size() == 3 && t[2] == "1.0" && t[1] == "binary_little_endian") {
        h.format = PlyFormat::Little;
      } else if (t.size() == 3 && t[2] == "1.0" && t[1] == "binary_big_endian") {
        h.format = PlyFormat::Big;
      } else {
        std::string line;
        for (const std::string_view w : t) line += (line.empty() ? "" : " ") + std::string(w);
        throw InvalidMesh(where + ": unsupported PLY format line " + quote(line) +
                          " (expected format ascii 1.0, binary_little_endian 1.0 or "
                          "binary_big_endian 1.0)");
      }
    } else if (t[0] == "element" && t.size() == 3) {
      PlyElement e;
      e.name = std::string(t[1]);
      e.count = count(where, t[2], "element");
      if (e.count < 0) throw InvalidMesh(where + ": negative element count");
      e.line = line;
      h.elements.push_back(std::move(e));
    } else if (t[0] == "property" && !h.elements.empty()) {
      PlyProperty p;
      bool ok = false;
      if (t.size() == 5 && t[1] == "list") {
        ok = plyType(t[2], p.count) && !p.count.isFloat && plyType(t[3], p.type) && !p.type.isFloat;
        p.name = std::string(t[4]);
      } else if (t.size() == 3) {
        ok = plyType(t[1], p.type);
        p.name = std::string(t[2]);
      }
      if (!ok) throw InvalidMesh(where + ": bad PLY property line " + quote(l));
      h.elements.back().props.push_back(p);
    } else {
      throw InvalidMesh(where + ": unexpected PLY header line " + quote(l));
    }
  }
  if (!haveFormat) throw InvalidMesh(source + ": the PLY header has no format line");
  if (h.skippedNamings > 0)
    warn(h.firstSkipped + "; not kept" +
         (h.skippedNamings > 1 ? " (nor " + std::to_string(h.skippedNamings - 1) + " more namings)"
                               : std::string()));
  h.dataStart = std::min(pos, text.size());
  h.dataLine = line + 1;
  return h;
}

/// Index of the property named one of `names` in `e`, -1 when none.
int findProperty(const PlyElement& e, std::initializer_list<const char*> names) {
  for (size_t i = 0; i < e.props.size(); ++i)
    for (const char* n : names)
      if (e.props[i].name == n) return static_cast<int>(i);
  return -1;
}

/// The vertex index `v` (read as double) as an id; out-of-range values stay out of range.
long long plyIndex(double v) {
  if (!(v >= -1e15 && v <= 1e15)) return -1;
  return static_cast<long long>(v);
}

}  // namespace

namespace {

/// The values of a PLY body, element by element: ASCII (whitespace-separated, an element may
/// span lines or share one) or binary.
class PlyValues {
 public:
  PlyValues(std::string_view text, const PlyHeader& h, const std::string& source)
      : ascii_(h.format == PlyFormat::Ascii),
        firstLine_(h.dataLine),
        source_(source),
        lines_(text.substr(h.dataStart), source, false),
        bin_(text.substr(h.dataStart), h.format == PlyFormat::Big, source) {}

  /// After the last element: values the header does not declare would be dropped unread, so
  /// an ASCII body with more is an error, and a binary one's extra bytes are warned about.
  void finish() {
    if (ascii_) {
      if (pending_ || lines_.token(token_))
        throw InvalidMesh(source_ + ":" + std::to_string(line()) +
                          ": more values after the last element the header declares");
    } else if (bin_.remaining() > 0) {
      warn(source_ + ": " + std::to_string(bin_.remaining()) +
           " bytes after the last element the header declares are not read");
    }
  }

  /// Starts element `k` of `e`. \throw InvalidMesh when an ASCII body has no value left.
  void start(const PlyElement& e, long long k) {
    what_ = e.name + " " + std::to_string(k);
    if (!ascii_) return;
    if (!pending_ && !(pending_ = lines_.token(token_))) {
      throw InvalidMesh(source_ + ": the file ends after " + std::to_string(k) + " of " +
                        std::to_string(e.count) + " '" + e.name + "' elements");
    }
  }
  /// The file's line of the last value read (0 for binary).
  int line() const { return ascii_ ? firstLine_ - 1 + lines_.lineNumber() : 0; }
  std::string where() const {
    return source_ + (ascii_ ? ":" + std::to_string(line()) : "") + ": " + what_;
  }

  /// Which value of a property next() reads.
  enum class Part { Value, Item, Count };

  /// The next value: of scalar property `prop`, an item of list `prop` or its count. ASCII
  /// integers must be written as integers within their type's range.
  double next(const PlyProperty& prop, Part part) {
    const PlyType& type = part == Part::Count ? prop.count : prop.type;
    if (!ascii_) return bin_.value(type.size, type.isFloat, type.isSigned, what_);
    if (!pending_ && !lines_.token(token_)) {
      throw InvalidMesh(where() + " has too few values (the file ends)");
    }
    pending_ = false;
    const std::string_view tok = token_;
    if (!type.isFloat) return integer(tok, prop, part);
    double v = 0.0;
    const Parsed p = parseDouble(tok, v);
    if (p == Parsed::Bad) throw InvalidMesh(where() + ": expected a number, got " + quote(tok));
    if (p == Parsed::Overflow) {
      throw InvalidMesh(where() + ": " + quote(tok) + " is beyond the range of double");
    }
    return v;
  }

  /// The length of list `prop`: at most one item per two bytes (ASCII: a digit and a space) or
  /// per item size (binary) left, compared as doubles since an ASCII length may be any number.
  long long listLength(const PlyProperty& prop) {
    const double n = next(prop, Part::Count);
    const double most = ascii_ ? static_cast<double>(lines_.remaining() / 2 + 1)
                               : static_cast<double>(bin_.remaining() / prop.type.size + 1);
    if (n > most && n == std::floor(n) && n < 1e18) {  // a fine length, but the file is short
      throw InvalidMesh(where() + ": its list '" + prop.name + "' of " +
                        std::to_string(static_cast<long long>(n)) +
                        " items runs past the end of the file");
    }
    if (!(n >= 0 && n <= most && n == std::floor(n))) {
      throw InvalidMesh(
          where() + " has a bad list length " +
          quote(ascii_ ? std::string(token_) : std::to_string(static_cast<long long>(n))));
    }
    return static_cast<long long>(n);
  }

 private:
  double integer(std::string_view tok, const PlyProperty& prop, Part part) const {
    const PlyType& type = part == Part::Count ? prop.count : prop.type;
    const auto v = parseInt(tok);
    const int bits = 8 * type.size;
    const long long lo = type.isSigned ? -(1LL << (bits - 1)) : 0;
    const long long hi = type.isSigned ? (1LL << (bits - 1)) - 1 : (1LL << bits) - 1;
    if (v && *v >= lo && *v <= hi) return static_cast<double>(*v);
    const std::string_view digits = tok.substr(!tok.empty() && (tok[0] == '-' || tok[0] == '+'));
    const bool beyondLongLong =  // digits only, but too many for parseInt: out of range too
        !v && !digits.empty() && digits.find_first_not_of("0123456789") == std::string_view::npos;
    const std::string range = type.name + ": " + std::to_string(lo) + ".." + std::to_string(hi);
    if (part == Part::Count) {
      throw InvalidMesh(where() + " has a bad list length " + quote(tok) + " for list '" +
                        prop.name + "' (" +
                        (v || beyondLongLong ? "out of range for " + range
                                             : "not an integer, the count is " + type.name) +
                        ")");
    }
    const std::string name =
        (part == Part::Value ? "property '" : "an item of list '") + prop.name + "'";
    if (!v && !beyondLongLong) {
      throw InvalidMesh(where() + ": expected an integer for " + name + " (" + type.name +
                        "), got " + quote(tok));
    }
    throw InvalidMesh(where() + ": " + quote(tok) + " is out of range for " + name + " (" + range +
                      ")");
  }

  bool ascii_;
  int firstLine_;
  std::string source_;
  Scanner lines_;
  BinaryReader bin_;
  std::string_view token_;  // the last ASCII value read, or the next one when pending_
  bool pending_ = false;
  std::string what_;
};

/// Reads the `e.count` elements of `e`; vertices and faces go to `raw`, others are skipped.
/// `named` says which of their properties hold which mesh property (the header's comments).
void readPlyElement(PlyValues& in, const PlyElement& e, const std::string& source,
                    const std::vector<std::pair<std::string, std::string>>& named, RawMesh& raw) {
  const bool vertex = e.name == "vertex", face = e.name == "face";
  const int xyz[3] = {findProperty(e, {"x"}), findProperty(e, {"y"}), findProperty(e, {"z"})};
  const int ids = findProperty(e, {"vertex_indices", "vertex_index"});
  // The named values (diffreg's own files): the column of each scalar property named, -1 else.
  std::vector<RawMesh::Values>& columns = vertex ? raw.vertexValues : raw.faceValues;
  std::vector<int> column(e.props.size(), -1);
  // A second vertex (face) element's values are not named: the namings hold for the first.
  if ((vertex || face) && !named.empty() && columns.empty()) {
    std::map<std::string_view, int> index;  // the first property of each name
    for (size_t i = 0; i < e.props.size(); ++i) index.emplace(e.props[i].name, static_cast<int>(i));
    for (const auto& [property, name] : named) {
      const auto it = index.find(property);
      if (it == index.end() || e.props[it->second].isList() || column[it->second] >= 0) continue;
      column[it->second] = static_cast<int>(columns.size());
      columns.push_back({name, {}});
      // The count is checked against the bytes left (parsePly): no growth by doubling.
      columns.back().values.reserve(static_cast<size_t>(e.count));
    }
  }
  const std::string where = source + ":" + std::to_string(e.line);
  if (vertex && (xyz[0] < 0 || xyz[1] < 0 || xyz[2] < 0))
    throw InvalidMesh(where + ": the vertex element has no x, y and z");
  if (face && (ids < 0 || !e.props[ids].isList()))
    throw InvalidMesh(where + ": the face element has no vertex_indices list");
  for (long long k = 0; k < e.count; ++k) {
    in.start(e, k);
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    RawFace f{in.line(), {}};
    for (size_t i = 0; i < e.props.size(); ++i) {
      const PlyProperty& prop = e.props[i];
      const bool mine = face && static_cast<int>(i) == ids;
      if (prop.isList()) {
        const long long n = in.listLength(prop);
        if (mine) f.ids.reserve(static_cast<size_t>(std::min<long long>(n, kFaceReserve)));
        for (long long j = 0; j < n; ++j) {
          const double id = in.next(prop, PlyValues::Part::Item);
          if (mine) f.ids.push_back(plyIndex(id));
        }
        continue;
      }
      const double v = in.next(prop, PlyValues::Part::Value);
      for (int c = 0; c < 3; ++c)
        if (vertex && static_cast<int>(i) == xyz[c]) p[c] = v;
      if (column[i] >= 0) {
        if (!std::isfinite(v))
          throw InvalidMesh(
              in.where() + " has a non-finite " +
              (prop.name == "quality" ? std::string("quality") : "value of " + quote(prop.name)));
        columns[column[i]].values.push_back(v);
      }
    }
    if (vertex) {
      if (!p.allFinite()) throw InvalidMesh(in.where() + " has a non-finite coordinate");
      raw.points.push_back(p);
    }
    if (face) raw.faces.push_back(std::move(f));
  }
}

}  // namespace

RawMesh parsePly(std::string_view text, const std::string& source) {
  text = withoutBom(text);
  const PlyHeader h = parsePlyHeader(text, source);
  std::uint64_t need = 0;
  const std::uint64_t have = text.size() - h.dataStart;
  for (const PlyElement& e : h.elements) {
    checkCount(source + ":" + std::to_string(e.line), "'" + e.name + "' elements", e.count,
               e.minBytes(h.format), have - std::min(need, have));
    need += static_cast<std::uint64_t>(e.count) * e.minBytes(h.format);
  }
  RawMesh raw;
  PlyValues values(text, h, source);
  for (const PlyElement& e : h.elements)
    readPlyElement(values, e, source, e.name == "vertex" ? h.vertexNamed : h.faceNamed, raw);
  values.finish();
  // Namings of no scalar property of the first vertex (face) element: said once.
  int unmatched = 0;
  std::string first;
  for (const bool vertex : {true, false}) {
    const auto& columns = vertex ? raw.vertexValues : raw.faceValues;
    for (const auto& naming : vertex ? h.vertexNamed : h.faceNamed) {
      const bool found =
          std::any_of(columns.begin(), columns.end(),
                      [&naming](const RawMesh::Values& v) { return v.name == naming.second; });
      if (!found && unmatched++ == 0)
        first = std::string(vertex ? "vertex" : "face") + " property " + quote(naming.first);
    }
  }
  if (unmatched > 0)
    warn(source + ": the header names " + std::to_string(unmatched) +
         " properties that are no scalar property of their element (first: the " + first +
         "); they are not kept");
  return raw;
}

// ---------------------------------------------------------------------------------------
// Medit .mesh

namespace {

/// Tokens of a Medit file with what each was expected to be, for the messages.
class MeditTokens {
 public:
  MeditTokens(std::string_view text, const std::string& source) : s_(text, source) {}
  bool atEnd() {
    fill();
    return !have_;
  }
  std::string_view peek(const std::string& what) {
    fill();
    if (!have_) throw InvalidMesh(s_.source() + ": unexpected end of file, expected " + what);
    return tok_;
  }
  std::string_view next(const std::string& what) {
    const std::string_view t = peek(what);
    have_ = false;
    return t;
  }
  double number(const std::string& what) {
    const std::string_view t = next(what);
    double v = 0.0;
    const Parsed p = parseDouble(t, v);
    if (p == Parsed::Bad) throw InvalidMesh(where() + ": expected " + what + ", got " + quote(t));
    if (p == Parsed::Overflow) {
      throw InvalidMesh(where() + ": " + what + " " + quote(t) + " is beyond the range of double");
    }
    return v;
  }
  long long integer(const std::string& what) {
    const std::string_view t = next(what);
    const auto v = parseInt(t);
    if (!v) throw InvalidMesh(where() + ": expected " + what + " (an integer), got " + quote(t));
    return *v;
  }
  std::string where() const { return s_.where(); }
  int line() const { return s_.lineNumber(); }
  std::uint64_t remaining() const { return s_.remaining(); }

 private:
  void fill() {
    if (!have_ && !ended_) {
      have_ = s_.token(tok_);
      ended_ = !have_;
    }
  }
  Scanner s_;
  std::string_view tok_;
  bool have_ = false, ended_ = false;
};

void readMeditVertices(MeditTokens& f, TetMesh& tet) {
  const long long n = f.integer("the number of vertices");
  checkCount(f.where(), "vertices", n, 2, f.remaining());
  for (long long i = 0; i < n; ++i) {
    const std::string what = "a coordinate of vertex " + std::to_string(i + 1);
    Eigen::Vector3d p;
    for (int c = 0; c < 3; ++c) p[c] = f.number(what);
    const std::string where = f.where();
    f.number("the reference label of vertex " + std::to_string(i + 1));
    if (!p.allFinite()) {
      throw InvalidMesh(where + ": vertex " + std::to_string(i + 1) +
                        " has a non-finite coordinate");
    }
    tet.points.push_back(p);
  }
}

void readMeditTets(MeditTokens& f, TetMesh& tet, std::vector<int>& lines) {
  const long long m = f.integer("the number of tetrahedra");
  checkCount(f.where(), "tetrahedra", m, 2, f.remaining());
  for (long long k = 0; k < m; ++k) {
    const std::string what = "a vertex index of tet " + std::to_string(k + 1);
    std::array<int, 4> t{};
    int line = 0;
    for (int j = 0; j < 4; ++j) {
      const long long v = f.integer(what);
      if (j == 0) line = f.line();
      t[j] = static_cast<int>(std::clamp(v, -1LL, 2000000000LL)) - 1;
    }
    f.number("the reference label of tet " + std::to_string(k + 1));
    tet.tets.push_back(t);
    lines.push_back(line);
  }
}

}  // namespace

TetMesh parseMedit(std::string_view text, const std::string& source) {
  MeditTokens f(withoutBom(text), source);
  TetMesh tet;
  std::vector<int> tetLines;
  bool haveVertices = false, haveTets = false;
  while (!f.atEnd()) {
    const std::string_view kwTok = f.next("a keyword");
    const std::string kw = lower(kwTok);
    if (isNumber(kwTok)) {
      throw InvalidMesh(f.where() + ": expected a keyword, got " + quote(kwTok) +
                        " (too many entries in a block?)");
    }
    if (kw == "end") break;
    if (kw == "meshversionformatted") {
      f.integer("a version number");
    } else if (kw == "dimension") {
      const long long d = f.integer("the dimension");
      if (d != 3) {
        throw InvalidMesh(f.where() + ": only 3D Medit meshes are supported (Dimension " +
                          std::to_string(d) + ")");
      }
    } else if (kw == "vertices") {
      if (haveVertices) throw InvalidMesh(f.where() + ": second Vertices block");
      haveVertices = true;
      readMeditVertices(f, tet);
    } else if (kw == "tetrahedra") {
      if (haveTets) throw InvalidMesh(f.where() + ": second Tetrahedra block");
      haveTets = true;
      readMeditTets(f, tet, tetLines);
    } else {
      // Any other block (Triangles, Edges, Corners, Normals, ...): a count and numbers.
      while (!f.atEnd() && isNumber(f.peek(""))) f.next("");
    }
  }
  if (!haveVertices) throw InvalidMesh(source + ": no Vertices block");
  if (tet.tets.empty()) {
    throw InvalidMesh(source + ": no tetrahedra (only the Tetrahedra block is read)");
  }
  const int n = static_cast<int>(tet.points.size());
  for (size_t k = 0; k < tet.tets.size(); ++k) {
    for (int v : tet.tets[k]) {
      if (v < 0 || v >= n) {
        throw InvalidMesh(source + ":" + std::to_string(tetLines[k]) + ": tet " +
                          std::to_string(k + 1) + " has vertex index " + std::to_string(v + 1) +
                          " out of range 1.." + std::to_string(n));
      }
    }
  }
  return tet;
}

// ---------------------------------------------------------------------------------------
// TetGen .node / .ele

namespace {

/// Field `i` of a TetGen header line (0 when the line ends before it): an integer in [0, most].
long long tetgenHeaderField(const std::string& where, const std::vector<std::string_view>& l,
                            size_t i, const char* what, long long most) {
  if (i >= l.size()) return 0;
  const auto v = parseInt(l[i]);
  if (!v || *v < 0 || *v > most) {
    throw InvalidMesh(where + ": the header's " + what + " count is " + quote(l[i]) +
                      " (an integer from 0 to " + std::to_string(most) + ")");
  }
  return *v;
}

int readTetgenNodes(std::string_view text, const std::string& source, TetMesh& tet) {
  Scanner f(text, source);
  std::vector<std::string_view> l;
  if (!f.line(l)) throw InvalidMesh(source + ": empty file");
  const long long n = count(f.where(), l[0], "point");
  const auto dim = l.size() > 1 ? parseInt(l[1]) : std::optional<long long>(3);
  if (!dim || *dim != 3) throw InvalidMesh(f.where() + ": only 3D TetGen meshes are supported");
  // Each point line: its index, x y z, the attributes and the boundary marker the header names.
  const long long attributes = tetgenHeaderField(f.where(), l, 2, "attributes", 1000);
  const long long markers = tetgenHeaderField(f.where(), l, 3, "boundary markers", 1);
  const size_t values = static_cast<size_t>(4 + attributes + markers);
  checkCount(f.where(), "points", n, 2, f.remaining());
  int firstIndex = 0;
  for (long long i = 0; i < n; ++i) {
    if (!f.line(l)) {
      throw InvalidMesh(source + ": expected " + std::to_string(n) + " points, found " +
                        std::to_string(i));
    }
    const auto id = parseInt(l[0]);
    if (i == 0 && id) firstIndex = static_cast<int>(*id);
    if (!id || *id != firstIndex + i || (firstIndex != 0 && firstIndex != 1)) {
      throw InvalidMesh(f.where() + ": expected point index " +
                        std::to_string(i == 0 ? 0 : firstIndex + i) + ", got " + quote(l[0]));
    }
    if (l.size() != values) {
      throw InvalidMesh(f.where() + ": a point line of " + std::to_string(l.size()) +
                        " values; the header says " + std::to_string(values) + " (index, x y z, " +
                        std::to_string(attributes) + " attributes, " + std::to_string(markers) +
                        " boundary markers)");
    }
    Eigen::Vector3d p;
    for (int c = 0; c < 3; ++c) p[c] = coordinate(l[c + 1], [&] { return f.where(); }, *id);
    tet.points.push_back(p);
  }
  if (f.line(l))
    throw InvalidMesh(f.where() + ": more data after the " + std::to_string(n) +
                      " points the header declares");
  return firstIndex;
}

void readTetgenTets(std::string_view text, const std::string& source, int firstIndex,
                    TetMesh& tet) {
  Scanner f(text, source);
  std::vector<std::string_view> l;
  if (!f.line(l)) throw InvalidMesh(source + ": empty file");
  const long long m = count(f.where(), l[0], "tet");
  if (m == 0) throw InvalidMesh(source + ": no tetrahedra");
  // Each tet line: its index, its corners (4, or 10 for quadratic tets: the first 4 are the
  // corners) and the attributes the header names.
  const long long corners =
      l.size() > 1 ? tetgenHeaderField(f.where(), l, 1, "nodes per tet", 10) : 4;
  if (corners != 4 && corners != 10)
    throw InvalidMesh(f.where() + ": " + std::to_string(corners) + " nodes per tet (4 or 10)");
  const long long attributes = tetgenHeaderField(f.where(), l, 2, "attributes", 1000);
  const size_t values = static_cast<size_t>(1 + corners + attributes);
  checkCount(f.where(), "tets", m, 2, f.remaining());
  const long long n = static_cast<long long>(tet.points.size());
  for (long long k = 0; k < m; ++k) {
    if (!f.line(l)) {
      throw InvalidMesh(source + ": expected " + std::to_string(m) + " tets, found " +
                        std::to_string(k));
    }
    if (l.size() != values) {
      throw InvalidMesh(f.where() + ": a tet line of " + std::to_string(l.size()) +
                        " values; the header says " + std::to_string(values) + " (index, " +
                        std::to_string(corners) + " nodes, " + std::to_string(attributes) +
                        " attributes)");
    }
    std::array<int, 4> t{};
    for (int j = 0; j < 4; ++j) {
      const auto v = parseInt(l[j + 1]);
      if (!v || *v < firstIndex || *v >= firstIndex + n) {
        throw InvalidMesh(f.where() + ": tet " + std::string(l[0]) + " has vertex index " +
                          quote(l[j + 1]) + " out of range " + std::to_string(firstIndex) + ".." +
                          std::to_string(firstIndex + n - 1));
      }
      t[j] = static_cast<int>(*v - firstIndex);
    }
    tet.tets.push_back(t);
  }
  if (f.line(l))
    throw InvalidMesh(f.where() + ": more data after the " + std::to_string(m) +
                      " tets the header declares");
}

}  // namespace

TetMesh parseTetgen(std::string_view node, const std::string& nodeSource, std::string_view ele,
                    const std::string& eleSource) {
  TetMesh tet;
  const int firstIndex = readTetgenNodes(withoutBom(node), nodeSource, tet);
  readTetgenTets(withoutBom(ele), eleSource, firstIndex, tet);
  return tet;
}

// ---------------------------------------------------------------------------------------
// Triangle meshes from polygons

namespace {

/// An OpenMesh importer that counts the vertices OpenMesh duplicates to split off faces it
/// cannot add (non-manifold).
class SplittingImporter : public OpenMesh::IO::ImporterT<TriMesh> {
 public:
  using Base = OpenMesh::IO::ImporterT<TriMesh>;
  using Base::add_face;
  explicit SplittingImporter(TriMesh& mesh) : Base(mesh), mesh_(mesh) {}

  OpenMesh::FaceHandle add_face(const VHandles& indices) override {
    const size_t before = mesh_.n_vertices();
    const auto fh = Base::add_face(indices);
    if (mesh_.n_vertices() > before) {
      duplicated += static_cast<int>(mesh_.n_vertices() - before);
      ++splitFaces;
      // OpenMesh copies each corner of the face, in order (ImporterT::add_face); the copy's
      // position confirms which, else names the corner it repeats.
      for (size_t j = 0; before + j < mesh_.n_vertices(); ++j) {
        const auto at = mesh_.point(OpenMesh::VertexHandle(static_cast<int>(before + j)));
        const auto same = [&](OpenMesh::VertexHandle v) {  // bit for bit: a NaN is a copy too
          return std::memcmp(mesh_.point(v).data(), at.data(), sizeof(at)) == 0;
        };
        int from = -1;
        if (j < indices.size() && same(indices[j])) from = indices[j].idx();
        for (size_t c = 0; from < 0 && c < indices.size(); ++c)
          if (same(indices[c])) from = indices[c].idx();
        if (from < 0) throw std::logic_error("buildTriMesh: a vertex copy repeats no corner");
        copied.push_back(from);
      }
    }
    return fh;
  }

  int duplicated = 0;
  int splitFaces = 0;
  std::vector<int> copied;  ///< the vertex each appended copy repeats

 private:
  TriMesh& mesh_;
};

/// Faces split off as non-manifold that are accepted whatever the size of the mesh.
constexpr size_t kMaxSplitFaces = 1000;

/// Throws InvalidMesh for a face with fewer than 3 vertices, an index outside
/// [0, numVertices) or a repeated vertex.
void checkFace(const std::string& source, const RawFace& f, size_t k, long long numVertices,
               int base) {
  const auto where = [&] {
    return source + (f.line > 0 ? ":" + std::to_string(f.line) : "") + ": face " +
           std::to_string(k + base);
  };
  if (f.ids.size() < 3) throw InvalidMesh(where() + " has fewer than 3 vertices");
  for (size_t j = 0; j < f.ids.size(); ++j) {
    if (f.ids[j] < 0 || f.ids[j] >= numVertices) {
      throw InvalidMesh(where() + " has vertex index " + std::to_string(f.ids[j] + base) +
                        " out of range " + std::to_string(base) + ".." +
                        std::to_string(numVertices - 1 + base));
    }
  }
  const auto repeated = [&](long long id) {
    throw InvalidMesh(where() + " is degenerate: vertex " + std::to_string(id + base) +
                      " appears twice");
  };
  if (f.ids.size() == 3) {  // the common case, without a copy
    const long long a = f.ids[0], b = f.ids[1], c = f.ids[2];
    if (a == b || a == c) repeated(a);
    if (b == c) repeated(b);
    return;
  }
  std::vector<long long> sorted = f.ids;
  std::sort(sorted.begin(), sorted.end());
  const auto dup = std::adjacent_find(sorted.begin(), sorted.end());
  if (dup != sorted.end()) repeated(*dup);
}

}  // namespace

namespace {
OpenMesh::mostream& omStream(int i) { return i == 0 ? ::omerr() : i == 1 ? ::omlog() : ::omout(); }
}  // namespace

OpenMeshQuiet::OpenMeshQuiet() {
  for (int i = 0; i < 3; ++i) {
    was_[i] = omStream(i).is_enabled();
    omStream(i).disable();
  }
}

OpenMeshQuiet::~OpenMeshQuiet() {
  for (int i = 0; i < 3; ++i)
    if (was_[i]) omStream(i).enable();
}

std::unique_ptr<TriMesh> buildTriMesh(const RawMesh& raw, const std::string& source) {
  BuildOrigin origin;
  return buildTriMesh(raw, source, origin);
}

bool plyReservedName(bool vertex, const std::string& name) {
  static const std::set<std::string> vertexNames = {
      "x",           "y",    "z",     "nx",        "ny",        "nz",          "red",
      "green",       "blue", "alpha", "quality",   "radius",    "flags",       "s",
      "t",           "u",    "v",     "texture_u", "texture_v", "diffuse_red", "diffuse_green",
      "diffuse_blue"};
  static const std::set<std::string> faceNames = {
      "vertex_indices", "vertex_index", "quality", "red",      "green",
      "blue",           "alpha",        "flags",   "texcoord", "texnumber"};
  return (vertex ? vertexNames : faceNames).count(name) > 0;
}

Mesh buildMesh(RawMesh raw, const std::string& source) {
  BuildOrigin origin;
  Mesh mesh(buildTriMesh(raw, source, origin));
  const bool traced =
      raw.points.size() + origin.copied.size() == static_cast<size_t>(mesh.numVertices()) &&
      (origin.faceOf.empty() ? raw.faces.size() : origin.faceOf.size()) ==
          static_cast<size_t>(mesh.numElements());
  if (!traced && (!raw.vertexValues.empty() || !raw.faceValues.empty()))
    throw std::logic_error("buildMesh: the origin of the built mesh is not known");
  std::string dropped;  // the values whose count is not the file's (two vertex elements)
  const auto attach = [&](bool vertex, RawMesh::Values& v) {
    const size_t fileCount = vertex ? raw.points.size() : raw.faces.size();
    if (v.values.size() != fileCount) {
      dropped += (dropped.empty() ? "" : ", ") + quote(v.name);
      return;
    }
    const int count = vertex ? mesh.numVertices() : mesh.numElements();
    Eigen::VectorXd values(count);
    for (int i = 0; i < count; ++i) {
      const size_t from = vertex ? (static_cast<size_t>(i) < fileCount
                                        ? i
                                        : origin.copied[static_cast<size_t>(i) - fileCount])
                                 : (origin.faceOf.empty() ? i : origin.faceOf[i]);
      values[i] = v.values[from];
    }
    std::vector<double>().swap(v.values);  // released before the mesh takes its copy
    if (vertex)
      mesh.setVertexScalar(v.name, values);
    else
      mesh.setElementScalar(v.name, values);
  };
  for (auto& v : raw.vertexValues) attach(true, v);
  for (auto& v : raw.faceValues) attach(false, v);
  if (!dropped.empty())
    warn(source + ": the values of " + dropped +
         " are not kept: the file has another count of them than of its vertices or faces");
  return mesh;
}

std::unique_ptr<TriMesh> buildTriMesh(const RawMesh& raw, const std::string& source,
                                      BuildOrigin& origin) {
  origin = {};
  OpenMeshQuiet quiet;
  const long long n = static_cast<long long>(raw.points.size());
  if (n > 2000000000LL) throw InvalidMesh(source + ": more than 2e9 vertices");
  for (size_t k = 0; k < raw.faces.size(); ++k) checkFace(source, raw.faces[k], k, n, raw.base);
  if (std::all_of(raw.faces.begin(), raw.faces.end(),
                  [](const RawFace& f) { return f.ids.size() == 3; })) {
    // Most files: triangles making an oriented manifold, built in one pass.
    std::vector<std::array<int, 3>> triangles(raw.faces.size());
    for (size_t k = 0; k < raw.faces.size(); ++k)
      for (size_t j = 0; j < 3; ++j) triangles[k][j] = static_cast<int>(raw.faces[k].ids[j]);
    if (auto built = buildOrientedManifold(raw.points, triangles)) return built;
  }
  auto mesh = std::make_unique<TriMesh>();  // on the heap: a Mesh takes it over without a copy
  TriMesh& tri = *mesh;
  // Room for what the file holds (polygons and split faces may add a little): no doubling of
  // OpenMesh's arrays while they fill, which would briefly hold three times their size.
  tri.reserve(raw.points.size(), raw.faces.size() * 3 / 2 + 3, raw.faces.size());
  SplittingImporter importer(tri);
  for (const auto& p : raw.points) importer.add_vertex(OpenMesh::Vec3d(p[0], p[1], p[2]));
  int polygons = 0, triangles = 0;
  unsigned long long polygonWork = 0;  // against kMaxPolygonWork
  std::vector<OpenMesh::VertexHandle> corners(3);
  for (size_t k = 0; k < raw.faces.size(); ++k) {
    const RawFace& f = raw.faces[k];
    if (f.ids.size() == 3) {  // the common case, without a list of triangles
      for (int j = 0; j < 3; ++j) corners[j] = OpenMesh::VertexHandle(static_cast<int>(f.ids[j]));
      importer.add_face(corners);
      if (!origin.faceOf.empty()) origin.faceOf.push_back(static_cast<int>(k));
    } else {
      const std::string where = source + (f.line > 0 ? ":" + std::to_string(f.line) : "") +
                                ": face " + std::to_string(k + raw.base);
      // A polygon over kMaxPolygonCorners gets triangulatePolygon's own error below.
      const unsigned long long n = std::min<size_t>(f.ids.size(), kMaxPolygonCorners);
      polygonWork += n * n;
      if (polygonWork > kMaxPolygonWork) {
        throw InvalidMesh(where +
                          ": too many large polygons (their squared corner counts add "
                          "up to " +
                          std::to_string(polygonWork) + " so far, more than " +
                          std::to_string(kMaxPolygonWork) +
                          ", about 4,000 faces of 256 corners); triangulate the file first");
      }
      const std::vector<std::array<long long, 3>> tris =
          triangulatePolygon(raw.points, f.ids, where);
      ++polygons;
      triangles += static_cast<int>(tris.size());
      if (origin.faceOf.empty()) {  // the faces before were the file's, one to one
        origin.faceOf.resize(tri.n_faces());
        std::iota(origin.faceOf.begin(), origin.faceOf.end(), 0);
      }
      for (const auto& t : tris) {
        for (int j = 0; j < 3; ++j) corners[j] = OpenMesh::VertexHandle(static_cast<int>(t[j]));
        importer.add_face(corners);
        origin.faceOf.push_back(static_cast<int>(k));
      }
    }
    // Each split face copies its vertices: a file of repeated faces would grow ~100 bytes of
    // memory per byte read. A few non-manifold faces are common, a mesh made of them is not.
    const size_t split = static_cast<size_t>(importer.splitFaces);
    if (split > std::max<size_t>(kMaxSplitFaces, raw.faces.size() / 10)) {
      const std::string where = source + (f.line > 0 ? ":" + std::to_string(f.line) : "");
      throw InvalidMesh(where + ": face " + std::to_string(k + raw.base) + ": " +
                        std::to_string(split) +
                        " faces so far would make the mesh non-manifold (repeated faces, or "
                        "more than two faces on an edge); at most 1000 or 10% are accepted");
    }
  }
  if (polygons > 0) {
    warn(source + ": triangulated " + std::to_string(polygons) + " polygonal faces into " +
         std::to_string(triangles) + " triangles");
  }
  origin.copied = std::move(importer.copied);
  if (importer.splitFaces > 0) {
    warn(source + ": " + std::to_string(importer.splitFaces) +
         " faces would make the mesh non-manifold; each was split off with its own copies of "
         "its vertices (" +
         std::to_string(importer.duplicated) + " vertices appended after the file's " +
         std::to_string(n) +
         "), which leaves it a piece of its own that a deformation needs handles on");
  }
  return mesh;
}

}  // namespace diffreg
