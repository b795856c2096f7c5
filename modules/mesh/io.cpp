#include "mesh/io.h"

#include "core/colormap.h"
#include "core/error.h"
#include "core/log.h"

#include <Eigen/Geometry>
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/System/omstream.hh>

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <optional>
#include <random>
#include <sstream>
#include <string_view>

namespace diffreg {
namespace {

namespace fs = std::filesystem;

const char* const kReadable = "obj, off, ply, om, mesh, node, ele";

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

std::string quote(const std::string& s) { return "'" + s + "'"; }

std::string num(double v) {
  std::ostringstream ss;
  ss << v;
  return ss.str();
}

/// Silences OpenMesh's own console output (omerr, omlog, omout) while alive: every problem
/// it would print is detected and reported by this file instead.
class OpenMeshQuiet {
 public:
  OpenMeshQuiet() {
    for (int i = 0; i < 3; ++i) {
      was_[i] = stream(i).is_enabled();
      stream(i).disable();
    }
  }
  ~OpenMeshQuiet() {
    for (int i = 0; i < 3; ++i)
      if (was_[i]) stream(i).enable();
  }
  OpenMeshQuiet(const OpenMeshQuiet&) = delete;
  OpenMeshQuiet& operator=(const OpenMeshQuiet&) = delete;

 private:
  static OpenMesh::mostream& stream(int i) {
    return i == 0 ? ::omerr() : i == 1 ? ::omlog() : ::omout();
  }
  bool was_[3] = {true, true, true};
};

/// Throws IoError unless `path` is a readable regular file.
void requireReadable(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw IoError("cannot open " + quote(path) + ": no such file");
  if (fs::is_directory(path, ec)) throw IoError("cannot read " + quote(path) + ": is a directory");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError("cannot open " + quote(path) + ": " + std::strerror(errno));
}

std::string readText(const std::string& path) {
  requireReadable(path);
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw IoError("cannot read " + quote(path));
  return ss.str();
}

std::optional<double> parseDouble(std::string_view s) {
  if (!s.empty() && s[0] == '+') s.remove_prefix(1);
  double v = 0.0;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  if (r.ec == std::errc::result_out_of_range && r.ptr == s.data() + s.size()) {
    return std::strtod(std::string(s).c_str(), nullptr);  // +-HUGE_VAL on overflow, ~0 below
  }
  if (r.ec != std::errc() || r.ptr != s.data() + s.size()) return std::nullopt;
  return v;
}

std::optional<long long> parseInt(std::string_view s) {
  if (!s.empty() && s[0] == '+') s.remove_prefix(1);
  long long v = 0;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  if (r.ec != std::errc() || r.ptr != s.data() + s.size()) return std::nullopt;
  return v;
}

// ---------------------------------------------------------------------------------------
// Whitespace-separated tokens with line numbers ('#' starts a comment), for Medit and TetGen.

struct Token {
  std::string_view text;
  int line = 0;
};

class TokenFile {
 public:
  explicit TokenFile(const std::string& path) : path_(path), text_(readText(path)) {
    int line = 1;
    bool comment = false;
    size_t start = std::string::npos;
    for (size_t i = 0; i <= text_.size(); ++i) {
      const char c = i < text_.size() ? text_[i] : '\n';
      const bool space = std::isspace(static_cast<unsigned char>(c)) || c == '#' || comment;
      if (space && start != std::string::npos) {
        tokens_.push_back({std::string_view(text_).substr(start, i - start), line});
        start = std::string::npos;
      }
      if (c == '#') comment = true;
      if (c == '\n') {
        ++line;
        comment = false;
      }
      if (!space && start == std::string::npos) start = i;
    }
  }

  const std::string& path() const { return path_; }
  bool atEnd() const { return pos_ >= tokens_.size(); }
  /// The next token without consuming it.
  const Token& peek(const std::string& what) const {
    if (atEnd()) throw InvalidMesh(path_ + ": unexpected end of file, expected " + what);
    return tokens_[pos_];
  }
  /// The next token; `what` says what was expected, for the end-of-file message.
  const Token& next(const std::string& what) {
    if (atEnd()) throw InvalidMesh(path_ + ": unexpected end of file, expected " + what);
    return tokens_[pos_++];
  }
  std::string where(const Token& t) const { return path_ + ":" + std::to_string(t.line); }

  double number(const std::string& what) {
    const Token& t = next(what);
    const auto v = parseDouble(t.text);
    if (!v) {
      throw InvalidMesh(where(t) + ": expected " + what + ", got " + quote(std::string(t.text)));
    }
    return *v;
  }
  long long integer(const std::string& what) {
    const Token& t = next(what);
    const auto v = parseInt(t.text);
    if (!v) {
      throw InvalidMesh(where(t) + ": expected " + what + " (an integer), got " +
                        quote(std::string(t.text)));
    }
    return *v;
  }
  long long count(const std::string& what) {
    const Token& t = peek(what);
    const long long n = integer(what);
    if (n < 0 || n > 1000000000LL) throw InvalidMesh(where(t) + ": bad " + what);
    return n;
  }
  /// Groups the remaining tokens by line.
  std::vector<std::vector<Token>> lines() {
    std::vector<std::vector<Token>> out;
    for (; !atEnd(); ++pos_) {
      if (out.empty() || out.back().back().line != tokens_[pos_].line) out.emplace_back();
      out.back().push_back(tokens_[pos_]);
    }
    return out;
  }

 private:
  std::string path_;
  std::string text_;
  std::vector<Token> tokens_;
  size_t pos_ = 0;
};

double det3(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
            const Eigen::Vector3d& d) {
  return (b - a).dot((c - a).cross(d - a));
}

/// A tet file whose tets are all negatively oriented uses the opposite convention: flip all.
void orientTets(TetMesh& tet, const std::string& path) {
  if (tet.tets.empty()) return;
  const int n = static_cast<int>(tet.points.size());
  for (const auto& t : tet.tets) {
    for (int v : t)
      if (v < 0 || v >= n) return;  // validateMesh reports it
    if (!(det3(tet.points[t[0]], tet.points[t[1]], tet.points[t[2]], tet.points[t[3]]) < 0.0))
      return;
  }
  for (auto& t : tet.tets) std::swap(t[2], t[3]);
  warn(path + ": all tets are negatively oriented; reoriented them (swapped two vertices each)");
}

// ---------------------------------------------------------------------------------------
// Medit .mesh

TetMesh readMedit(const std::string& path) {
  TokenFile f(path);
  TetMesh tet;
  std::vector<int> tetLines;
  bool haveVertices = false, haveTets = false;
  while (!f.atEnd()) {
    const Token& kwTok = f.next("a keyword");
    const std::string kw = lower(std::string(kwTok.text));
    if (parseDouble(kwTok.text)) {
      throw InvalidMesh(f.where(kwTok) + ": expected a keyword, got " +
                        quote(std::string(kwTok.text)) + " (too many entries in a block?)");
    }
    if (kw == "end") break;
    if (kw == "meshversionformatted") {
      f.integer("a version number");
    } else if (kw == "dimension") {
      const Token& t = f.peek("the dimension");
      const long long d = f.integer("the dimension");
      if (d != 3) {
        throw InvalidMesh(f.where(t) + ": only 3D Medit meshes are supported (Dimension " +
                          std::to_string(d) + ")");
      }
    } else if (kw == "vertices") {
      if (haveVertices) throw InvalidMesh(f.where(kwTok) + ": second Vertices block");
      haveVertices = true;
      const long long n = f.count("the number of vertices");
      tet.points.resize(n);
      for (long long i = 0; i < n; ++i) {
        const std::string what = "a coordinate of vertex " + std::to_string(i + 1);
        const Token& first = f.peek(what);
        for (int c = 0; c < 3; ++c) tet.points[i][c] = f.number(what);
        f.number("the reference label of vertex " + std::to_string(i + 1));
        if (!tet.points[i].allFinite()) {
          throw InvalidMesh(f.where(first) + ": vertex " + std::to_string(i + 1) +
                            " has a non-finite coordinate");
        }
      }
    } else if (kw == "tetrahedra") {
      if (haveTets) throw InvalidMesh(f.where(kwTok) + ": second Tetrahedra block");
      haveTets = true;
      const long long m = f.count("the number of tetrahedra");
      tet.tets.resize(m);
      tetLines.resize(m);
      for (long long k = 0; k < m; ++k) {
        const std::string what = "a vertex index of tet " + std::to_string(k + 1);
        tetLines[k] = f.peek(what).line;
        for (int j = 0; j < 4; ++j) {
          const long long v = f.integer(what);
          tet.tets[k][j] = static_cast<int>(std::clamp(v, -1LL, 2000000000LL)) - 1;
        }
        f.number("the reference label of tet " + std::to_string(k + 1));
      }
    } else {
      // Any other block (Triangles, Edges, Corners, Normals, ...): a count and numbers.
      while (!f.atEnd() && parseDouble(f.peek("").text)) f.next("");
    }
  }
  if (!haveVertices) throw InvalidMesh(path + ": no Vertices block");
  if (tet.tets.empty()) {
    throw InvalidMesh(path + ": no tetrahedra (only the Tetrahedra block is read)");
  }
  const int n = static_cast<int>(tet.points.size());
  for (size_t k = 0; k < tet.tets.size(); ++k) {
    for (int v : tet.tets[k]) {
      if (v < 0 || v >= n) {
        throw InvalidMesh(path + ":" + std::to_string(tetLines[k]) + ": tet " +
                          std::to_string(k + 1) + " has vertex index " + std::to_string(v + 1) +
                          " out of range 1.." + std::to_string(n));
      }
    }
  }
  orientTets(tet, path);
  return tet;
}

// ---------------------------------------------------------------------------------------
// TetGen .node / .ele

TetMesh readTetgen(const std::string& path) {
  const std::string ext = extensionOf(path);
  const std::string base = path.substr(0, path.size() - ext.size() - 1);
  const std::string nodePath = base + ".node", elePath = base + ".ele";
  for (const std::string& p : {nodePath, elePath}) {
    std::error_code ec;
    if (!fs::exists(p, ec)) {
      throw IoError("cannot open " + quote(p) + " (TetGen meshes need both .node and .ele)");
    }
  }
  TetMesh tet;
  int firstIndex = 0;
  {
    TokenFile f(nodePath);
    const auto lines = f.lines();
    if (lines.empty()) throw InvalidMesh(nodePath + ": empty file");
    const auto& head = lines[0];
    const auto n = parseInt(head[0].text);
    const auto dim = head.size() > 1 ? parseInt(head[1].text) : std::optional<long long>(3);
    if (!n || *n < 0) throw InvalidMesh(f.where(head[0]) + ": expected the number of points");
    if (!dim || *dim != 3) {
      throw InvalidMesh(f.where(head[0]) + ": only 3D TetGen meshes are supported");
    }
    if (static_cast<long long>(lines.size()) - 1 < *n) {
      throw InvalidMesh(nodePath + ": expected " + std::to_string(*n) + " points, found " +
                        std::to_string(lines.size() - 1));
    }
    tet.points.resize(*n);
    for (long long i = 0; i < *n; ++i) {
      const auto& l = lines[i + 1];
      const auto id = parseInt(l[0].text);
      if (i == 0 && id) firstIndex = static_cast<int>(*id);
      if (!id || *id != firstIndex + i || (firstIndex != 0 && firstIndex != 1)) {
        throw InvalidMesh(f.where(l[0]) + ": expected point index " +
                          std::to_string(i == 0 ? 0 : firstIndex + i) + ", got " +
                          quote(std::string(l[0].text)));
      }
      if (l.size() < 4) throw InvalidMesh(f.where(l[0]) + ": point needs 3 coordinates");
      for (int c = 0; c < 3; ++c) {
        const auto v = parseDouble(l[c + 1].text);
        if (!v) {
          throw InvalidMesh(f.where(l[0]) + ": expected a coordinate, got " +
                            quote(std::string(l[c + 1].text)));
        }
        tet.points[i][c] = *v;
      }
      if (!tet.points[i].allFinite()) {
        throw InvalidMesh(f.where(l[0]) + ": point " + std::to_string(*id) +
                          " has a non-finite coordinate");
      }
    }
  }
  {
    TokenFile f(elePath);
    const auto lines = f.lines();
    if (lines.empty()) throw InvalidMesh(elePath + ": empty file");
    const auto m = parseInt(lines[0][0].text);
    if (!m || *m < 0) throw InvalidMesh(f.where(lines[0][0]) + ": expected the number of tets");
    if (*m == 0) throw InvalidMesh(elePath + ": no tetrahedra");
    if (static_cast<long long>(lines.size()) - 1 < *m) {
      throw InvalidMesh(elePath + ": expected " + std::to_string(*m) + " tets, found " +
                        std::to_string(lines.size() - 1));
    }
    const int n = static_cast<int>(tet.points.size());
    tet.tets.resize(*m);
    for (long long k = 0; k < *m; ++k) {
      const auto& l = lines[k + 1];
      if (l.size() < 5) throw InvalidMesh(f.where(l[0]) + ": tet needs 4 vertex indices");
      for (int j = 0; j < 4; ++j) {
        const auto v = parseInt(l[j + 1].text);
        if (!v || *v < firstIndex || *v >= firstIndex + n) {
          throw InvalidMesh(f.where(l[0]) + ": tet " + std::string(l[0].text) +
                            " has vertex index " + quote(std::string(l[j + 1].text)) +
                            " out of range " + std::to_string(firstIndex) + ".." +
                            std::to_string(firstIndex + n - 1));
        }
        tet.tets[k][j] = static_cast<int>(*v - firstIndex);
      }
    }
  }
  orientTets(tet, path);
  return tet;
}

// ---------------------------------------------------------------------------------------
// OBJ / OFF / PLY / OM through OpenMesh

/// An OpenMesh importer that also records every face exactly as the reader passed it, and how
/// many vertices OpenMesh duplicated to split off faces it could not add (non-manifold).
class RecordingImporter : public OpenMesh::IO::ImporterT<TriMesh> {
 public:
  using Base = OpenMesh::IO::ImporterT<TriMesh>;
  using Base::add_face;
  explicit RecordingImporter(TriMesh& mesh) : Base(mesh), mesh_(mesh) {}

  OpenMesh::FaceHandle add_face(const VHandles& indices) override {
    std::vector<int> face;
    face.reserve(indices.size());
    for (auto h : indices) face.push_back(h.idx());
    faces.push_back(std::move(face));
    const size_t before = mesh_.n_vertices();
    const auto fh = Base::add_face(indices);
    if (mesh_.n_vertices() > before) {
      duplicated += static_cast<int>(mesh_.n_vertices() - before);
      ++splitFaces;
    }
    return fh;
  }

  std::vector<std::vector<int>> faces;
  int duplicated = 0;
  int splitFaces = 0;

 private:
  TriMesh& mesh_;
};

/// A face as written in the file: 0-based vertex ids and its line (0 when unknown).
struct RawFace {
  int line = 0;
  std::vector<long long> ids;
};

/// Throws InvalidMesh for a face with fewer than 3 vertices, an index outside
/// [0, numVertices) or a repeated vertex. `base` is the file's first index (OBJ: 1), used
/// for the face and vertex numbers in messages.
void checkFaces(const std::string& path, const std::vector<RawFace>& faces, long long numVertices,
                int base) {
  for (size_t k = 0; k < faces.size(); ++k) {
    const RawFace& f = faces[k];
    const std::string where = path + (f.line > 0 ? ":" + std::to_string(f.line) : "") + ": face " +
                              std::to_string(k + base);
    if (f.ids.size() < 3) throw InvalidMesh(where + " has fewer than 3 vertices");
    for (size_t j = 0; j < f.ids.size(); ++j) {
      if (f.ids[j] < 0 || f.ids[j] >= numVertices) {
        throw InvalidMesh(where + " has vertex index " + std::to_string(f.ids[j] + base) +
                          " out of range " + std::to_string(base) + ".." +
                          std::to_string(numVertices - 1 + base));
      }
      for (size_t i = 0; i < j; ++i) {
        if (f.ids[i] == f.ids[j]) {
          throw InvalidMesh(where + " is degenerate: vertex " + std::to_string(f.ids[j] + base) +
                            " appears twice");
        }
      }
    }
  }
}

void checkCoordinates(const std::string& where, const std::vector<std::string_view>& coords,
                      long long vertex) {
  if (coords.size() < 3) throw InvalidMesh(where + ": vertex needs 3 coordinates");
  for (int c = 0; c < 3; ++c) {
    const auto v = parseDouble(coords[c]);
    if (!v)
      throw InvalidMesh(where + ": expected a coordinate, got " + quote(std::string(coords[c])));
    if (!std::isfinite(*v)) {
      throw InvalidMesh(where + ": vertex " + std::to_string(vertex) +
                        " has a non-finite coordinate");
    }
  }
}

/// Checks an OBJ file's vertex and face lines before OpenMesh reads it (its reader silently
/// drops faces with a repeated vertex and reads bad numbers as garbage); returns the faces.
std::vector<RawFace> checkObj(const std::string& path) {
  TokenFile f(path);
  std::vector<RawFace> faces;
  long long numVertices = 0;
  for (const auto& line : f.lines()) {
    const std::string_view key = line[0].text;
    const std::string where = f.where(line[0]);
    if (key == "v") {
      ++numVertices;
      std::vector<std::string_view> coords;
      for (size_t i = 1; i < line.size(); ++i) coords.push_back(line[i].text);
      checkCoordinates(where, coords, numVertices);
    } else if (key == "f") {
      RawFace face{line[0].line, {}};
      for (size_t i = 1; i < line.size(); ++i) {
        const std::string_view tok = line[i].text;
        const auto id = parseInt(tok.substr(0, tok.find('/')));
        if (!id || *id == 0) {
          throw InvalidMesh(where + ": face " + std::to_string(faces.size() + 1) +
                            " has a bad vertex reference " + quote(std::string(tok)));
        }
        face.ids.push_back(*id > 0 ? *id - 1 : numVertices + *id);
      }
      faces.push_back(std::move(face));
    }
  }
  checkFaces(path, faces, numVertices, 1);
  return faces;
}

/// Same for ASCII OFF (binary OFF is left to OpenMesh): returns the faces, or nothing.
std::optional<std::vector<RawFace>> checkOff(const std::string& path) {
  TokenFile f(path);
  auto lines = f.lines();
  if (lines.empty()) throw InvalidMesh(path + ": empty file");
  const std::string head(lines[0][0].text);
  if (head.size() < 3 || head.compare(head.size() - 3, 3, "OFF") != 0) {
    throw InvalidMesh(f.where(lines[0][0]) + ": not an OFF file (no OFF header)");
  }
  for (const auto& t : lines[0])
    if (t.text == "BINARY") return std::nullopt;
  // The counts follow the header, on its line or the next.
  std::vector<Token> counts(lines[0].begin() + 1, lines[0].end());
  size_t next = 1;
  if (counts.empty() && lines.size() > 1) counts = lines[next++];
  std::optional<long long> nv, nf;
  if (counts.size() >= 2) {
    nv = parseInt(counts[0].text);
    nf = parseInt(counts[1].text);
  }
  if (!nv || !nf || *nv < 0 || *nf < 0) {
    throw InvalidMesh(path + ": expected the vertex and face counts after the OFF header");
  }
  if (static_cast<long long>(lines.size() - next) < *nv + *nf) {
    throw InvalidMesh(path + ": expected " + std::to_string(*nv) + " vertices and " +
                      std::to_string(*nf) + " faces, the file ends early");
  }
  for (long long i = 0; i < *nv; ++i) {
    const auto& line = lines[next + i];
    std::vector<std::string_view> coords;
    for (const auto& t : line) coords.push_back(t.text);
    checkCoordinates(f.where(line[0]), coords, i);
  }
  std::vector<RawFace> faces(*nf);
  for (long long k = 0; k < *nf; ++k) {
    const auto& line = lines[next + *nv + k];
    faces[k].line = line[0].line;
    const auto size = parseInt(line[0].text);
    if (!size || *size < 0 || static_cast<long long>(line.size()) < 1 + *size) {
      throw InvalidMesh(f.where(line[0]) + ": face " + std::to_string(k) +
                        ": bad vertex count or too few indices");
    }
    for (long long j = 0; j < *size; ++j) {
      const auto id = parseInt(line[1 + j].text);
      if (!id) {
        throw InvalidMesh(f.where(line[0]) + ": face " + std::to_string(k) +
                          ": expected a vertex index, got " + quote(std::string(line[1 + j].text)));
      }
      faces[k].ids.push_back(*id);
    }
  }
  checkFaces(path, faces, *nv, 0);
  return faces;
}

TriMesh readOpenMesh(const std::string& path, const std::string& ext) {
  requireReadable(path);
  std::optional<std::vector<RawFace>> fileFaces;
  if (ext == "obj") fileFaces = checkObj(path);
  if (ext == "off") fileFaces = checkOff(path);
  TriMesh tri;
  RecordingImporter importer(tri);
  OpenMesh::IO::Options opt;
  if (ext == "om") opt += OpenMesh::IO::Options::Custom;  // restore persistent properties
  bool ok = false;
  {
    OpenMeshQuiet quiet;
    ok = OpenMesh::IO::IOManager().read(path, importer, opt);
  }
  if (!ok) throw InvalidMesh(path + ": OpenMesh's " + ext + " reader cannot read it");

  const int fileVertices = static_cast<int>(tri.n_vertices()) - importer.duplicated;
  std::vector<RawFace> faces(importer.faces.size());
  for (size_t k = 0; k < faces.size(); ++k) {
    faces[k].ids.assign(importer.faces[k].begin(), importer.faces[k].end());
  }
  checkFaces(path, faces, fileVertices, 0);
  if (fileFaces && fileFaces->size() != faces.size()) {
    warn(path + ": OpenMesh's reader passed on " + std::to_string(faces.size()) + " of the " +
         std::to_string(fileFaces->size()) + " faces in the file");
  }
  int polygons = 0, triangles = 0;
  for (const auto& face : faces) {
    if (face.ids.size() > 3) {
      ++polygons;
      triangles += static_cast<int>(face.ids.size()) - 2;
    }
  }
  if (polygons > 0) {
    warn(path + ": triangulated " + std::to_string(polygons) + " polygonal faces into " +
         std::to_string(triangles) + " triangles");
  }
  if (importer.splitFaces > 0) {
    warn(path + ": " + std::to_string(importer.splitFaces) +
         " faces would make the mesh non-manifold; each was split off with its own copies of "
         "its vertices (" +
         std::to_string(importer.duplicated) + " vertices appended after the file's " +
         std::to_string(fileVertices) + ")");
  }
  return tri;
}

// ---------------------------------------------------------------------------------------
// Writing

/// Writes through `body` to "<path>.tmp-XXXXXX" beside `path`, then renames it into place.
/// On any failure the temporary file is removed and IoError is thrown.
void writeAtomically(const std::string& path, const std::function<void(std::ostream&)>& body) {
  static const char alphabet[] = "abcdefghijklmnopqrstuvwxyz0123456789";
  std::random_device rd;
  std::mt19937 rng(rd());
  std::string tmp;
  int fd = -1;
  for (int attempt = 0; attempt < 100 && fd < 0; ++attempt) {
    tmp = path + ".tmp-";
    for (int i = 0; i < 6; ++i) tmp += alphabet[rng() % (sizeof(alphabet) - 1)];
    fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0 && errno != EEXIST) {
      throw IoError("cannot write " + quote(path) + ": " + std::strerror(errno));
    }
  }
  if (fd < 0) throw IoError("cannot write " + quote(path) + ": no free temporary name");
  ::close(fd);
  try {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw IoError("cannot write " + quote(tmp));
    body(out);
    out.flush();
    if (!out) throw IoError("cannot write " + quote(path) + ": write failed");
    out.close();
    if (out.fail()) throw IoError("cannot write " + quote(path) + ": close failed");
    if (std::rename(tmp.c_str(), path.c_str()) != 0) {
      throw IoError("cannot write " + quote(path) + ": " + std::strerror(errno));
    }
  } catch (const Error&) {
    std::remove(tmp.c_str());
    throw;
  } catch (const std::exception& e) {
    std::remove(tmp.c_str());
    throw IoError("cannot write " + quote(path) + ": " + e.what());
  }
}

void writeMedit(std::ostream& out, const TetMesh& tet) {
  out << "MeshVersionFormatted 2\nDimension 3\n\nVertices\n" << tet.points.size() << "\n";
  out << std::setprecision(17);
  for (const auto& p : tet.points) out << p[0] << ' ' << p[1] << ' ' << p[2] << " 0\n";
  out << "\nTetrahedra\n" << tet.tets.size() << "\n";
  for (const auto& t : tet.tets) {
    out << t[0] + 1 << ' ' << t[1] + 1 << ' ' << t[2] + 1 << ' ' << t[3] + 1 << " 0\n";
  }
  out << "\nEnd\n";
}

/// ASCII PLY: points (float), optional vertex quality (float) with viridis colours, faces
/// with optional face quality (float).
void writePly(std::ostream& out, const Eigen::MatrixXd& points, const Eigen::MatrixXi& faces,
              const Eigen::VectorXd* vquality, const Eigen::VectorXd* fquality, bool colors) {
  colors = colors && vquality != nullptr;
  out << "ply\nformat ascii 1.0\ncomment diffreg\n";
  out << "element vertex " << points.rows() << "\n";
  out << "property float x\nproperty float y\nproperty float z\n";
  if (vquality) out << "property float quality\n";
  if (colors) out << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  out << "element face " << faces.rows() << "\nproperty list uchar int vertex_indices\n";
  if (fquality) out << "property float quality\n";
  out << "end_header\n" << std::setprecision(9);
  for (int i = 0; i < points.rows(); ++i) {
    out << static_cast<float>(points(i, 0)) << ' ' << static_cast<float>(points(i, 1)) << ' '
        << static_cast<float>(points(i, 2));
    if (vquality) out << ' ' << static_cast<float>((*vquality)[i]);
    if (colors) {
      const auto rgb = viridis((*vquality)[i]);
      out << ' ' << int(rgb[0]) << ' ' << int(rgb[1]) << ' ' << int(rgb[2]);
    }
    out << '\n';
  }
  for (int k = 0; k < faces.rows(); ++k) {
    out << "3 " << faces(k, 0) << ' ' << faces(k, 1) << ' ' << faces(k, 2);
    if (fquality) out << ' ' << static_cast<float>((*fquality)[k]);
    out << '\n';
  }
}

/// The boundary of a tet mesh: faces not shared by two tets, oriented outward, with the tet
/// each belongs to, over the boundary vertices only (kept in increasing id order).
struct Boundary {
  Eigen::MatrixXd points;
  Eigen::MatrixXi faces;
  std::vector<int> vertexIds;  ///< original id of each boundary vertex
  std::vector<int> owner;      ///< tet of each boundary face
};

Boundary tetBoundary(const TetMesh& tet) {
  // Outward faces of a positively oriented tet (a, b, c, d), the one opposite vertex i first.
  static const int local[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  struct Entry {
    std::array<int, 3> key;
    int tet, face;
  };
  std::vector<Entry> entries;
  entries.reserve(tet.tets.size() * 4);
  for (size_t k = 0; k < tet.tets.size(); ++k) {
    for (int f = 0; f < 4; ++f) {
      std::array<int, 3> key{tet.tets[k][local[f][0]], tet.tets[k][local[f][1]],
                             tet.tets[k][local[f][2]]};
      std::sort(key.begin(), key.end());
      entries.push_back({key, static_cast<int>(k), f});
    }
  }
  std::sort(entries.begin(), entries.end(),
            [](const Entry& a, const Entry& b) { return a.key < b.key; });
  Boundary b;
  std::vector<std::array<int, 3>> faces;
  for (size_t i = 0; i < entries.size();) {
    size_t j = i + 1;
    while (j < entries.size() && entries[j].key == entries[i].key) ++j;
    if (j == i + 1) {
      const auto& t = tet.tets[entries[i].tet];
      const int* l = local[entries[i].face];
      faces.push_back({t[l[0]], t[l[1]], t[l[2]]});
      b.owner.push_back(entries[i].tet);
    }
    i = j;
  }
  std::vector<int> map(tet.points.size(), -1);
  for (const auto& f : faces)
    for (int v : f) map[v] = 0;
  for (size_t v = 0; v < map.size(); ++v) {
    if (map[v] == 0) {
      map[v] = static_cast<int>(b.vertexIds.size());
      b.vertexIds.push_back(static_cast<int>(v));
    }
  }
  b.points.resize(b.vertexIds.size(), 3);
  for (size_t i = 0; i < b.vertexIds.size(); ++i) {
    b.points.row(i) = tet.points[b.vertexIds[i]].transpose();
  }
  b.faces.resize(faces.size(), 3);
  for (size_t k = 0; k < faces.size(); ++k)
    for (int j = 0; j < 3; ++j) b.faces(k, j) = map[faces[k][j]];
  return b;
}

}  // namespace

std::string extensionOf(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  const std::string name = slash == std::string::npos ? path : path.substr(slash + 1);
  const size_t dot = name.find_last_of('.');
  if (dot == std::string::npos || dot == 0) return "";
  return lower(name.substr(dot + 1));
}

Mesh readMesh(const std::string& path) {
  const std::string ext = extensionOf(path);
  Mesh mesh;
  if (ext == "obj" || ext == "off" || ext == "ply" || ext == "om") {
    mesh = Mesh(readOpenMesh(path, ext));
  } else if (ext == "mesh") {
    mesh = Mesh(readMedit(path));
  } else if (ext == "node" || ext == "ele") {
    mesh = Mesh(readTetgen(path));
  } else {
    throw IoError("cannot read " + quote(path) + ": unknown mesh extension " +
                  quote(ext.empty() ? "(none)" : "." + ext) + " (supported: " + kReadable + ")");
  }
  validateMesh(mesh, path);
  return mesh;
}

void validateMesh(const Mesh& mesh, const std::string& path) {
  const int n = mesh.numVertices(), m = mesh.numElements();
  const char* element = mesh.isTet() ? "tet" : "face";
  if (m == 0) throw InvalidMesh(path + ": no " + (mesh.isTet() ? "tetrahedra" : "faces"));
  const Eigen::MatrixXd p = mesh.positions();
  for (int i = 0; i < n; ++i) {
    if (!p.row(i).allFinite()) {
      throw InvalidMesh(path + ": vertex " + std::to_string(i) + " (0-based) has a non-finite " +
                        "coordinate");
    }
  }
  const Eigen::MatrixXi e = mesh.elements();
  const int s = mesh.elementSize();
  for (int k = 0; k < m; ++k) {
    const std::string name = path + ": " + element + " " + std::to_string(k) + " (0-based)";
    for (int j = 0; j < s; ++j) {
      if (e(k, j) < 0 || e(k, j) >= n) {
        throw InvalidMesh(name + " has vertex index " + std::to_string(e(k, j)) +
                          " out of range 0.." + std::to_string(n - 1));
      }
    }
    double edgeSum = 0.0;
    int edges = 0;
    for (int a = 0; a < s; ++a)
      for (int b = a + 1; b < s; ++b, ++edges) edgeSum += (p.row(e(k, a)) - p.row(e(k, b))).norm();
    const double h = edgeSum / edges;
    const Eigen::Vector3d a = p.row(e(k, 0)).transpose(), b = p.row(e(k, 1)).transpose(),
                          c = p.row(e(k, 2)).transpose();
    if (s == 3) {
      const double area = 0.5 * (b - a).cross(c - a).norm();
      if (!(area > 1e-14 * h * h)) {
        throw InvalidMesh(name + " is degenerate (area " + num(area) + ")");
      }
    } else {
      const double vol = det3(a, b, c, p.row(e(k, 3)).transpose()) / 6.0;
      if (!(std::abs(vol) > 1e-14 * h * h * h)) {
        throw InvalidMesh(name + " is degenerate (volume " + num(vol) + ")");
      }
      if (vol < 0.0) {
        throw InvalidMesh(name + " is inverted (volume " + num(vol) + ")");
      }
    }
  }
  const std::vector<bool> used = mesh.referenced();
  const int unused = static_cast<int>(std::count(used.begin(), used.end(), false));
  if (unused > 0) {
    const int first = static_cast<int>(std::find(used.begin(), used.end(), false) - used.begin());
    warn(path + ": " + std::to_string(unused) +
         " unreferenced vertices (first: " + std::to_string(first) +
         ", 0-based) keep their numbering and are left out of every system");
  }
}

std::vector<std::string> writableExtensions(MeshKind kind) {
  if (kind == MeshKind::Tet) return {"mesh", "ply"};
  return {"obj", "off", "ply", "om"};
}

void checkWritable(const std::string& path, MeshKind kind) {
  const std::string ext = extensionOf(path);
  const auto formats = writableExtensions(kind);
  if (std::find(formats.begin(), formats.end(), ext) != formats.end()) return;
  std::string list;
  for (const auto& f : formats) list += (list.empty() ? "" : ", ") + f;
  throw IoError("cannot write " + quote(path) + ": unsupported extension " +
                quote(ext.empty() ? "(no extension)" : "." + ext) + " for a " + toString(kind) +
                " mesh (supported: " + list + ")");
}

void writeMesh(const std::string& path, const Mesh& mesh, const WriteOptions& options) {
  checkWritable(path, mesh.kind());
  const std::string ext = extensionOf(path);
  if (!mesh.positions().allFinite()) {
    throw InvalidMesh("cannot write " + quote(path) + ": the mesh has non-finite coordinates");
  }
  const auto scalar = [&](bool vertex, const std::string& name) -> std::optional<Eigen::VectorXd> {
    if (name.empty()) return std::nullopt;
    if (vertex ? !mesh.hasVertexScalar(name) : !mesh.hasElementScalar(name)) return std::nullopt;
    Eigen::VectorXd v = vertex ? mesh.vertexScalar(name) : mesh.elementScalar(name);
    if (!v.allFinite()) {
      throw InvalidMesh("cannot write " + quote(path) + ": property " + quote(name) +
                        " has non-finite values");
    }
    return v;
  };

  writeAtomically(path, [&](std::ostream& out) {
    if (ext == "mesh") {
      writeMedit(out, mesh.tet());
    } else if (ext == "ply") {
      auto vq = scalar(true, options.vertexQuality);
      auto fq = scalar(false, options.faceQuality);
      if (mesh.isTet()) {
        const Boundary b = tetBoundary(mesh.tet());
        std::optional<Eigen::VectorXd> bvq, bfq;
        if (vq) {
          bvq = Eigen::VectorXd(b.vertexIds.size());
          for (size_t i = 0; i < b.vertexIds.size(); ++i) (*bvq)[i] = (*vq)[b.vertexIds[i]];
        }
        if (fq) {
          bfq = Eigen::VectorXd(b.owner.size());
          for (size_t k = 0; k < b.owner.size(); ++k) (*bfq)[k] = (*fq)[b.owner[k]];
        }
        writePly(out, b.points, b.faces, bvq ? &*bvq : nullptr, bfq ? &*bfq : nullptr,
                 options.colors);
      } else {
        writePly(out, mesh.positions(), mesh.elements(), vq ? &*vq : nullptr, fq ? &*fq : nullptr,
                 options.colors);
      }
    } else {
      OpenMesh::IO::Options opt;
      if (ext == "om") opt += OpenMesh::IO::Options::Binary;
      OpenMeshQuiet quiet;
      if (!OpenMesh::IO::write_mesh(mesh.tri(), out, ext, opt, 9)) {
        throw IoError("cannot write " + quote(path) + ": OpenMesh's " + ext + " writer failed");
      }
    }
  });
}

}  // namespace diffreg
