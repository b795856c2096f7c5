// Hostile mesh files (modules/mesh/io.h, parse.h, polygon.h): counts beyond the file's size,
// numbers beyond double, endless and special files, truncation, awkward polygons; and the
// double precision of every reader and writer.

#include <diffreg/core/error.h>
#include <diffreg/core/file.h>
#include <diffreg/mesh/io.h>
#include <diffreg/mesh/parse.h>

#include "hostile_support.h"
#include "test_support.h"

#include <catch2/catch.hpp>

#include <Eigen/Geometry>

#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>

using namespace diffreg;
using namespace diffreg::testing;
namespace fs = std::filesystem;

namespace {

/// True when reading `path` throws a diffreg::Error within 512 MiB of address space.
bool failsWithinMemory(const std::string& path) {
  return inChildWithMemoryLimit(std::uint64_t(512) << 20, [&] {
    try {
      readMesh(path);
    } catch (const Error&) {
      return true;
    }
    return false;
  });
}

std::string binaryFile(const TempDir& tmp, const std::string& name, const std::string& header,
                       size_t zeros) {
  return tmp.file(name, header + std::string(zeros, '\0'));
}

}  // namespace

TEST_CASE("counts beyond the file's size fail at once, in bounded memory", "[mesh][hostile]") {
  TempDir tmp;
  SECTION("Medit Tetrahedra 999999999 in a small file") {
    const std::string p = tmp.file("big.mesh",
                                   "MeshVersionFormatted 2\nDimension 3\nVertices\n4\n0 0 0 0\n"
                                   "1 0 0 0\n0 1 0 0\n0 0 1 0\nTetrahedra\n999999999\n1 2 3 4 0\n");
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(p); }),
               Catch::Contains(p + ":10") && Catch::Contains("999999999"));
    CHECK(failsWithinMemory(p));
  }
  SECTION("binary PLY and OFF with a count of 2e9") {
    const std::string ply = binaryFile(tmp, "big.ply",
                                       "ply\nformat binary_little_endian 1.0\nelement vertex "
                                       "2000000000\nproperty float x\nproperty float y\nproperty "
                                       "float z\nelement face 1\nproperty list uchar int "
                                       "vertex_indices\nend_header\n",
                                       100);
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(ply); }),
               Catch::Contains(ply + ":3") && Catch::Contains("2000000000"));
    CHECK(failsWithinMemory(ply));
    std::string counts("OFF BINARY\n");
    for (std::uint32_t v : {0x77359400u, 1u, 0u})  // 2e9 vertices, big-endian
      for (int b = 3; b >= 0; --b) counts += static_cast<char>((v >> (8 * b)) & 0xff);
    const std::string off = binaryFile(tmp, "big.off", counts, 100);
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(off); }), Catch::Contains("2000000000"));
    CHECK(failsWithinMemory(off));
  }
  SECTION("ASCII OFF, TetGen and OM headers") {
    const std::string off = tmp.file("big2.off", "OFF\n999999999 1 0\n0 0 0\n");
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(off); }), Catch::Contains("999999999"));
    tmp.file("big.node", "999999999 3 0 0\n0 0 0 0\n");
    tmp.file("big.ele", "1 4 0\n0 0 0 0 0\n");
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(tmp / "big.node"); }),
               Catch::Contains("999999999"));
    std::string om("OM\x54\x02", 4);
    for (std::uint32_t v : {2000000000u, 1u, 3u})
      for (int b = 0; b < 4; ++b) om += static_cast<char>((v >> (8 * b)) & 0xff);
    const std::string p = binaryFile(tmp, "big.om", om, 100);
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(p); }), Catch::Contains("2000000000"));
    CHECK(failsWithinMemory(p));
  }
}

TEST_CASE("special and oversized files are refused without being read", "[mesh][hostile]") {
  TempDir tmp;
  SECTION("a device") {
    CHECK_THAT(messageOf<IoError>([] { readFileLimited("/dev/zero", "mesh file", 1 << 20); }),
               Catch::Contains("/dev/zero") && Catch::Contains("not a regular file"));
  }
  SECTION("a FIFO named like a mesh") {
    const std::string p = tmp / "pipe.obj";
    REQUIRE(::mkfifo(p.c_str(), 0600) == 0);
    CHECK_THAT(messageOf<IoError>([&] { readMesh(p); }),
               Catch::Contains(p) && Catch::Contains("not a regular file"));
  }
  SECTION("a (sparse) file over the limit") {
    const std::string p = tmp / "huge.obj";
    { std::ofstream touch(p); }
    REQUIRE(::truncate(p.c_str(), static_cast<off_t>(limits::meshBytes + 1)) == 0);
    CHECK_THAT(messageOf<IoError>([&] { readMesh(p); }),
               Catch::Contains(p) && Catch::Contains("limit"));
  }
}

TEST_CASE("coordinates are doubles; values beyond double are refused", "[mesh][hostile]") {
  TempDir tmp;
  SECTION("an OBJ line beyond the range of double names file and line") {
    const std::string p = tmp.file("over.obj", "v 0 0 0\nv 1e309 0 0\nv 0 1 0\nf 1 2 3\n");
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(p); }),
               Catch::Contains(p + ":2") && Catch::Contains("beyond the range of double"));
  }
  SECTION("beyond float is fine: no vertex disappears, faces keep their vertices") {
    const std::string p = tmp.file("float.obj",
                                   "v 0 0 0\nv 3.5e38 0 0\nv 0 3.5e38 0\nv 3.5e38 3.5e38 0\n"
                                   "f 1 2 3\nf 2 4 3\n");
    const Mesh mesh = readMesh(p);
    REQUIRE(mesh.numVertices() == 4);
    CHECK(mesh.positions()(1, 0) == 3.5e38);
    CHECK(mesh.elements().row(1) == Eigen::RowVector3i(1, 3, 2));
  }
  SECTION("coordinates whose area or volume overflows are named as such, not as degenerate") {
    const std::string tri = tmp.file("huge.obj", "v 0 0 0\nv 1e300 0 0\nv 0 1e300 0\nf 1 2 3\n");
    CHECK(messageOf<InvalidMesh>([&] { readMesh(tri); }) ==
          tri +
              ": face 0 (0-based)'s area overflows: a corner has a coordinate of 1e+300; scale "
              "the mesh");
    const std::string tet =
        tmp.file("huge.mesh",
                 "MeshVersionFormatted 1\nDimension 3\nVertices\n4\n0 0 0 0\n1e200 0 0 0\n"
                 "0 1e200 0 0\n0 0 1e200 0\nTetrahedra\n1\n1 2 3 4 0\nEnd\n");
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(tet); }),
               Catch::Contains("tet 0 (0-based)'s volume overflows"));
  }
  SECTION("a fine grid far from the origin is not degenerate") {
    std::string obj;
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i)
        obj +=
            "v " + std::to_string(1e6 + 0.01 * i) + " " + std::to_string(1e6 + 0.01 * j) + " 0\n";
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 2; ++i) {
        const int a = 1 + i + 3 * j;
        obj += "f " + std::to_string(a) + " " + std::to_string(a + 1) + " " +
               std::to_string(a + 4) + "\nf " + std::to_string(a) + " " + std::to_string(a + 4) +
               " " + std::to_string(a + 3) + "\n";
      }
    const Mesh mesh = readMesh(tmp.file("far.obj", obj));
    CHECK(mesh.numElements() == 8);
    CHECK(mesh.positions()(1, 0) - mesh.positions()(0, 0) == Approx(0.01).epsilon(1e-9));
  }
  SECTION("truncated ASCII PLY says where it ends") {
    const std::string p = tmp.file("cut.ply",
                                   "ply\nformat ascii 1.0\nelement vertex 4\nproperty double x\n"
                                   "property double y\nproperty double z\nelement face 2\n"
                                   "property list uchar int vertex_indices\nend_header\n"
                                   "0 0 0\n1 0 0\n0 1 0\n1 1 0\n3 0 1 2\n");
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(p); }),
               Catch::Contains(p) && Catch::Contains("ends after 1 of 2 'face'"));
  }
}

namespace {

/// Signed area of triangle (a, b, c) in the xy plane.
double area2(const Mesh& m, int a, int b, int c) {
  const Eigen::MatrixXd p = m.positions();
  return 0.5 *
         ((p(b, 0) - p(a, 0)) * (p(c, 1) - p(a, 1)) - (p(b, 1) - p(a, 1)) * (p(c, 0) - p(a, 0)));
}

}  // namespace

TEST_CASE("polygons are ear-clipped in their plane or refused", "[mesh][hostile]") {
  TempDir tmp;
  SECTION("a non-convex polygon: triangles inside it, none reversed, area kept") {
    // An arrow (concave at the 5th corner); a fan from corner 1 would leave the polygon.
    const std::string p =
        tmp.file("arrow.obj", "v 0 0 0\nv 4 0 0\nv 4 4 0\nv 2 1 0\nv 0 4 0\nf 1 2 3 4 5\n");
    const Mesh mesh = readMesh(p);
    REQUIRE(mesh.numElements() == 3);
    double total = 0.0;
    const Eigen::MatrixXi e = mesh.elements();
    for (int k = 0; k < 3; ++k) {
      const double a = area2(mesh, e(k, 0), e(k, 1), e(k, 2));
      CHECK(a > 0.0);
      total += a;
    }
    CHECK(total == Approx(4 * 4 - 0.5 * 4 * 3));  // the square minus the notch
  }
  SECTION("a polygon in a tilted plane keeps its orientation") {
    const std::string p =
        tmp.file("tilted.off", "OFF\n5 1 0\n0 0 0\n4 0 4\n4 4 4\n2 1 2\n0 4 0\n5 0 1 2 3 4\n");
    const Mesh mesh = readMesh(p);
    REQUIRE(mesh.numElements() == 3);
    const Eigen::MatrixXd x = mesh.positions();
    const Eigen::MatrixXi e = mesh.elements();
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d a = x.row(e(k, 0)), b = x.row(e(k, 1)), c = x.row(e(k, 2));
      CHECK((b - a).cross(c - a).dot(Eigen::Vector3d(-1, 0, 1)) > 0.0);
    }
  }
  SECTION("self-intersecting and non-planar polygons are refused") {
    const std::string bow = tmp.file("bow.obj", "v 0 0 0\nv 2 2 0\nv 2 0 0\nv 0 1 0\nf 1 2 3 4\n");
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(bow); }),
               Catch::Contains(bow + ":5") && Catch::Contains("self-intersecting"));
    const std::string bent =
        tmp.file("bent.obj", "v 0 0 0\nv 1 0 0\nv 1 1 1\nv 0 1 0\nf 1 2 3 4\n");
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(bent); }),
               Catch::Contains(bent + ":5") && Catch::Contains("non-planar"));
  }
}

namespace {

/// A random grid mesh: positions with arbitrary mantissas at a random scale and offset.
Mesh randomGrid(std::mt19937_64& rng, bool planar) {
  std::uniform_real_distribution<double> unit(-0.3, 0.3), exponent(-60.0, 60.0);
  const double scale = std::pow(10.0, exponent(rng)), offset = scale * (1 + 1e3 * unit(rng));
  const int n = 3 + static_cast<int>(rng() % 6);
  TriMesh tri;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
      tri.add_vertex(OpenMesh::Vec3d(offset + scale * (i + unit(rng)),
                                     -offset + scale * (j + unit(rng)),
                                     planar ? offset : scale * unit(rng)));
  const auto v = [&](int i, int j) { return OpenMesh::VertexHandle(i + n * j); };
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      tri.add_face(v(i, j), v(i + 1, j), v(i + 1, j + 1));
      tri.add_face(v(i, j), v(i + 1, j + 1), v(i, j + 1));
    }
  return Mesh(std::move(tri));
}

bool bitExact(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() &&
         std::memcmp(a.data(), b.data(), sizeof(double) * a.size()) == 0;
}

}  // namespace

TEST_CASE("random valid meshes written and read back are bit-exact", "[mesh][hostile]") {
  TempDir tmp;
  std::mt19937_64 rng(12);
  for (int round = 0; round < 20; ++round) {
    const Mesh mesh = randomGrid(rng, round % 2 == 0);
    for (const char* ext : {"obj", "off", "ply", "om"}) {
      INFO("round " << round << ", " << ext);
      const std::string p = tmp / (std::string("r.") + ext);
      writeMesh(p, mesh);
      const Mesh back = readMesh(p);
      CHECK(bitExact(back.positions(), mesh.positions()));
      CHECK(back.elements() == mesh.elements());
    }
    // A tet on three grid corners and a point above the first.
    const int n = static_cast<int>(std::lround(std::sqrt(mesh.numVertices())));
    const Eigen::MatrixXd x = mesh.positions();
    TetMesh tet;
    for (int i : {0, 1, n}) tet.points.push_back(x.row(i).transpose());
    Eigen::Vector3d top = x.row(0).transpose();
    top[2] += (x.row(1) - x.row(0)).norm();
    tet.points.push_back(top);
    tet.tets.push_back({0, 1, 2, 3});
    if ((tet.points[1] - tet.points[0])
            .dot((tet.points[2] - tet.points[0]).cross(tet.points[3] - tet.points[0])) < 0)
      std::swap(tet.tets[0][2], tet.tets[0][3]);
    const Mesh solid{TetMesh(tet)};
    writeMesh(tmp / "r.mesh", solid);
    CHECK(bitExact(readMesh(tmp / "r.mesh").positions(), solid.positions()));
  }
}

TEST_CASE("fuzzing findings stay fixed", "[mesh][hostile]") {
  TempDir tmp;
  SECTION("an ASCII PLY list length of 1e24 (was undefined behaviour)") {
    const std::string p = tmp.file("list.ply",
                                   "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\n"
                                   "property double y\nproperty double z\nelement face 1\n"
                                   "property list uchar int vertex_indices\nend_header\n"
                                   "0 0 0\n1 0 0\n0 1 0\n0999999999999999999999993 0 1 2\n");
    CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(p); }),
               Catch::Contains(p + ":13") && Catch::Contains("bad list length"));
  }
}

TEST_CASE("a file of repeated faces is refused before it grows", "[mesh][hostile]") {
  TempDir tmp;
  std::string obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  for (int i = 0; i < 5000; ++i) obj += "f 1 2 3\n";
  const std::string p = tmp.file("dup.obj", obj);
  CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(p); }),
             Catch::Contains(p + ":1005") && Catch::Contains("non-manifold"));
}

namespace {

/// Peak resident memory added by reading `path`, in bytes, measured in a child process (the
/// peak is reset first, through /proc/self/clear_refs); -1 when it cannot be measured.
long long readingPeak(const std::string& path) {
  int pipe[2];
  if (::pipe(pipe) != 0) return -1;
  const pid_t pid = ::fork();
  if (pid == 0) {
    const auto kb = [](const char* key) {
      std::ifstream in("/proc/self/status");
      std::string line;
      while (std::getline(in, line))
        if (line.rfind(key, 0) == 0) return std::atoll(line.c_str() + std::strlen(key));
      return -1LL;
    };
    std::ofstream("/proc/self/clear_refs") << "5";
    const long long before = kb("VmRSS:");
    try {
      readMesh(path);
    } catch (const Error&) {
    }
    const long long grown = (kb("VmHWM:") - before) * 1024;
    (void)!::write(pipe[1], &grown, sizeof grown);
    std::_Exit(0);
  }
  long long grown = -1;
  (void)!::read(pipe[0], &grown, sizeof grown);
  ::waitpid(pid, nullptr, 0);
  ::close(pipe[0]);
  ::close(pipe[1]);
  return grown;
}

}  // namespace

TEST_CASE("reading a mesh takes at most 24 times its file size", "[mesh][hostile]") {
  // The README's bound, on the files that cost the most per byte: the shortest vertex records
  // (each costs a point as read and a vertex of the mesh) and a grid of short face records.
  TempDir tmp;
  std::string vertices, off = "OFF\n300000 1 0\n", grid;
  for (int i = 0; i < 300000; ++i) vertices += "v 0 0 0\n";
  for (int i = 0; i < 300000; ++i) off += "0 0 0\n";
  off += "3 0 1 2\n";
  std::string medit = "MeshVersionFormatted 1\nDimension 3\nVertices\n300000\n";
  for (int i = 0; i < 300000; ++i) medit += "0 0 0 0\n";
  medit += "Tetrahedra\n1\n1 2 3 4 0\nEnd\n";
  const int n = 250;
  for (int i = 0; i < n * n; ++i)
    grid += "v " + std::to_string(i % n) + " " + std::to_string(i / n) + " 0\n";
  for (int i = 0; i + 1 < n; ++i)
    for (int j = 0; j + 1 < n; ++j) {
      const int a = 1 + i * n + j;
      grid += "f " + std::to_string(a) + " " + std::to_string(a + 1) + " " + std::to_string(a + n) +
              "\nf " + std::to_string(a + 1) + " " + std::to_string(a + n + 1) + " " +
              std::to_string(a + n) + "\n";
    }
  for (const auto& [name, text] : {std::pair<std::string, std::string>{"points.obj", vertices},
                                   {"points.off", off},
                                   {"points.mesh", medit},
                                   {"grid.obj", grid}}) {
    const std::string p = tmp.file(name, text);
    const long long peak = readingPeak(p);
    INFO(name << ": " << text.size() << " bytes, peak grew by " << peak << " bytes");
    REQUIRE(peak >= 0);
    CHECK(peak <= 24 * static_cast<long long>(text.size()));
  }
}

TEST_CASE("a file of many large polygons is refused within seconds", "[mesh][hostile]") {
  // 4,097 faces of 256 corners (each its own): one more than the polygon work allows. They took
  // half a millisecond each; a 128 MiB file of them took 16-19 s.
  TempDir tmp;
  const int faces = 4097, corners = 256;
  std::string obj;
  obj.reserve(static_cast<size_t>(faces) * corners * 24);
  for (int f = 0; f < faces; ++f)
    for (int i = 0; i < corners; ++i) {
      const double a = 2 * M_PI * i / corners;
      obj +=
          "v " + std::to_string(3 * f + std::cos(a)) + " " + std::to_string(std::sin(a)) + " 0\n";
    }
  for (int f = 0; f < faces; ++f) {
    obj += "f";
    for (int i = 0; i < corners; ++i) obj += " " + std::to_string(f * corners + i + 1);
    obj += "\n";
  }
  // One face of 70,000 corners gets the error of its own corner count, not the work limit's.
  std::string one;
  for (int i = 0; i < 70000; ++i)
    one += "v " + std::to_string(i) + " " + std::to_string(i % 7) + " 0\n";
  one += "f";
  for (int i = 1; i <= 70000; ++i) one += " " + std::to_string(i);
  const std::string single = tmp.file("one.obj", one + "\n");
  CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(single); }),
             Catch::Contains("a polygon with 70000 corners (at most 256)"));
  const std::string p = tmp.file("polygons.obj", obj);
  const std::string line = std::to_string(faces * corners + faces);  // the last face's
  CHECK_THAT(messageOf<InvalidMesh>([&] { readMesh(p); }),
             Catch::Contains(p + ":" + line + ": face " + std::to_string(faces) +
                             ": too many large polygons") &&
                 Catch::Contains("triangulate the file first"));
}
