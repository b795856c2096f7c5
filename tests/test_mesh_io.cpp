// Reading, validating and writing meshes (modules/mesh/io.h).

#include <diffreg/core/colormap.h>
#include <diffreg/core/error.h>
#include <diffreg/mesh/io.h>
#include <diffreg/mesh/parse.h>
#include <diffreg/mesh/shapes.h>

#include <Eigen/Geometry>
#include <OpenMesh/Core/IO/MeshIO.hh>
#include "test_support.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>

using namespace diffreg;
using namespace diffreg::testing;
namespace fs = std::filesystem;

namespace {

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

const char* kTetFile =
    "MeshVersionFormatted 2\n"
    "Dimension 3\n"
    "Vertices\n5\n"
    "0 0 0 1\n1 0 0 1\n0 1 0 1\n0 0 1 1\n1 1 1 1\n"
    "Tetrahedra\n2\n"
    "1 2 3 4 0\n2 5 3 4 0\n"
    "End\n";

/// A little-endian binary PLY of the unit triangle's three float vertices and one face whose
/// vertex list has a count of type `countType`; the face's count and indices follow.
std::string binaryTrianglePly(const std::string& countType) {
  std::string binary =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
      "property float y\nproperty float z\nelement face 1\n"
      "property list " +
      countType + " int vertex_indices\nend_header\n";
  for (float v : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f})
    binary.append(reinterpret_cast<const char*>(&v), 4);
  return binary;
}

double totalVolume(const Mesh& mesh) {
  const Eigen::MatrixXd p = mesh.positions();
  double v = 0.0;
  for (const auto& t : mesh.tet().tets) {
    const Eigen::Vector3d a = p.row(t[0]), b = p.row(t[1]), c = p.row(t[2]), d = p.row(t[3]);
    v += (b - a).dot((c - a).cross(d - a)) / 6.0;
  }
  return v;
}

/// A minimal ASCII PLY parser: element name -> property names, and rows of numbers.
struct Ply {
  std::map<std::string, std::vector<std::string>> props;  // scalar properties per element
  std::map<std::string, std::vector<std::vector<double>>> rows;
};

Ply parsePly(const std::string& path) {
  std::ifstream in(path);
  std::string line, current;
  std::vector<std::pair<std::string, int>> order;
  Ply ply;
  std::getline(in, line);
  REQUIRE(line == "ply");
  while (std::getline(in, line) && line != "end_header") {
    std::istringstream ls(line);
    std::string key;
    ls >> key;
    if (key == "format") {
      std::string fmt;
      ls >> fmt;
      REQUIRE(fmt == "ascii");
    } else if (key == "element") {
      int n = 0;
      ls >> current >> n;
      order.push_back({current, n});
    } else if (key == "property") {
      std::string type, name;
      ls >> type;
      if (type == "list") {
        std::string a, b;
        ls >> a >> b;
      }
      ls >> name;
      ply.props[current].push_back(name);
    }
  }
  for (const auto& [name, n] : order) {
    for (int i = 0; i < n; ++i) {
      std::getline(in, line);
      std::istringstream ls(line);
      std::vector<double> row;
      double x;
      while (ls >> x) row.push_back(x);
      ply.rows[name].push_back(row);
    }
  }
  return ply;
}

}  // namespace

TEST_CASE("extensionOf", "[mesh][io]") {
  CHECK(extensionOf("a/b/Bunny.OBJ") == "obj");
  CHECK(extensionOf("x.tar.mesh") == "mesh");
  CHECK(extensionOf("dir.d/file") == "");
  CHECK(extensionOf(".hidden") == "");
  CHECK(extensionOf("noext") == "");
}

TEST_CASE("the shared meshes read with the documented kinds and counts", "[mesh][io]") {
  const fs::path dir = DIFFREG_SHARED_MESHES;
  if (!fs::exists(dir)) {
    WARN("shared meshes not found at " << dir << "; skipping");
    return;
  }
  struct Case {
    const char* file;
    MeshKind kind;
    int vertices, elements;
  };
  const Case cases[] = {
      {"planar-woody.obj", MeshKind::Planar, 694, 1267},
      {"planar-alligator.obj", MeshKind::Planar, 3208, 5981},
      {"planar-rectangle-sheet.obj", MeshKind::Planar, 913, 1708},
      {"planar-octopus.obj", MeshKind::Planar, 2731, 4868},
      {"planar-crocodile.obj", MeshKind::Planar, 26045, 50579},
      {"surface-decimated-knight.off", MeshKind::Surface, 502, 1000},
      {"surface-fertility.off", MeshKind::Surface, 4494, 9000},
      {"surface-rocker-arm.obj", MeshKind::Surface, 10044, 20088},
      {"surface-beetle-20k.off", MeshKind::Surface, 19887, 38656},
      {"surface-armadillo.obj", MeshKind::Surface, 43243, 86482},
      {"tet-bar.mesh", MeshKind::Tet, 3842, 14114},
      {"tet-decimated-knight.mesh", MeshKind::Tet, 1822, 5452},
      {"tet-monkey.mesh", MeshKind::Tet, 21010, 86965},
  };
  for (const Case& c : cases) {
    const fs::path p = dir / c.file;
    if (!fs::exists(p)) {
      WARN(p << " not found; skipping");
      continue;
    }
    INFO(c.file);
    const Mesh mesh = readMesh(p.string());
    CHECK(mesh.kind() == c.kind);
    CHECK(mesh.numVertices() == c.vertices);
    CHECK(mesh.numElements() == c.elements);
  }
}

TEST_CASE("tet-bar: volume 5 and 5788 outward boundary faces in the PLY", "[mesh][io]") {
  const fs::path p = fs::path(DIFFREG_SHARED_MESHES) / "tet-bar.mesh";
  if (!fs::exists(p)) {
    WARN(p << " not found; skipping");
    return;
  }
  const Mesh mesh = readMesh(p.string());
  CHECK(totalVolume(mesh) == Approx(5.0).epsilon(1e-9));
  TempDir tmp;
  writeMesh(tmp / "bar.ply", mesh);
  const Ply ply = parsePly(tmp / "bar.ply");
  REQUIRE(ply.rows.at("face").size() == 5788u);
  // Outward orientation: the divergence theorem gives the (positive) enclosed volume.
  double v = 0.0;
  const auto& pts = ply.rows.at("vertex");
  for (const auto& f : ply.rows.at("face")) {
    const Eigen::Vector3d a(pts[f[1]][0], pts[f[1]][1], pts[f[1]][2]);
    const Eigen::Vector3d b(pts[f[2]][0], pts[f[2]][1], pts[f[2]][2]);
    const Eigen::Vector3d c(pts[f[3]][0], pts[f[3]][1], pts[f[3]][2]);
    v += a.dot(b.cross(c)) / 6.0;
  }
  CHECK(v == Approx(5.0).epsilon(1e-5));
}

TEST_CASE("the non-manifold beetle reads, its bad faces split off", "[mesh][io]") {
  const fs::path p = fs::path(DIFFREG_SHARED_MESHES) / "surface-beetle-1k.obj";
  if (!fs::exists(p)) {
    WARN(p << " not found; skipping");
    return;
  }
  Mesh mesh;
  const std::string warned = stderrOf([&] { mesh = readMesh(p.string()); });
  // The warning says where the copies are, and what the split means for a deformation.
  CHECK(warned.find("vertices appended after the file's 1148), which leaves it a piece of its "
                    "own that a deformation needs handles on") != std::string::npos);
  CHECK(mesh.kind() == MeshKind::Surface);
  CHECK(mesh.numElements() == 2053);
  // File vertices keep their numbering; copies for split-off faces come after them.
  CHECK(mesh.numVertices() > 1148);
  const Eigen::MatrixXd pos = mesh.positions();
  for (int i = 1148; i < mesh.numVertices(); ++i) {
    bool copy = false;
    for (int j = 0; j < 1148 && !copy; ++j) copy = pos.row(i) == pos.row(j);
    CHECK(copy);
  }
}

TEST_CASE("OBJ/OFF/PLY errors name the file and the element", "[mesh][io]") {
  TempDir tmp;
  const std::string quad = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";

  SECTION("missing file") {
    const std::string p = tmp / "missing.obj";
    CHECK_THAT(messageOf<IoError>([&] { readMesh(p); }), Catch::Contains(p));
  }
  SECTION("a directory") {
    const std::string p = tmp / "dir.obj";
    fs::create_directory(p);
    CHECK_THAT(messageOf<IoError>([&] { readMesh(p); }), Catch::Contains(p));
  }
  SECTION("unknown extension lists the supported ones") {
    const std::string p = tmp.file("a.xyz", "1 2 3\n");
    const std::string m = messageOf<IoError>([&] { readMesh(p); });
    CHECK_THAT(m, Catch::Contains(p) && Catch::Contains("obj") && Catch::Contains("mesh"));
  }
  SECTION("no faces") {
    const std::string p = tmp.file("empty.obj", quad);
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(p); }),
               Catch::Contains(p) && Catch::Contains("no faces"));
  }
  SECTION("non-finite coordinate") {
    const std::string p = tmp.file("nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n");
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(p); }),
               Catch::Contains(p + ":2") && Catch::Contains("non-finite"));
    const std::string q = tmp.file("inf.off", "OFF\n3 1 0\n0 0 0\n1e999 0 0\n0 1 0\n3 0 1 2\n");
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(q); }),
               Catch::Contains(q + ":4") && Catch::Contains("vertex 1 has a non-finite"));
  }
  SECTION("out-of-range index") {
    const std::string p = tmp.file("range.obj", quad + "f 1 2 3\nf 1 3 9\n");
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(p); }),
               Catch::Contains(p + ":6") && Catch::Contains("face 2") && Catch::Contains("9"));
    const std::string q = tmp.file("range.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n");
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(q); }),
               Catch::Contains(q + ":6") && Catch::Contains("face 0") &&
                   Catch::Contains("index 3 out of range 0..2"));
    const std::string r = tmp.file("range.ply",
                                   "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                                   "property float y\nproperty float z\nelement face 2\n"
                                   "property list uchar int vertex_indices\nend_header\n"
                                   "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 2 7\n");
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(r); }),
               Catch::Contains(r) && Catch::Contains("face 1") && Catch::Contains("7"));
  }
  SECTION("repeated vertex in a face is degenerate") {
    const std::string p = tmp.file("rep.obj", quad + "f 1 2 3\nf 1 1 3\n");
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(p); }),
               Catch::Contains(p + ":6") && Catch::Contains("face 2 is degenerate"));
    const std::string q = tmp.file("rep.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 1\n");
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(q); }),
               Catch::Contains(q) && Catch::Contains("face 0 is degenerate"));
  }
  SECTION("zero-area and relatively tiny faces are degenerate") {
    const std::string p =
        tmp.file("flat.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 2 1 4\n");
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(p); }),
               Catch::Contains(p) && Catch::Contains("face 1 (0-based) is degenerate"));
    const std::string q =
        tmp.file("sliver.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0.5 1e-16 0\nf 1 2 3\nf 1 4 2\n");
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(q); }), Catch::Contains("face 1"));
  }
}

TEST_CASE("OBJ: the one-pass reading gives what the token-wise reading gives", "[mesh][io]") {
  // Points, faces and their lines equal, or the same error (one pass leaves every error line to
  // the token-wise reading).
  const auto same = [](const std::string& text) {
    INFO(text);
    std::string fast, general;
    RawMesh a, b;
    try {
      a = parseObj(text, "t.obj");
    } catch (const InvalidMesh& e) {
      fast = e.what();
    }
    try {
      b = detail::parseObjByTokens(text, "t.obj");
    } catch (const InvalidMesh& e) {
      general = e.what();
    }
    CHECK(fast == general);
    REQUIRE(a.points.size() == b.points.size());
    for (size_t i = 0; i < a.points.size(); ++i) CHECK(a.points[i] == b.points[i]);
    REQUIRE(a.faces.size() == b.faces.size());
    for (size_t k = 0; k < a.faces.size(); ++k) {
      CHECK(a.faces[k].line == b.faces[k].line);
      CHECK(a.faces[k].ids == b.faces[k].ids);
    }
    CHECK(a.base == b.base);
  };
  const std::string quad = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";
  for (const std::string& text : std::vector<std::string>{
           quad + "f 1 2 3\nf 1 3 4\n",
           "# header\n\n  v\t+1.5 -2e-3 .5 # point\r\nv 1 2 3 1 extra\nvn 0 0 1\nvt 0 0\n"
           "v 0 1 0\r\ng part\no obj\nusemtl m\ns 1\nf 1/1 2/2/2 3//3\r\nf -1 -2 -3#c\n"
           "f +1 2 03\nf 3 2 1 1\nf   \n\t f 1 2 3",
           quad + "f 1 2 3\nf 1 3 9\n",             // out of range: read, refused later
           quad + "f 1 2 3\nf 1 3 -5\n",            // before the first vertex
           quad + "f 1 0 3\n",                       // no vertex 0
           quad + "f 1 2 x\n", quad + "f 1 2 /3\n", quad + "f 1 2 -+3\n",
           quad + "f 1 2 99999999999999999999\n",  // beyond long long
           quad + "f 1 2 1234567890123456789\n",   // 19 digits
           quad + "f\n", quad + "v\n", "v 1 2\n", "v 1 2 nan\n", "v 1 2 1e400\n",
           "v 1 2 inf\n", "v 1 2 3x\n", quad + "f 1 2 3", "vv 1 2 3\nff 1 2 3\n" + quad,
           std::string("v 0 0 0\nv 1 0 0\0\nv 0 1 0\nf 1 2 3\n", 33), ""})
    same(text);
  // A byte order mark (skipped once), and lines that start with no OBJ statement (left to the
  // token-wise reading, for its warning) among the statements that are read past.
  for (const std::string& text : std::vector<std::string>{
           "\xEF\xBB\xBF" + quad + "f 1 2 3\n", "\xEF\xBB\xBF\xEF\xBB\xBF" + quad + "f 1 2 3\n",
           "V 0 0 0\nv1 0 0 0\n\xC2\xA0v 0 0 0\n" + quad + "f 1 2 3\n",
           quad + "vt 0 0\nvn 0 0 1\nvp 0\nl 1 2\np 1\ncurv2 1 2\nend\ng\nf 1 2 3\n"})
    same(text);
}

TEST_CASE("a leading UTF-8 byte order mark is skipped in every text format", "[mesh][io]") {
  TempDir tmp;
  const std::string bom = "\xEF\xBB\xBF";
  const auto same = [&](const std::string& name, const std::string& text, int vertices) {
    INFO(name);
    const Mesh plain = readMesh(tmp.file(name, text));
    const Mesh marked = readMesh(tmp.file("bom-" + name, bom + text));
    CHECK(plain.numVertices() == vertices);
    CHECK(marked.positions() == plain.positions());
    CHECK(marked.elements() == plain.elements());
  };
  const std::string points = "0 0 0\n1 0 0\n0 1 0\n1 1 0\n5 5 0\n";
  const std::string faces = "3 0 1 2\n3 1 3 2\n3 1 4 3\n";
  SECTION("OBJ") {
    same("a.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 5 5 0\nf 1 2 3\nf 2 4 3\nf 2 5 4\n", 5);
  }
  SECTION("OFF") {
    same("a.off", "OFF\n5 3 0\n" + points + faces, 5);
    same("b.off", "OFF 5 3 0\n" + points + faces, 5);
  }
  SECTION("ASCII PLY") {
    same("a.ply",
         "ply\nformat ascii 1.0\nelement vertex 5\nproperty double x\nproperty double y\n"
         "property double z\nelement face 3\nproperty list uchar int vertex_indices\n"
         "end_header\n" +
             points + faces,
         5);
  }
  SECTION("binary PLY") {
    std::string binary = binaryTrianglePly("uchar");
    binary += '\3';
    for (std::int32_t i : {0, 1, 2}) binary.append(reinterpret_cast<const char*>(&i), 4);
    same("binary.ply", binary, 3);
  }
  SECTION("Medit") {
    // This one starts with Vertices: a mark stuck to it would hide the block.
    same("a.mesh", std::string(kTetFile).substr(std::string(kTetFile).find("Vertices")), 5);
    same("b.mesh", kTetFile, 5);
  }
  SECTION("TetGen .node and .ele") {
    const std::string node = "5 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n5 1 1 1\n";
    const std::string ele = "2 4 0\n1 1 2 3 4\n2 2 5 3 4\n";
    tmp.file("plain.node", node);
    tmp.file("plain.ele", ele);
    tmp.file("marked.node", bom + node);
    tmp.file("marked.ele", bom + ele);
    const Mesh plain = readMesh(tmp / "plain.node");
    const Mesh marked = readMesh(tmp / "marked.ele");
    CHECK(plain.numVertices() == 5);
    CHECK(marked.positions() == plain.positions());
    CHECK(marked.elements() == plain.elements());
  }
  SECTION("one mark, at the start: a second one is not skipped") {
    const std::string p = tmp.file("twice.ply", bom + bom + "ply\nformat ascii 1.0\n");
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(p); }),
               Catch::Contains(p + ":1") && Catch::Contains("not a PLY file"));
  }
}

TEST_CASE("OBJ: lines that start with no OBJ statement are ignored with one warning",
          "[mesh][io]") {
  TempDir tmp;
  const std::string quad = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";
  SECTION("statements diffreg does not use are read past silently") {
    const std::string p = tmp.file(
        "known.obj", "mtllib a.mtl\no thing\ng part\ns off\nusemtl m\n" + quad +
                         "vt 0 0\nvn 0 0 1\nvp 0 0\nl 1 2\np 3\ncstype bspline\ndeg 3\n"
                         "curv 0 1 1 2\ncurv2 1 2\nsurf 0 1 0 1 1 2\nparm u 0 1\ntrim 0 1 1\n"
                         "hole 0 1 1\nscrv 0 1 1\nsp 1\nend\ncon 1 0 1 1\nbmat u 1\nstep 1\n"
                         "mg 1 0.5\nbevel off\nc_interp off\nd_interp off\nlod 1\n"
                         "maplib a.map\nusemap off\nshadow_obj s.obj\ntrace_obj t.obj\n"
                         "ctech cparm 1\nstech cparma 1 1\ncall x.mod\ncsh -cmd\n"
                         "f 1 2 3\nf 1 3 4\n");
    Mesh mesh;
    CHECK(stderrOf([&] { mesh = readMesh(p); }).empty());
    CHECK(mesh.numVertices() == 4);
    CHECK(mesh.numElements() == 2);
  }
  SECTION("unknown first words: the lines are not read, one warning names the first") {
    const std::string p =
        tmp.file("unknown.obj", "# V, v1 and a non-breaking space are no statements\n" + quad +
                                    "V 9 9 9\nv1 9 9 9\n\xC2\xA0v 9 9 9\nvt 0 0\n"
                                    "f 1 2 3\nf 1 3 4\n");
    Mesh mesh;
    const std::string err = stderrOf([&] { mesh = readMesh(p); });
    CHECK(mesh.numVertices() == 4);  // the faces still refer to the file's v lines
    CHECK(mesh.positions().row(3) == Eigen::RowVector3d(0, 1, 0));
    CHECK(std::count(err.begin(), err.end(), '\n') == 1);
    CHECK_THAT(err, Catch::StartsWith("diffreg: warning: " + p + ": ") &&
                        Catch::Contains("3 lines") && Catch::Contains("line 6") &&
                        Catch::Contains("'V'"));
    const std::string q = tmp.file("nbsp.obj", "\xC2\xA0v 9 9 9\n" + quad + "f 1 2 3\nf 1 3 4\n");
    const std::string nbsp = stderrOf([&] { readMesh(q); });
    CHECK_THAT(nbsp, Catch::Contains(q + ": ") && Catch::Contains("1 line ") &&
                         Catch::Contains("line 1") && Catch::Contains("'\\xc2\\xa0v'"));
  }
}

TEST_CASE("ASCII PLY values are whitespace-separated: elements may span or share lines",
          "[mesh][io]") {
  TempDir tmp;
  const std::string header =
      "ply\nformat ascii 1.0\nelement vertex 4\nproperty double x\nproperty double y\n"
      "property double z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n";
  const Mesh lines = readMesh(tmp.file(
      "lines.ply", header + "0 0 0.5\n1 0 0\n1 1 0\n0 1 0.25\n3 0 1 2\n3 0 2 3\n"));
  const Mesh free = readMesh(tmp.file(
      "free.ply", header + "0 0\n0.5 1 0 0 1\n1\t0 0 1 0.25 3\n0 1 2 3 0\n\n2 3\n"));
  CHECK(free.positions() == lines.positions());
  CHECK(free.elements() == lines.elements());
  SECTION("a missing value is named with its element and line") {
    const std::string p = tmp.file("short.ply", header + "0 0 0 1 0 0 1 1 0 0 1 0\n3 0 1 2\n3 0 2\n");
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(p); }),
               Catch::Contains("short.ply:12") && Catch::Contains("face 1") &&
                   Catch::Contains("too few values"));
  }
}

TEST_CASE("ASCII PLY integers are integers within their type; the format is 1.0", "[mesh][io]") {
  TempDir tmp;
  // Vertex properties `props` (after x y z), faces with `list` indices, `body` after the header.
  const auto ply = [&](const std::string& props, const std::string& list, const std::string& body) {
    return tmp.file("t.ply",
                    "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\n"
                    "property double y\nproperty double z\n" +
                        props + "element face 1\nproperty list " + list +
                        " vertex_indices\nend_header\n" + body);
  };
  const auto error = [&](const std::string& path) {
    return messageOf<InvalidMesh>([&] { readMesh(path); });
  };
  SECTION("the ends of each type's range read as themselves") {
    const std::string p =
        ply("property char a\nproperty uchar b\nproperty short c\nproperty ushort d\n"
            "property int e\nproperty uint f\nproperty int8 g\nproperty uint8 h\n",
            "uint8 uint32",
            "0 0 0 -128 255 -32768 65535 -2147483648 4294967295 -128 255\n"
            "1 0 0 127 0 32767 0 2147483647 0 127 0\n0 1 0 +1 00 0 0 0 0 0 0\n3 0 1 2\n");
    const Mesh mesh = readMesh(p);
    CHECK(mesh.numVertices() == 3);
    CHECK(mesh.elements() == (Eigen::MatrixXi(1, 3) << 0, 1, 2).finished());
  }
  SECTION("a value beyond its type names the file, line, element and property") {
    const std::string p =
        ply("property uchar red\n", "uchar int", "0 0 0 0\n1 0 0 300\n0 1 0 0\n3 0 1 2\n");
    CHECK_THAT(error(p), Catch::Contains(p + ":12: vertex 1") && Catch::Contains("'300'") &&
                             Catch::Contains("'red'") && Catch::Contains("uchar: 0..255"));
    for (const auto& [type, value] :
         std::vector<std::pair<std::string, std::string>>{{"char", "-129"},
                                                          {"int8", "128"},
                                                          {"uchar", "-1"},
                                                          {"uint8", "256"},
                                                          {"short", "32768"},
                                                          {"int16", "-32769"},
                                                          {"ushort", "65536"},
                                                          {"uint16", "-1"},
                                                          {"int", "2147483648"},
                                                          {"int32", "-2147483649"},
                                                          {"uint", "4294967296"},
                                                          {"uint32", "-1"},
                                                          {"int", "99999999999999999999999"}}) {
      INFO(type << " " << value);
      const std::string q = ply("property " + type + " v\n", "uchar int",
                                "0 0 0 0\n1 0 0 0\n0 1 0 " + value + "\n3 0 1 2\n");
      CHECK_THAT(error(q), Catch::Contains(q + ":13: vertex 2") &&
                               Catch::Contains("'" + value + "' is out of range") &&
                               Catch::Contains(type));
    }
  }
  SECTION("a value that is no integer") {
    for (const std::string value : {"2.5", "1.0", "1e0", "0x1", "one"}) {
      INFO(value);
      const std::string p =
          ply("property int v\n", "uchar int", "0 0 0 " + value + "\n1 0 0 0\n0 1 0 0\n3 0 1 2\n");
      CHECK_THAT(error(p), Catch::Contains(p + ":11: vertex 0") &&
                               Catch::Contains("expected an integer for property 'v' (int)"));
    }
    // A face index of 2.5 used to be read as 2.
    const std::string p = ply("", "uchar int", "0 0 0\n1 0 0\n0 1 0\n3 0 1 2.5\n");
    CHECK_THAT(error(p), Catch::Contains(p + ":13: face 0") &&
                             Catch::Contains("list 'vertex_indices' (int), got '2.5'"));
  }
  SECTION("list counts likewise") {
    for (const std::string count : {"256", "3.0", "-3"}) {
      INFO(count);
      const std::string p = ply("", "uchar int", "0 0 0\n1 0 0\n0 1 0\n" + count + " 0 1 2\n");
      CHECK_THAT(error(p), Catch::Contains(p + ":13: face 0 has a bad list length '" + count) &&
                               Catch::Contains("uchar"));
    }
    const std::string p = ply("", "char int", "0 0 0\n1 0 0\n0 1 0\n128 0 1 2\n");
    CHECK_THAT(error(p), Catch::Contains("'128'") && Catch::Contains("char: -128..127"));
  }
  SECTION("a binary count of a signed type is signed") {
    std::string binary = binaryTrianglePly("char");
    binary += '\xff';  // -1, not 255
    binary += std::string(255 * 4, '\0');
    const std::string p = tmp.file("signed.ply", binary);
    CHECK_THAT(error(p), Catch::Contains(p + ": face 0 has a bad list length '-1'"));
  }
  SECTION("a list that the end of the file cuts off says so") {
    std::string binary = binaryTrianglePly("uchar");
    binary += '\3';
    binary += std::string(4, '\0');  // one of its three indices
    const std::string p = tmp.file("cut.ply", binary);
    CHECK_THAT(error(p), Catch::Contains(p + ": face 0: its list 'vertex_indices' of 3 items runs "
                                             "past the end of the file"));
    const std::string q = ply("", "uchar int", "0 0 0\n1 0 0\n0 1 0\n200 0 1 2\n");
    CHECK_THAT(error(q),
               Catch::Contains(q + ":13: face 0: its list 'vertex_indices' of 200 items"));
  }
  SECTION("the format line is ascii, binary_little_endian or binary_big_endian 1.0") {
    for (const std::string format :
         {"format ascii 2.0", "format ascii 1", "format ascii", "format ascii 1.0 extra",
          "format binary_little_endian 1.1", "format binary_big_endian 0.9", "format",
          "format ASCII 1.0", "format ascii 1.0\nformat binary_little_endian 1.0"}) {
      INFO(format);
      const std::string p =
          tmp.file("f.ply", "ply\n" + format +
                                "\nelement vertex 3\nproperty float x\nproperty float y\n"
                                "property float z\nelement face 1\n"
                                "property list uchar int vertex_indices\nend_header\n"
                                "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
      CHECK_THAT(error(p), Catch::Contains(p + ":") && Catch::Contains("format"));
    }
  }
}

TEST_CASE("polygons are triangulated, unreferenced vertices keep their numbering", "[mesh][io]") {
  TempDir tmp;
  const std::string p =
      tmp.file("poly.obj",
               "# a quad and a triangle\nv 0 0 0\nv 1 0 0\nv 7 7 0\nv 1 1 0\nv 0 1 0\n"
               "v 2 0.5 0\nf 1 2 4 5\nf 2 6 4\n");
  const Mesh mesh = readMesh(p);
  CHECK(mesh.kind() == MeshKind::Planar);
  CHECK(mesh.numVertices() == 6);
  CHECK(mesh.numElements() == 3);
  const auto used = mesh.referenced();
  CHECK(used == std::vector<bool>{true, true, false, true, true, true});
  CHECK(mesh.positions().row(2) == Eigen::RowVector3d(7, 7, 0));
  CHECK(mesh.positions().row(5) == Eigen::RowVector3d(2, 0.5, 0));
}

TEST_CASE("Medit .mesh reading", "[mesh][io]") {
  TempDir tmp;
  SECTION("other blocks, comments and any keyword case are fine") {
    const std::string p =
        tmp.file("ok.mesh",
                 "meshversionformatted 1 # comment\nDIMENSION\n3\n# a comment line\n"
                 "Vertices\n5\n0 0 0 1\n1 0 0 1\n0 1 0 1\n0 0 1 1\n1 1 1 1\n"
                 "Edges\n1\n1 2 0\nCorners\n2\n1\n2\nTriangles\n2\n1 2 3 0\n2 3 4 0\n"
                 "tetrahedra\n2\n1 2 3 4 0\n2 5 3 4 7\nRequiredVertices 1 3\nEnd\n");
    const Mesh mesh = readMesh(p);
    CHECK(mesh.kind() == MeshKind::Tet);
    CHECK(mesh.numVertices() == 5);
    CHECK(mesh.numElements() == 2);
    CHECK(mesh.tet().tets[1] == std::array<int, 4>{1, 4, 2, 3});
  }
  SECTION("all tets negatively oriented: reoriented") {
    const std::string p = tmp.file("neg.mesh",
                                   "Vertices\n4\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n"
                                   "Tetrahedra\n1\n1 3 2 4 0\n");
    const Mesh mesh = readMesh(p);
    CHECK(totalVolume(mesh) == Approx(1.0 / 6.0));
  }
  SECTION("no tetrahedra") {
    const std::string p = tmp.file("surf.mesh",
                                   "Dimension 3\nVertices\n3\n0 0 0 0\n1 0 0 0\n0 1 0 0\n"
                                   "Triangles\n1\n1 2 3 0\nEnd\n");
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(p); }),
               Catch::Contains(p) && Catch::Contains("no tetrahedra"));
  }
  SECTION("index out of range names the line and the tet") {
    std::string text = kTetFile;
    text.replace(text.find("2 5 3 4 0"), 9, "2 6 3 4 0");
    const std::string p = tmp.file("range.mesh", text);
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(p); }),
               Catch::Contains(p + ":13") && Catch::Contains("tet 2") &&
                   Catch::Contains("index 6 out of range 1..5"));
  }
  SECTION("non-finite coordinate") {
    std::string text = kTetFile;
    text.replace(text.find("1 1 1 1"), 7, "1 inf 1 1");
    const std::string p = tmp.file("inf.mesh", text);
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(p); }),
               Catch::Contains(p + ":9") && Catch::Contains("vertex 5 has a non-finite"));
  }
  SECTION("bad number") {
    std::string text = kTetFile;
    text.replace(text.find("1 1 1 1"), 7, "1 x 1 1");
    const std::string p = tmp.file("bad.mesh", text);
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(p); }),
               Catch::Contains(p + ":9") && Catch::Contains("'x'"));
  }
  SECTION("truncated") {
    std::string text = kTetFile;
    text = text.substr(0, text.find("2 5 3 4 0"));
    const std::string p = tmp.file("short.mesh", text);
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(p); }),
               Catch::Contains(p) && Catch::Contains("end of file") && Catch::Contains("tet 2"));
  }
  SECTION("degenerate tet (coplanar, or repeated vertex)") {
    std::string text = kTetFile;
    text.replace(text.find("1 1 1 1"), 7, "1 1 0 1");  // vertex 5 in the plane z = 0
    text.replace(text.find("2 5 3 4 0"), 9, "1 2 5 3 0");
    const std::string p = tmp.file("flat.mesh", text);
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(p); }),
               Catch::Contains(p) && Catch::Contains("tet 1 (0-based) is degenerate"));
    std::string rep = kTetFile;
    rep.replace(rep.find("2 5 3 4 0"), 9, "2 5 5 4 0");
    const std::string q = tmp.file("rep.mesh", rep);
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(q); }),
               Catch::Contains(q) && Catch::Contains("tet 1 (0-based) is degenerate"));
  }
  SECTION("an inverted tet among positive ones") {
    std::string text = kTetFile;
    text.replace(text.find("2 5 3 4 0"), 9, "2 5 4 3 0");
    const std::string p = tmp.file("inv.mesh", text);
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(p); }),
               Catch::Contains(p) && Catch::Contains("tet 1 (0-based) is inverted"));
  }
  SECTION("a repeated tet is refused, whatever its vertex order") {
    std::string text = kTetFile;  // tets 1 2 3 4 and 2 5 3 4 share the triangle 2 3 4
    text.replace(text.find("Tetrahedra\n2\n"), 13, "Tetrahedra\n3\n1 2 3 4 0\n");
    const std::string p = tmp.file("twice.mesh", text);
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(p); }),
               Catch::Contains(p) && Catch::Contains("tets 0 and 1 (0-based)") &&
                   Catch::Contains("same side") && Catch::Contains("repeated"));
    // Alone, each of its triangles is on two tets: the sides tell the copies apart.
    for (const char* copy : {"1 2 3 4 0", "2 1 4 3 0", "3 4 1 2 0"}) {
      INFO(copy);
      const std::string q = tmp.file("alone.mesh",
                                     "Vertices\n4\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n"
                                     "Tetrahedra\n2\n1 2 3 4 0\n" +
                                         std::string(copy) + "\n");
      CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(q); }),
                 Catch::Contains(q) && Catch::Contains("tets 0 and 1 (0-based)"));
    }
  }
  SECTION("a triangle of three tets is refused, naming them") {
    // Tets 2 and 3 both stand on the triangle 1 2 3 above z = 0, tet 1 below it.
    const std::string p = tmp.file("three.mesh",
                                   "Vertices\n6\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 -1 0\n"
                                   "0 0 1 0\n0.2 0.2 2 0\nTetrahedra\n3\n1 3 2 4 0\n"
                                   "1 2 3 5 0\n1 2 3 6 0\n");
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(p); }),
               Catch::Contains(p) && Catch::Contains("tets 0, 1 and 2 (0-based)") &&
                   Catch::Contains("vertices 0, 1, 2;"));
  }
  SECTION("TetGen: a repeated tet is refused too") {
    tmp.file("rep.node", "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n");
    const std::string e = tmp.file("rep.ele", "2 4 0\n1 1 2 3 4\n2 1 2 3 4\n");
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(e); }),
               Catch::Contains("rep.ele") && Catch::Contains("tets 0 and 1 (0-based)"));
  }
  SECTION("a 2D Medit mesh is refused") {
    const std::string p = tmp.file("d2.mesh", "Dimension 2\nVertices\n0\n");
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(p); }), Catch::Contains(p + ":1"));
  }
}

TEST_CASE("TetGen .node/.ele, 0- and 1-based", "[mesh][io]") {
  TempDir tmp;
  for (int base : {0, 1}) {
    INFO("first index " << base);
    const std::string b = std::to_string(base);
    const auto id = [&](int i) { return std::to_string(i + base); };
    std::string node = "# points\n5 3 1 1\n";
    const char* pts[] = {"0 0 0", "1 0 0", "0 1 0", "0 0 1", "1 1 1"};
    for (int i = 0; i < 5; ++i) node += id(i) + "  " + pts[i] + "  0.5 1\n";
    const std::string ele = "2 4 0\n" + id(0) + " " + id(0) + " " + id(1) + " " + id(2) + " " +
                            id(3) + "\n" + id(1) + " " + id(1) + " " + id(4) + " " + id(2) + " " +
                            id(3) + "\n";
    tmp.file("t" + b + ".node", node);
    tmp.file("t" + b + ".ele", ele);
    for (const char* ext : {".node", ".ele"}) {
      const Mesh mesh = readMesh(tmp / ("t" + b + ext));
      CHECK(mesh.kind() == MeshKind::Tet);
      CHECK(mesh.numVertices() == 5);
      CHECK(mesh.tet().tets[0] == std::array<int, 4>{0, 1, 2, 3});
      CHECK(mesh.tet().tets[1] == std::array<int, 4>{1, 4, 2, 3});
    }
  }
  SECTION("missing partner file") {
    tmp.file("lonely.node", "1 3 0 0\n0 0 0 0\n");
    CHECK_THAT(messageOf<IoError>([&] { readMesh(tmp / "lonely.node"); }),
               Catch::Contains(tmp / "lonely.ele"));
  }
  SECTION("every line has the values its header names") {
    const std::string corners = "1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n";
    const auto error = [&](const std::string& node, const std::string& ele) {
      tmp.file("h.node", node);
      tmp.file("h.ele", ele);
      return messageOf<InvalidMesh>([&] { readMesh(tmp / "h.node"); });
    };
    // Two attributes claimed, none given; a count no line could hold; a marker of 2.
    CHECK_THAT(error("4 3 2 0\n" + corners, "1 4 0\n1 1 2 3 4\n"),
               Catch::Contains("h.node:2: a point line of 4 values; the header says 6"));
    CHECK_THAT(error("4 3 2000000000 0\n" + corners, "1 4 0\n1 1 2 3 4\n"),
               Catch::Contains("h.node:1: the header's attributes count is '2000000000'"));
    CHECK_THAT(error("4 3 0 2\n" + corners, "1 4 0\n1 1 2 3 4\n"),
               Catch::Contains("boundary markers count is '2'"));
    CHECK_THAT(error("4 3 0 0\n" + corners, "1 4 1\n1 1 2 3 4\n"),
               Catch::Contains("h.ele:2: a tet line of 5 values; the header says 6"));
    CHECK_THAT(error("4 3 0 0\n" + corners, "1 5 0\n1 1 2 3 4 4\n"),
               Catch::Contains("5 nodes per tet (4 or 10)"));
    // As TetGen writes them: with a region attribute, and quadratic tets (their corners first).
    tmp.file("r.node", "4 3 0 1\n1 0 0 0 1\n2 1 0 0 1\n3 0 1 0 1\n4 0 0 1 1\n");
    tmp.file("r.ele", "1 4 1\n1 1 2 3 4 7\n");
    CHECK(readMesh(tmp / "r.ele").numElements() == 1);
    std::string quadratic = "10 3 0 0\n" + corners;
    for (int i = 5; i <= 10; ++i) quadratic += std::to_string(i) + " 0.1 0.1 0.1\n";
    tmp.file("q.node", quadratic);
    tmp.file("q.ele", "1 10 0\n1 1 2 3 4 5 6 7 8 9 10\n");
    CHECK(readMesh(tmp / "q.ele").tet().tets[0] == std::array<int, 4>{0, 1, 2, 3});
  }
  SECTION("index out of range") {
    tmp.file("bad.node", "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n");
    const std::string e = tmp.file("bad.ele", "1 4 0\n1 1 2 3 5\n");
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(tmp / "bad.node"); }),
               Catch::Contains(e + ":2") && Catch::Contains("out of range 1..4"));
  }
}

TEST_CASE("Medit write then read gives identical doubles", "[mesh][io]") {
  TempDir tmp;
  TetMesh tet;
  tet.points = {{0.1, 1.0 / 3.0, M_PI},
                {1.0 + 1e-15, 2.0 / 7.0, -1e-300},
                {1e-17, 1.0 + 0.1, 0.3},
                {0.7, 0.2, 5.0}};
  tet.tets = {{0, 1, 2, 3}};
  const Eigen::Vector3d a = tet.points[0], b = tet.points[1], c = tet.points[2], d = tet.points[3];
  if ((b - a).dot((c - a).cross(d - a)) < 0) std::swap(tet.tets[0][2], tet.tets[0][3]);
  const Mesh mesh(tet);
  const std::string p = tmp / "round.mesh";
  writeMesh(p, mesh);
  const Mesh back = readMesh(p);
  CHECK(back.positions() == mesh.positions());
  CHECK(back.elements() == mesh.elements());
}

TEST_CASE("OBJ, OFF and OM round trips", "[mesh][io]") {
  TempDir tmp;
  const std::string src = tmp.file("src.obj",
                                   "v 0 0 0.25\nv 1.5 0 0\nv 1 1.125 0\nv 0 1 0.5\n"
                                   "f 1 2 3\nf 1 3 4\n");
  Mesh mesh = readMesh(src);
  for (const char* ext : {"obj", "off", "om"}) {
    INFO(ext);
    const std::string p = tmp / (std::string("out.") + ext);
    writeMesh(p, mesh);
    const Mesh back = readMesh(p);
    CHECK(back.kind() == MeshKind::Surface);
    CHECK(back.elements() == mesh.elements());
    CHECK(back.positions() == mesh.positions());  // exactly representable values
  }
  SECTION("OM keeps doubles and the scalar properties") {
    Eigen::MatrixXd p = mesh.positions();
    p(1, 0) = 0.1;
    p(2, 2) = 1.0 / 3.0;
    mesh.setPositions(p);
    mesh.setVertexScalar(prop::weight, Eigen::Vector4d(0.1, 0.2, 1.0 / 3.0, 0.0));
    mesh.setElementScalar(prop::distortion, Eigen::Vector2d(M_PI, 1e-300));
    writeMesh(tmp / "props.om", mesh);
    const Mesh back = readMesh(tmp / "props.om");
    CHECK(back.positions() == p);
    REQUIRE(back.hasVertexScalar(prop::weight));
    REQUIRE(back.hasElementScalar(prop::distortion));
    CHECK(back.vertexScalar(prop::weight) == mesh.vertexScalar(prop::weight));
    CHECK(back.elementScalar(prop::distortion) == mesh.elementScalar(prop::distortion));
    CHECK(back.vertexScalarNames() == std::vector<std::string>{prop::weight});
  }
}

TEST_CASE("large meshes, formatted in blocks on several threads, round-trip in order",
          "[mesh][io]") {
  // More rows than one formatting block (1024) of vertices, and faces over more than one
  // round of 64 blocks, with coordinates and values that need all 17 digits: any block written
  // out of place or twice shows here.
  TempDir tmp;
  Mesh mesh = makeSphere(1.0, 200, 180);
  REQUIRE(mesh.numVertices() > 4 * 1024);
  REQUIRE(mesh.numElements() > 64 * 1024);
  Eigen::MatrixXd p = mesh.positions();
  for (Eigen::Index i = 0; i < p.rows(); ++i) p.row(i) *= 1.0 + std::sqrt(2.0) * 1e-3 * i;
  mesh.setPositions(p);
  const Eigen::VectorXd w = Eigen::VectorXd::LinSpaced(mesh.numVertices(), 0.0, M_PI).array().sin();
  const Eigen::VectorXd d = Eigen::VectorXd::LinSpaced(mesh.numElements(), 1.0 / 3.0, 7.0);
  mesh.setVertexScalar(prop::weight, w);
  mesh.setElementScalar(prop::distortion, d);
  for (const char* ext : {"obj", "off", "ply"}) {
    INFO(ext);
    const std::string path = tmp / (std::string("big.") + ext);
    writeMesh(path, mesh);
    const Mesh back = readMesh(path);
    CHECK(back.positions() == p);
    CHECK(back.elements() == mesh.elements());
  }
  const Ply ply = parsePly(tmp / "big.ply");
  const auto& vs = ply.rows.at("vertex");
  const auto& fs_ = ply.rows.at("face");
  REQUIRE(vs.size() == static_cast<size_t>(w.size()));
  REQUIRE(fs_.size() == static_cast<size_t>(d.size()));
  Eigen::Index firstWrongVertex = -1, firstWrongFace = -1;
  for (Eigen::Index i = 0; i < w.size() && firstWrongVertex < 0; ++i)
    if (vs[i][3] != w[i]) firstWrongVertex = i;
  for (Eigen::Index k = 0; k < d.size() && firstWrongFace < 0; ++k)
    if (fs_[k][4] != d[k]) firstWrongFace = k;
  CHECK(firstWrongVertex == -1);
  CHECK(firstWrongFace == -1);

  Mesh tet = makeTetBox(1.0, 1.0 / 3.0, 0.7, 12, 10, 10);
  REQUIRE(tet.numVertices() > 1024);
  writeMesh(tmp / "big.mesh", tet);
  const Mesh tetBack = readMesh(tmp / "big.mesh");
  CHECK(tetBack.positions() == tet.positions());
  CHECK(tetBack.elements() == tet.elements());
}

TEST_CASE("a failed write leaves the existing file untouched and no temp file", "[mesh][io]") {
  TempDir tmp;
  const std::string keep = "precious\n";
  const Mesh tri = readMesh(tmp.file("t.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"));
  const Mesh tet = readMesh(tmp.file("t.mesh", kTetFile));
  const auto onlyFiles = [&](std::vector<std::string> names) {
    std::vector<std::string> found;
    for (const auto& e : fs::directory_iterator(tmp.path)) found.push_back(e.path().filename());
    std::sort(found.begin(), found.end());
    std::sort(names.begin(), names.end());
    CHECK(found == names);
  };

  SECTION("unsupported extension for the kind") {
    const std::string out = tmp.file("out.obj", keep);
    CHECK_THAT(messageOf<IoError>([&] { writeMesh(out, tet); }),
               Catch::Contains(out) && Catch::Contains("mesh, ply"));
    CHECK(slurp(out) == keep);
    const std::string out2 = tmp.file("out.mesh", keep);
    CHECK_THAT(messageOf<IoError>([&] { writeMesh(out2, tri); }), Catch::Contains(out2));
    CHECK(slurp(out2) == keep);
  }
  SECTION("rename onto a directory fails after writing") {
    const std::string out = tmp / "dir.ply";
    fs::create_directory(out);
    tmp.file("dir.ply/inside", keep);
    CHECK_THAT(messageOf<IoError>([&] { writeMesh(out, tri); }), Catch::Contains(out));
    CHECK(fs::is_directory(out));
    CHECK(slurp(tmp / "dir.ply/inside") == keep);
    onlyFiles({"t.obj", "t.mesh", "dir.ply"});
  }
  SECTION("missing directory") {
    const std::string out = tmp / "no/such/dir/out.obj";
    CHECK_THAT(messageOf<IoError>([&] { writeMesh(out, tri); }), Catch::Contains(out));
    onlyFiles({"t.obj", "t.mesh"});
  }
  SECTION("non-finite values are never written") {
    const std::string out = tmp.file("out.ply", keep);
    Mesh bad = tri;
    bad.setVertexScalar(prop::weight, Eigen::Vector3d(0, NAN, 1));
    CHECK_THROWS_AS(writeMesh(out, bad), InvalidMesh);
    CHECK(slurp(out) == keep);
    onlyFiles({"t.obj", "t.mesh", "out.ply"});
  }
  SECTION("a successful write replaces the file") {
    const std::string out = tmp.file("out.off", keep);
    writeMesh(out, tri);
    CHECK(readMesh(out).numElements() == 1);
    onlyFiles({"t.obj", "t.mesh", "out.off"});
  }
}

TEST_CASE("PLY carries vertex and face quality and viridis colours", "[mesh][io]") {
  TempDir tmp;
  Mesh mesh = readMesh(tmp.file("q.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n"));
  const Eigen::Vector4d w(0.0, 0.25, 1.5, -0.5);
  const Eigen::Vector2d d(0.125, 3.0);
  mesh.setVertexScalar(prop::weight, w);
  mesh.setElementScalar(prop::distortion, d);
  const std::string out = tmp / "q.ply";
  writeMesh(out, mesh);

  SECTION("header and values") {
    const Ply ply = parsePly(out);
    CHECK(ply.props.at("vertex") ==
          std::vector<std::string>{"x", "y", "z", "quality", "red", "green", "blue"});
    CHECK(ply.props.at("face") == std::vector<std::string>{"vertex_indices", "quality"});
    const auto& vs = ply.rows.at("vertex");
    REQUIRE(vs.size() == 4u);
    for (int i = 0; i < 4; ++i) {
      CHECK(vs[i][3] == w[i]);
      const auto rgb = viridis(std::clamp(w[i], 0.0, 1.0));
      CHECK(vs[i][4] == rgb[0]);
      CHECK(vs[i][5] == rgb[1]);
      CHECK(vs[i][6] == rgb[2]);
    }
    const auto& fs_ = ply.rows.at("face");
    REQUIRE(fs_.size() == 2u);
    CHECK(fs_[0][4] == d[0]);
    CHECK(fs_[1][4] == d[1]);
  }
  SECTION("OpenMesh reads the quality back as custom properties") {
    TriMesh back;
    OpenMesh::IO::Options opt = OpenMesh::IO::Options::Custom;
    REQUIRE(OpenMesh::IO::read_mesh(back, out, opt));
    OpenMesh::VPropHandleT<double> vq;
    OpenMesh::FPropHandleT<double> fq;
    REQUIRE(back.get_property_handle(vq, "quality"));
    REQUIRE(back.get_property_handle(fq, "quality"));
    for (int i = 0; i < 4; ++i) CHECK(back.property(vq, back.vertex_handle(i)) == w[i]);
    CHECK(back.property(fq, back.face_handle(1)) == d[1]);
  }
  SECTION("readMesh reads the qualities back as the properties they hold, exactly") {
    const Mesh back = readMesh(out);
    REQUIRE(back.hasVertexScalar(prop::weight));
    REQUIRE(back.hasElementScalar(prop::distortion));
    CHECK(back.vertexScalar(prop::weight) == Eigen::VectorXd(w));
    CHECK(back.elementScalar(prop::distortion) == Eigen::VectorXd(d));
    // Other names, as the writer's options give them.
    WriteOptions named;
    named.vertexQuality = prop::distortion;  // absent on vertices: no vertex quality
    named.faceQuality = "my:area";
    Mesh other = mesh;
    other.setElementScalar("my:area", Eigen::Vector2d(0.5, 0.25));
    writeMesh(tmp / "named.ply", other, named);
    const Mesh again = readMesh(tmp / "named.ply");
    REQUIRE(again.hasElementScalar("my:area"));
    CHECK(again.elementScalar("my:area")(1) == 0.25);
    // The properties that are not the qualities go out under their own names.
    const Ply ply = parsePly(tmp / "named.ply");
    CHECK(ply.props.at("vertex") == std::vector<std::string>{"x", "y", "z", prop::weight});
    CHECK(ply.props.at("face") ==
          std::vector<std::string>{"vertex_indices", "quality", prop::distortion});
    REQUIRE(again.hasVertexScalar(prop::weight));
    REQUIRE(again.hasElementScalar(prop::distortion));
    CHECK(again.vertexScalar(prop::weight) == Eigen::VectorXd(w));
    CHECK(again.elementScalar(prop::distortion) == Eigen::VectorXd(d));
  }
  SECTION("a quality whose meaning the file does not state is not taken for the weights") {
    const std::string foreign = tmp.file(
        "foreign.ply",
        "ply\nformat ascii 1.0\ncomment VCGLIB generated\nelement vertex 3\nproperty double x\n"
        "property double y\nproperty double z\nproperty float quality\nelement face 1\n"
        "property list uchar int vertex_indices\nproperty float quality\nend_header\n"
        "0 0 0 0.5\n1 0 0 0.5\n0 1 0 0.5\n3 0 1 2 7\n");
    const Mesh back = readMesh(foreign);
    CHECK_FALSE(back.hasVertexScalar(prop::weight));
    CHECK_FALSE(back.hasElementScalar(prop::distortion));
  }
  SECTION("a named quality that is not finite names the element") {
    std::string text = slurp(out);
    const size_t at = text.find(" 0.25 ");
    REQUIRE(at != std::string::npos);
    text.replace(at, 6, " nan ");
    CHECK_THROWS_WITH(readMesh(tmp.file("nan.ply", text)),
                      Catch::Contains("vertex 1") && Catch::Contains("non-finite quality"));
  }
  SECTION("no properties, no colours: plain PLY that readMesh reads") {
    const Mesh plain = readMesh(tmp.file("p.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"));
    writeMesh(tmp / "p.ply", plain);
    const Ply ply = parsePly(tmp / "p.ply");
    CHECK(ply.props.at("vertex") == std::vector<std::string>{"x", "y", "z"});
    CHECK(readMesh(tmp / "p.ply").numElements() == 1);
  }
}

TEST_CASE("PLY of a tet mesh: boundary faces carry their tet's value", "[mesh][io]") {
  TempDir tmp;
  Mesh mesh = readMesh(tmp.file("two.mesh", kTetFile));
  mesh.setVertexScalar(prop::weight, Eigen::VectorXd::LinSpaced(5, 0.0, 1.0));
  mesh.setElementScalar(prop::distortion, Eigen::Vector2d(10.0, 20.0));
  writeMesh(tmp / "two.ply", mesh);
  const Ply ply = parsePly(tmp / "two.ply");
  const auto& faces = ply.rows.at("face");
  REQUIRE(faces.size() == 6u);  // 8 tet faces, one shared
  REQUIRE(ply.rows.at("vertex").size() == 5u);
  int tenths = 0, twenties = 0;
  for (const auto& f : faces) {
    // Face vertices all belong to the owning tet: tet 0 = {0,1,2,3}, tet 1 = {1,4,2,3}.
    const bool usesV4 = f[1] == 4 || f[2] == 4 || f[3] == 4;
    const bool usesV0 = f[1] == 0 || f[2] == 0 || f[3] == 0;
    CHECK(f[4] == (usesV4 ? 20.0 : 10.0));
    if (usesV0) ++tenths;
    if (usesV4) ++twenties;
  }
  CHECK(tenths == 3);
  CHECK(twenties == 3);
  for (int i = 0; i < 5; ++i) CHECK(ply.rows.at("vertex")[i][3] == Approx(0.25 * i));
  // Read back, the boundary surface has the weights again; its faces' values are their tets',
  // not a distortion of the faces, so they do not come back as one.
  const Mesh back = readMesh(tmp / "two.ply");
  REQUIRE(back.hasVertexScalar(prop::weight));
  CHECK(back.vertexScalar(prop::weight)(4) == 1.0);
  CHECK_FALSE(back.hasElementScalar(prop::distortion));
}

TEST_CASE("PLY quality names that cannot be written or read back say so", "[mesh][io]") {
  TempDir tmp;
  Mesh mesh = readMesh(tmp.file("q.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"));
  mesh.setVertexScalar("my weight", Eigen::Vector3d(0.1, 0.2, 0.3));
  WriteOptions spaced;
  spaced.vertexQuality = "my weight";
  const std::string err = stderrOf([&] { writeMesh(tmp / "s.ply", mesh, spaced); });
  CHECK(err.find("'my weight' goes out as quality without its name") != std::string::npos);
  CHECK_FALSE(readMesh(tmp / "s.ply").hasVertexScalar("my weight"));
  // A header naming it in bytes other than printable ASCII: warned about, not kept.
  std::string text = slurp(tmp / "s.ply");
  text.insert(text.find("element vertex"), "comment diffreg vertex quality w\xe9ight\n");
  const std::string path = tmp.file("named.ply", text);
  Mesh back;
  const std::string warned = stderrOf([&] { back = readMesh(path); });
  CHECK(warned.find("the vertex quality naming 'w\\xe9ight' is not printable ASCII; not kept") !=
        std::string::npos);
  CHECK(back.vertexScalarNames().empty());
}

TEST_CASE("PLY keeps every named property, exactly, under its own name", "[mesh][io]") {
  TempDir tmp;
  Mesh mesh = readMesh(tmp.file("q.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n"));
  const Eigen::Vector4d w(0.1, 1.0 / 3.0, 2.5e-300, -7.0), g(1e300, -0.0, 4.0, 0.5);
  const Eigen::Vector2d d(0.125, 3.0), s(1.0 / 7.0, 2.0);
  mesh.setVertexScalar(prop::weight, w);
  mesh.setVertexScalar("geodesic", g);
  mesh.setElementScalar(prop::distortion, d);
  mesh.setElementScalar(prop::smoothness, s);
  writeMesh(tmp / "all.ply", mesh);
  const Mesh back = readMesh(tmp / "all.ply");
  CHECK(back.vertexScalarNames().size() == 2u);
  CHECK(back.elementScalarNames().size() == 2u);
  CHECK(back.vertexScalar(prop::weight) == Eigen::VectorXd(w));
  CHECK(back.vertexScalar("geodesic") == Eigen::VectorXd(g));
  CHECK(back.elementScalar(prop::distortion) == Eigen::VectorXd(d));
  CHECK(back.elementScalar(prop::smoothness) == Eigen::VectorXd(s));
  // OpenMesh reads the file, each extra property as a custom property of its name.
  TriMesh om;
  OpenMesh::IO::Options opt = OpenMesh::IO::Options::Custom;
  REQUIRE(OpenMesh::IO::read_mesh(om, tmp / "all.ply", opt));
  OpenMesh::VPropHandleT<double> geodesic;
  REQUIRE(om.get_property_handle(geodesic, "geodesic"));
  CHECK(om.property(geodesic, om.vertex_handle(2)) == 4.0);

  SECTION("a name PLY cannot hold is warned about, the file still reads") {
    Mesh odd = mesh;
    odd.setVertexScalar("x", w);
    odd.setElementScalar("two words", d);
    const std::string err = stderrOf([&] { writeMesh(tmp / "odd.ply", odd); });
    CHECK(err.find("vertex property 'x' is not written (PLY readers take a property of that "
                   "name for something else); .om keeps it") != std::string::npos);
    CHECK(err.find("element property 'two words' is not written") != std::string::npos);
    const Mesh again = readMesh(tmp / "odd.ply");
    CHECK(again.vertexScalarNames().size() == 2u);
    CHECK(again.points() == odd.points());
  }
  SECTION("a tet mesh's boundary keeps the vertex properties") {
    Mesh tet = readMesh(tmp.file("two.mesh", kTetFile));
    tet.setVertexScalar("geodesic", Eigen::VectorXd::LinSpaced(5, 0.0, 4.0));
    tet.setElementScalar(prop::smoothness, Eigen::Vector2d(1.0, 2.0));
    writeMesh(tmp / "tet.ply", tet);
    const Mesh surface = readMesh(tmp / "tet.ply");
    REQUIRE(surface.hasVertexScalar("geodesic"));
    CHECK(surface.vertexScalar("geodesic") == Eigen::VectorXd::LinSpaced(5, 0.0, 4.0));
    CHECK_FALSE(surface.hasElementScalar(prop::smoothness));  // a tet's value, not a face's
  }
}

TEST_CASE("PLY namings: at most 256, the first of each, the others warned about in one line",
          "[mesh][io][hostile]") {
  TempDir tmp;
  // 300 namings of properties (one of which the file has) and 60,000 second namings of its
  // quality: read in one pass over the header, one warning for every naming not taken and one
  // for those that name nothing.
  std::string header = "ply\nformat ascii 1.0\ncomment diffreg vertex quality w\n";
  for (int i = 0; i < 300; ++i)
    header += "comment diffreg vertex property p" + std::to_string(i) + "\n";
  for (int i = 0; i < 60000; ++i)
    header += "comment diffreg vertex quality w" + std::to_string(i) + "\n";
  header += "comment diffreg face property vertex_indices\ncomment diffreg vertex property x\n";
  const std::string path = tmp.file(
      "many.ply", header +
                      "element vertex 3\nproperty double x\nproperty double y\nproperty double z\n"
                      "property double quality\nproperty double p7\nproperty double p299\n"
                      "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                      "0 0 0 0.5 7 1\n1 0 0 0.25 8 2\n0 1 0 1 9 3\n3 0 1 2\n");
  Mesh mesh;
  const std::string err = stderrOf([&] { mesh = readMesh(path); });
  // w and p0 ... p254 make the 256 kept.
  CHECK(err == "diffreg: warning: " + path +
                   ":259: the vertex property naming 'p255' is one more than the 256 kept; not "
                   "kept (nor 60046 more namings)\n"
                   "diffreg: warning: " +
                   path +
                   ": the header names 254 properties that are no scalar property of their "
                   "element (first: the vertex property 'p0'); they are not kept\n");
  CHECK(mesh.vertexScalar("w") == Eigen::Vector3d(0.5, 0.25, 1.0));
  CHECK(mesh.vertexScalar("p7") == Eigen::Vector3d(7.0, 8.0, 9.0));
  CHECK(mesh.vertexScalarNames().size() == 2u);
  CHECK(mesh.elementScalarNames().empty());
}

TEST_CASE("named PLY values follow polygons and split faces into the built mesh", "[mesh][io]") {
  TempDir tmp;
  // Five vertices with a named quality and `faces` faces with a named property "area".
  const auto file = [&tmp](const std::string& name, int faces, const std::string& body) {
    return tmp.file(name,
                    "ply\nformat ascii 1.0\ncomment diffreg vertex quality diffreg:weight\n"
                    "comment diffreg face property area\nelement vertex 5\n"
                    "property double x\nproperty double y\nproperty double z\n"
                    "property double quality\nelement face " +
                        std::to_string(faces) +
                        "\nproperty list uchar int vertex_indices\n"
                        "property double area\nend_header\n" +
                        body);
  };
  SECTION("each triangle of a polygon takes the polygon's value") {
    const std::string path = file("quad.ply", 2,
                                  "0 0 0 0.5\n1 0 0 1.5\n1 1 0 2.5\n0 1 0 3.5\n2 0 0 4.5\n"
                                  "4 0 1 2 3 7\n3 1 4 2 9\n");
    Mesh mesh;
    const std::string err = stderrOf([&] { mesh = readMesh(path); });
    CHECK(err.find("triangulated 1 polygonal faces into 2 triangles") != std::string::npos);
    CHECK(err.find("not kept") == std::string::npos);
    REQUIRE(mesh.numElements() == 3);
    REQUIRE(mesh.hasElementScalar("area"));
    CHECK(mesh.elementScalar("area") == Eigen::Vector3d(7.0, 7.0, 9.0));
    CHECK(mesh.vertexScalar(prop::weight) == Eigen::VectorXd::LinSpaced(5, 0.5, 4.5));
  }
  SECTION("a vertex copied for a split face takes the value of the vertex it copies") {
    // Three triangles on the edge 0-1: the third is split off with copies of 0, 1 and 4.
    const std::string path = file("fin.ply", 3,
                                  "0 0 0 10\n1 0 0 11\n0 1 0 12\n0 -1 0 13\n0 0 1 14\n"
                                  "3 0 1 2 1\n3 1 0 3 2\n3 0 1 4 3\n");
    Mesh mesh;
    const std::string err = stderrOf([&] { mesh = readMesh(path); });
    CHECK(err.find("split off") != std::string::npos);
    REQUIRE(mesh.numVertices() == 8);
    REQUIRE(mesh.hasVertexScalar(prop::weight));
    const Eigen::VectorXd& w = mesh.vertexScalar(prop::weight);
    const Eigen::MatrixXi f = mesh.elements();
    const Mesh::PointRows p = mesh.points();
    for (int i = 0; i < 8; ++i) {  // each copy sits where its vertex does, with its value
      INFO("vertex " << i);
      const int file = i < 5 ? i : static_cast<int>(std::lround(w[i] - 10.0));
      CHECK(p.row(i) == p.row(file));
    }
    CHECK(w.tail(3) == Eigen::Vector3d(10.0, 11.0, 14.0));
    CHECK(mesh.elementScalar("area") == Eigen::Vector3d(1.0, 2.0, 3.0));
    CHECK(f.row(2).minCoeff() >= 5);
  }
}

TEST_CASE("a mesh file name with a NUL byte is refused before anything else", "[io][hostile]") {
  TempDir dir;
  // The system would take the name cut at the NUL: the existing file "cut".
  std::ofstream(dir / "cut") << "kept";
  const std::string cut = (dir / "cut") + std::string(1, '\0');
  const Mesh mesh = makeRectangle(1.0, 1.0, 2, 2);
  for (const std::string ext : {".obj", ".foo", ".node", ""}) {
    INFO("extension '" << ext << "'");
    CHECK_THROWS_WITH(readMesh(cut + ext), Catch::StartsWith("cannot read '") &&
                                               Catch::Contains("cut\\x00" + ext + "'") &&
                                               Catch::EndsWith("the name has a NUL byte"));
    CHECK_THROWS_WITH(writeMesh(cut + ext, mesh), Catch::StartsWith("cannot write '") &&
                                                      Catch::EndsWith("the name has a NUL byte"));
  }
  std::ifstream in(dir / "cut");
  CHECK(std::string(std::istreambuf_iterator<char>(in), {}) == "kept");
  CHECK(dir.entries() == 1);
}

TEST_CASE(".om keeps property names of up to 255 printable bytes and refuses the others",
          "[io][om]") {
  TempDir dir;
  Mesh mesh = makeRectangle(1.0, 1.0, 2, 2);
  const Eigen::VectorXd values = Eigen::VectorXd::LinSpaced(mesh.numVertices(), 0.0, 1.0);
  const std::string longest(255, 'p');
  mesh.setVertexScalar(longest, values);
  writeMesh(dir / "ok.om", mesh);
  const Mesh back = readMesh(dir / "ok.om");
  REQUIRE(back.hasVertexScalar(longest));
  CHECK(back.vertexScalar(longest) == values);
  // Too long for its length byte (OpenMesh aborted, or wrote a file it cannot read), OpenMesh's
  // own prefixes (never written), bytes the reader skips: refused, nothing written.
  for (const std::string& name :
       {std::string(256, 'p'), std::string(300, 'p'), std::string("v:quality"), std::string("f:x"),
        std::string("b:c"), std::string("caf\xc3\xa9")}) {
    Mesh odd = makeRectangle(1.0, 1.0, 2, 2);
    odd.setVertexScalar(name, values);
    INFO(name.size() << " bytes");
    CHECK_THROWS_WITH(writeMesh(dir / "odd.om", odd), Catch::Contains("cannot be kept in .om"));
  }

  CHECK(dir.entries() == 1);

  // At most 256 properties of vertices (and of faces) are read back, with one warning.
  Mesh many = makeRectangle(1.0, 1.0, 2, 2);
  for (int i = 0; i < 300; ++i) many.setVertexScalar("p" + std::to_string(1000 + i), values);
  const std::string said = stderrOf([&] { writeMesh(dir / "many.om", many); });
  CHECK(said == "diffreg: warning: writing '" + (dir / "many.om") +
                    "': 300 named vertex properties go out, but reading the file back keeps "
                    "only the first 256\n");
  Mesh manyBack;
  const std::string err = stderrOf([&] { manyBack = readMesh(dir / "many.om"); });
  CHECK(err.find("and any later ones are skipped: at most 256 of each are kept") !=
        std::string::npos);
  CHECK(std::count(err.begin(), err.end(), '\n') == 1);
  CHECK(manyBack.vertexScalarNames().size() == 256u);
  // PLY likewise; its quality is one of the named.
  many.setVertexScalar("diffreg:weight", values);
  const std::string plySaid = stderrOf([&] { writeMesh(dir / "many.ply", many); });
  CHECK(plySaid == "diffreg: warning: writing '" + (dir / "many.ply") +
                       "': 301 named vertex properties go out, but reading the file back keeps "
                       "only the first 256\n");
  // At the bound: nothing said.
  Mesh bound = makeRectangle(1.0, 1.0, 2, 2);
  for (int i = 0; i < 256; ++i)
    bound.setElementScalar("f" + std::to_string(i), Eigen::VectorXd::Zero(bound.numElements()));
  CHECK(stderrOf([&] { writeMesh(dir / "bound.ply", bound); }).empty());
  CHECK(stderrOf([&] { writeMesh(dir / "bound.om", bound); }).empty());
}

TEST_CASE("a number in a mesh file takes one sign: +-1 is no number", "[io][hostile]") {
  const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  CHECK(parseObj("v +1 0 0\nv 0 1 0\nv 0 0 1\nf +1 2 3\n", "t.obj").points[0].x() == 1.0);
  CHECK(parseObj(tri + "f -3 -2 -1\n", "t.obj").faces.size() == 1);
  CHECK_THROWS_AS(parseObj("v +-1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\n", "t.obj"), InvalidMesh);
  CHECK_THROWS_AS(parseObj(tri + "f +-3 1 2\n", "t.obj"), InvalidMesh);
  CHECK_THROWS_AS(parseObj("v + 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\n", "t.obj"), InvalidMesh);
  CHECK_THROWS_AS(parseOff("OFF\n3 1 0\n+-1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n", "t.off"), InvalidMesh);
  CHECK_THROWS_AS(parseOff("OFF\n3 1 0\n1 0 0\n0 1 0\n0 0 1\n3 +-0 1 2\n", "t.off"), InvalidMesh);
  CHECK(parseOff("OFF\n3 1 0\n+1 0 0\n0 1 0\n0 0 1\n3 +0 1 2\n", "t.off").points[0].x() == 1.0);
}

TEST_CASE("data past the elements a header declares is refused, not dropped", "[io][hostile]") {
  const std::string plyHead =
      "ply\nformat ascii 1.0\nelement vertex 4\nproperty double x\nproperty double y\n"
      "property double z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0\n1 0 0\n0 1 0\n1 1 0\n3 0 1 2\n3 1 3 2\n";
  CHECK(parsePly(plyHead, "t.ply").faces.size() == 2);
  CHECK(parsePly(plyHead + "\n  \n", "t.ply").faces.size() == 2);  // blank lines are fine
  CHECK_THROWS_WITH(
      parsePly(plyHead + "3 0 3 2\n", "t.ply"),
      Catch::Contains("t.ply:16:") && Catch::Contains("more values after the last element"));
  const std::string off = "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n3 0 1 2\n3 1 3 2\n";
  CHECK(parseOff(off + "# a comment\n", "t.off").faces.size() == 2);
  CHECK_THROWS_WITH(parseOff(off + "3 0 3 2\n", "t.off"),
                    Catch::Contains("more data after the 2 faces"));
  const std::string node = "5 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n4 1 1 1\n";
  const std::string ele = "1 4 0\n0 0 1 2 3\n";
  CHECK(parseTetgen(node, "t.node", ele, "t.ele").tets.size() == 1);
  CHECK_THROWS_WITH(parseTetgen(node, "t.node", ele + "1 1 2 4 3\n", "t.ele"),
                    Catch::Contains("more data after the 1 tets"));
  CHECK_THROWS_WITH(parseTetgen(node + "5 2 2 2\n", "t.node", ele, "t.ele"),
                    Catch::Contains("more data after the 5 points"));
}
