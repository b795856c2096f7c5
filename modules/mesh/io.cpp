#include <diffreg/mesh/io.h>

#include <diffreg/core/colormap.h>
#include <diffreg/core/error.h>
#include <diffreg/core/file.h>
#include <diffreg/core/log.h>
#include <diffreg/core/parallel.h>
#include <diffreg/core/text.h>
#include <diffreg/mesh/boundary.h>
#include <diffreg/mesh/om.h>
#include <diffreg/mesh/parse.h>
#include <diffreg/mesh/tet_facets.h>

#include <Eigen/Geometry>
#include <OpenMesh/Core/IO/IOManager.hh>
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/IO/importer/ImporterT.hh>
#include <OpenMesh/Core/System/omstream.hh>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <memory>
#include <optional>
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

/// Throws unless each triangle of the tets is a face of at most two tets, on its two sides: a
/// third tet on a triangle, or a second one on the same side (a repeated tet, or two that
/// overlap), makes no solid, and its boundary surface would be wrong. Expects positively
/// oriented tets with vertex ids in range. The faces are grouped by their vertices
/// (mesh/tet_facets.h: O(m log m) for m tets).
void checkTetFaces(const TetMesh& tet, const std::string& path) {
  const auto triangle = [](const std::array<int, 3>& key) {
    return "vertices " + std::to_string(key[0]) + ", " + std::to_string(key[1]) + ", " +
           std::to_string(key[2]);
  };
  forEachFacet(
      sortedTetFacets(static_cast<int>(tet.tets.size()), static_cast<int>(tet.points.size()),
                      [&tet](int k, int j) { return tet.tets[static_cast<std::size_t>(k)][j]; }),
      [&](const std::array<int, 3>& key, const TetFacet* first, int count) {
        if (count > 2) {
          throw InvalidMesh(path + ": tets " + std::to_string(first[0].tet) + ", " +
                            std::to_string(first[1].tet) + " and " + std::to_string(first[2].tet) +
                            " (0-based) share the triangle of " + triangle(key) +
                            "; a triangle is a face of at most two tets");
        }
        if (count == 2 && first[0].odd == first[1].odd) {
          throw InvalidMesh(path + ": tets " + std::to_string(first[0].tet) + " and " +
                            std::to_string(first[1].tet) +
                            " (0-based) lie on the same side of their common triangle of " +
                            triangle(key) + " (a repeated tet, or two that overlap)");
        }
      });
}

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
  const std::string node = readFileLimited(nodePath, "mesh file", limits::meshBytes);
  const std::string ele = readFileLimited(elePath, "mesh file", limits::meshBytes);
  return parseTetgen(node, nodePath, ele, elePath);
}

// ---------------------------------------------------------------------------------------
// Writing

/// Text output of the writers: numbers formatted by std::to_chars straight into a buffer that
/// goes to the stream in large pieces (a stream's own formatting, and a string per number, cost
/// several times more on a large mesh). Doubles in the shortest form that reads back as the
/// same double (at most 17 digits); integers in decimal. Without a stream it only collects the
/// text (a piece of writeRows).
class TextOut {
 public:
  explicit TextOut(std::ostream* out) : out_(out) { buffer_.reserve(kChunk + kRoom); }
  TextOut(const TextOut&) = delete;
  TextOut& operator=(const TextOut&) = delete;
  ~TextOut() { flush(); }

  TextOut& operator<<(double v) { return number(v); }
  TextOut& operator<<(int v) { return number(v); }
  TextOut& operator<<(long v) { return number(v); }
  TextOut& operator<<(long long v) { return number(v); }
  TextOut& operator<<(unsigned long v) { return number(v); }
  TextOut& operator<<(char c) {
    buffer_.push_back(c);
    return spill();
  }
  TextOut& operator<<(std::string_view text) {
    buffer_.append(text);
    return spill();
  }
  TextOut& operator<<(const char* text) { return *this << std::string_view(text); }

  void flush() {
    if (!out_) return;
    out_->write(buffer_.data(), static_cast<std::streamsize>(buffer_.size()));
    buffer_.clear();
  }
  /// Text formatted elsewhere (a piece of writeRows), written straight through when large.
  TextOut& append(std::string_view text) {
    if (!out_ || text.size() < kChunk) return *this << text;
    flush();
    out_->write(text.data(), static_cast<std::streamsize>(text.size()));
    return *this;
  }
  /// A collecting TextOut's text.
  std::string& text() { return buffer_; }

 private:
  static constexpr size_t kChunk = 1 << 16, kRoom = 32;  // a number takes at most 24 chars

  template <typename T>
  TextOut& number(T v) {
    // Formatted on the stack and appended: growing the buffer by kRoom first would clear those
    // bytes for every number.
    char digits[kRoom];
    const auto r = std::to_chars(digits, digits + kRoom, v);
    buffer_.append(digits, static_cast<size_t>(r.ptr - digits));
    return spill();
  }
  TextOut& spill() {
    if (out_ && buffer_.size() >= kChunk) flush();
    return *this;
  }

  std::ostream* out_;
  std::string buffer_;
};

/// Rows [0, rows) of a text format, row i written by line(out, i): blocks of kRowBlock rows are
/// formatted concurrently once the thread pool runs (parallel.h), up to kBlockRound blocks at a
/// time (a few MB of text in memory), and written in order, so the file is the same as from one
/// thread. Formatting the shortest
/// round-trip digits is most of a writer's time (5.5 ms of a 10K-vertex PLY).
template <typename Line>
void writeRows(TextOut& out, int rows, const Line& line) {
  constexpr int kRowBlock = 1024, kBlockRound = 64;
  if (rows <= kRowBlock || parallel::threads() == 1) {
    for (int i = 0; i < rows; ++i) line(out, i);
    return;
  }
  std::vector<std::unique_ptr<TextOut>> pieces;
  for (int first = 0; first < rows; first += kRowBlock * kBlockRound) {
    const int blocks = std::min(kBlockRound, (rows - first + kRowBlock - 1) / kRowBlock);
    while (static_cast<int>(pieces.size()) < blocks)
      pieces.push_back(std::make_unique<TextOut>(nullptr));
    parallel::forChunks(blocks, 1, [&](int block, int, int) {
      TextOut& piece = *pieces[static_cast<size_t>(block)];
      const int begin = first + block * kRowBlock, end = std::min(rows, begin + kRowBlock);
      for (int i = begin; i < end; ++i) line(piece, i);
    });
    for (int b = 0; b < blocks; ++b) {
      std::string& text = pieces[static_cast<size_t>(b)]->text();
      out.append(text);
      text.clear();
    }
  }
}

void writeMedit(std::ostream& stream, const TetMesh& tet) {
  TextOut out(&stream);
  out << "MeshVersionFormatted 2\nDimension 3\n\nVertices\n" << tet.points.size() << "\n";
  writeRows(out, static_cast<int>(tet.points.size()), [&](TextOut& o, int i) {
    const auto& p = tet.points[static_cast<size_t>(i)];
    o << p[0] << ' ' << p[1] << ' ' << p[2] << " 0\n";
  });
  out << "\nTetrahedra\n" << tet.tets.size() << "\n";
  writeRows(out, static_cast<int>(tet.tets.size()), [&](TextOut& o, int k) {
    const auto& t = tet.tets[static_cast<size_t>(k)];
    o << t[0] + 1 << ' ' << t[1] + 1 << ' ' << t[2] + 1 << ' ' << t[3] + 1 << " 0\n";
  });
  out << "\nEnd\n";
}

template <typename Points>
void writePoint(TextOut& out, const Points& points, int i) {
  out << points(i, 0) << ' ' << points(i, 1) << ' ' << points(i, 2);
}

/// Whether a property name can stand in a PLY comment as one word: printable ASCII, no space.
bool oneWord(const std::string& name) {
  return printableAscii(name) && name.find(' ') == std::string::npos;
}

/// Why .om cannot keep a property of that name, nullptr when it can. Its names are one length
/// byte and the bytes; OpenMesh does not write names of the form "c:..." (its own, such as
/// "v:points"); diffreg's reader takes printable ASCII.
const char* omUnkeptBecause(const std::string& name) {
  return name.empty()                         ? "empty"
         : name.size() > 255                  ? "longer than 255 bytes"
         : !printableAscii(name)              ? "not printable ASCII"
         : name.size() >= 2 && name[1] == ':' ? "OpenMesh does not write names of the form 'c:...'"
                                              : nullptr;
}

/// A column of doubles in a PLY: the file's property and, when not empty, the mesh property
/// it holds, which a header comment names for readMesh.
struct PlyColumn {
  std::string property;
  std::string name;
  Eigen::VectorXd values;
};

/// ASCII PLY: points (double; n x 3, an Eigen matrix or view) and triangles, each with its
/// columns; with `colors`, viridis colours over the vertex quality (the column "quality").
template <typename Points>
void writePly(std::ostream& stream, const Points& points, const Eigen::MatrixXi& faces,
              const std::vector<PlyColumn>& vertexColumns,
              const std::vector<PlyColumn>& faceColumns, bool colors) {
  TextOut out(&stream);
  const PlyColumn* quality = nullptr;
  for (const auto& c : vertexColumns)
    if (c.property == "quality") quality = &c;
  colors = colors && quality != nullptr;
  out << "ply\nformat ascii 1.0\ncomment diffreg\n";
  for (const auto* columns : {&vertexColumns, &faceColumns})
    for (const auto& c : *columns)
      if (!c.name.empty())
        out << "comment diffreg " << (columns == &vertexColumns ? "vertex " : "face ")
            << (c.property == "quality" ? "quality " : "property ") << c.name << "\n";
  out << "element vertex " << points.rows() << "\n";
  out << "property double x\nproperty double y\nproperty double z\n";
  for (const auto& c : vertexColumns) out << "property double " << c.property << "\n";
  if (colors) out << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  out << "element face " << faces.rows() << "\nproperty list uchar int vertex_indices\n";
  for (const auto& c : faceColumns) out << "property double " << c.property << "\n";
  out << "end_header\n";
  writeRows(out, static_cast<int>(points.rows()), [&](TextOut& o, int i) {
    writePoint(o, points, i);
    for (const auto& c : vertexColumns) o << ' ' << c.values[i];
    if (colors) {
      const auto rgb = viridis(quality->values[i]);
      o << ' ' << int(rgb[0]) << ' ' << int(rgb[1]) << ' ' << int(rgb[2]);
    }
    o << '\n';
  });
  writeRows(out, static_cast<int>(faces.rows()), [&](TextOut& o, int k) {
    o << "3 " << faces(k, 0) << ' ' << faces(k, 1) << ' ' << faces(k, 2);
    for (const auto& c : faceColumns) o << ' ' << c.values[k];
    o << '\n';
  });
}

/// OBJ (1-based faces) or OFF, with exact coordinates.
void writeObjOff(std::ostream& stream, const Mesh& mesh, bool obj) {
  TextOut out(&stream);
  const Mesh::PointRows p = mesh.points();
  const Eigen::MatrixXi f = mesh.elements();
  if (!obj) out << "OFF\n" << p.rows() << ' ' << f.rows() << " 0\n";
  writeRows(out, static_cast<int>(p.rows()), [&](TextOut& o, int i) {
    o << (obj ? "v " : "");
    writePoint(o, p, i);
    o << '\n';
  });
  const int base = obj ? 1 : 0;
  writeRows(out, static_cast<int>(f.rows()), [&](TextOut& o, int k) {
    o << (obj ? "f " : "3 ") << f(k, 0) + base << ' ' << f(k, 1) + base << ' ' << f(k, 2) + base
      << '\n';
  });
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
  checkNoNul(path, "read");
  const std::string ext = extensionOf(path);
  const auto text = [&] { return readFileLimited(path, "mesh file", limits::meshBytes); };
  Mesh mesh;
  if (ext == "obj") {
    mesh = Mesh(buildTriMesh(parseObj(text(), path), path));
  } else if (ext == "off") {
    mesh = Mesh(buildTriMesh(parseOff(text(), path), path));
  } else if (ext == "ply") {
    mesh = buildMesh(parsePly(text(), path), path);
  } else if (ext == "om") {
    mesh = parseOm(text(), path);
  } else if (ext == "mesh" || ext == "node" || ext == "ele") {
    TetMesh tet = ext == "mesh" ? parseMedit(text(), path) : readTetgen(path);
    orientTets(tet, path);
    mesh = Mesh(std::move(tet));
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
  const Mesh::PointRows p = mesh.points();
  for (int i = 0; i < n; ++i) {
    if (!p.row(i).allFinite()) {
      throw InvalidMesh(path + ": vertex " + std::to_string(i) + " (0-based) has a non-finite " +
                        "coordinate");
    }
  }
  const Eigen::MatrixXi e = mesh.elements();
  const int s = mesh.elementSize();
  for (int k = 0; k < m; ++k) {
    // Spelled out only for an error: every face of a large mesh is checked.
    const auto name = [&] {
      return path + ": " + element + " " + std::to_string(k) + " (0-based)";
    };
    for (int j = 0; j < s; ++j) {
      if (e(k, j) < 0 || e(k, j) >= n) {
        throw InvalidMesh(name() + " has vertex index " + std::to_string(e(k, j)) +
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
    // Coordinates near the top of the double range overflow the products (a NaN area).
    const auto overflow = [&](const char* what) {
      double largest = 0.0;
      for (int j = 0; j < s; ++j) largest = std::max(largest, p.row(e(k, j)).cwiseAbs().maxCoeff());
      return InvalidMesh(name() + "'s " + what + " overflows: a corner has a coordinate of " +
                         num(largest) + "; scale the mesh");
    };
    if (s == 3) {
      const double area = 0.5 * (b - a).cross(c - a).norm();
      if (!std::isfinite(area) || !std::isfinite(h)) throw overflow("area");
      if (!(area > 1e-14 * h * h)) {
        throw InvalidMesh(name() + " is degenerate (area " + num(area) + ")");
      }
    } else {
      const double vol = det3(a, b, c, p.row(e(k, 3)).transpose()) / 6.0;
      if (!std::isfinite(vol) || !std::isfinite(h)) throw overflow("volume");
      if (!(std::abs(vol) > 1e-14 * h * h * h)) {
        throw InvalidMesh(name() + " is degenerate (volume " + num(vol) + ")");
      }
      if (vol < 0.0) {
        throw InvalidMesh(name() + " is inverted (volume " + num(vol) + ")");
      }
    }
  }
  if (mesh.isTet()) checkTetFaces(mesh.tet(), path);
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
  checkNoNul(path, "write");
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
  if (!mesh.points().allFinite()) {
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

  // A reader keeps the first kMaxNamedProperties of each kind: say so where more go out.
  const auto warnBeyondKept = [&](bool vertex, size_t written) {
    if (written > static_cast<size_t>(kMaxNamedProperties))
      warn("writing " + quote(path) + ": " + std::to_string(written) + " named " +
           (vertex ? "vertex" : "face") + " properties go out, but reading the file back " +
           "keeps only the first " + std::to_string(kMaxNamedProperties));
  };
  if (ext == "om") {  // .om carries every named property
    const auto storable = [&](const std::string& name) {
      if (const char* why = omUnkeptBecause(name))
        throw IoError("cannot write " + quote(path) + ": the property name " +
                      quote(name.size() > 80 ? name.substr(0, 80) + "..." : name) +
                      " cannot be kept in .om (" + why + ")");
    };
    for (const auto& name : mesh.vertexScalarNames()) {
      storable(name);
      scalar(true, name);
    }
    for (const auto& name : mesh.elementScalarNames()) {
      storable(name);
      scalar(false, name);
    }
    warnBeyondKept(true, mesh.vertexScalarNames().size());
    warnBeyondKept(false, mesh.elementScalarNames().size());
  }
  // PLY: the chosen vertex and face properties as "quality" (which MeshLab shows), every other
  // named property as a property of the same name; each named in the header for readMesh.
  const auto plyColumns = [&](bool vertex, std::vector<PlyColumn>& columns) {
    const std::string& quality = vertex ? options.vertexQuality : options.faceQuality;
    const std::optional<Eigen::VectorXd> q = scalar(vertex, quality);
    if (q) {
      if (!oneWord(quality))
        warn("writing " + quote(path) + ": the property " + quote(quality) +
             " goes out as quality without its name (not one word of printable ASCII), so "
             "reading the file back will not restore it");
      columns.push_back({"quality", oneWord(quality) ? quality : "", *q});
    }
    for (const auto& name : vertex ? mesh.vertexScalarNames() : mesh.elementScalarNames()) {
      if (q && name == quality) continue;  // written as the quality
      const bool reserved = plyReservedName(vertex, name);
      if (!oneWord(name) || reserved) {
        warn("writing " + quote(path) + ": the " + (vertex ? "vertex" : "element") + " property " +
             quote(name) + " is not written (" +
             (reserved ? "PLY readers take a property of that name for something else"
                       : "a PLY property name is one word of printable ASCII") +
             ")" + (!mesh.isTet() && !omUnkeptBecause(name) ? "; .om keeps it" : ""));
        continue;
      }
      columns.push_back({name, name, *scalar(vertex, name)});
    }
    // A tet's element properties go out unnamed (below): read back as nothing.
    if (vertex || !mesh.isTet())
      warnBeyondKept(vertex, static_cast<size_t>(std::count_if(
                                 columns.begin(), columns.end(),
                                 [](const PlyColumn& c) { return !c.name.empty(); })));
  };
  writeFileAtomically(path, [&](std::ostream& out) {
    if (ext == "mesh") {
      writeMedit(out, mesh.tet());
    } else if (ext == "ply") {
      std::vector<PlyColumn> vertexColumns, faceColumns;
      plyColumns(true, vertexColumns);
      plyColumns(false, faceColumns);
      if (mesh.isTet()) {
        const BoundarySurface b = boundarySurface(mesh.tet());
        // The boundary's vertices carry the tets' vertex values and read back as them; its
        // faces carry their tet's values, which are no values of the faces: left unnamed.
        for (auto& c : vertexColumns) {
          Eigen::VectorXd v(b.vertexIds.size());
          for (size_t i = 0; i < b.vertexIds.size(); ++i) v[i] = c.values[b.vertexIds[i]];
          c.values = std::move(v);
        }
        for (auto& c : faceColumns) {
          Eigen::VectorXd v(b.element.size());
          for (size_t k = 0; k < b.element.size(); ++k) v[k] = c.values[b.element[k]];
          c.values = std::move(v);
          c.name.clear();
        }
        writePly(out, b.points, b.faces, vertexColumns, faceColumns, options.colors);
      } else {
        writePly(out, mesh.points(), mesh.elements(), vertexColumns, faceColumns, options.colors);
      }
    } else if (ext == "obj" || ext == "off") {
      writeObjOff(out, mesh, ext == "obj");
    } else {
      OpenMesh::IO::Options opt = OpenMesh::IO::Options::Binary;
      OpenMeshQuiet quiet;
      if (!OpenMesh::IO::write_mesh(mesh.tri(), out, ext, opt, 9)) {
        throw IoError("cannot write " + quote(path) + ": OpenMesh's " + ext + " writer failed");
      }
    }
  });
}

}  // namespace diffreg
