// The .om reader (modules/mesh/om.h): what OpenMesh writes reads back exactly (positions, faces,
// double properties), old and float files read, and corrupt files (every truncation, every
// byte changed, the inputs that stopped OpenMesh's own reader on an assertion) end in an
// InvalidMesh naming the file, never in a crash.

#include <diffreg/core/error.h>
#include <diffreg/core/log.h>
#include <diffreg/mesh/io.h>
#include <diffreg/mesh/om.h>
#include <diffreg/mesh/parse.h>
#include <diffreg/mesh/shapes.h>

#include "test_support.h"

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <catch2/catch.hpp>

#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>

using namespace diffreg;
using namespace diffreg::testing;

namespace {

std::string bytesOf(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

/// A small surface with a vertex and a face property, written by diffreg (OpenMesh's writer).
std::string writtenOm(const TempDir& tmp, Mesh& mesh) {
  mesh = makeRectangle(2.0, 1.0, 4, 3);
  Eigen::MatrixXd p = mesh.positions();
  for (int v = 0; v < p.rows(); ++v) p(v, 2) = 0.1 * std::sin(1.0 + v) / 3.0;
  mesh.setPositions(p);
  Eigen::VectorXd w(mesh.numVertices()), d(mesh.numElements());
  for (int v = 0; v < w.size(); ++v) w[v] = 1.0 / (v + 3.0);
  for (int f = 0; f < d.size(); ++f) d[f] = std::exp(-f) * M_PI;
  mesh.setVertexScalar(prop::weight, w);
  mesh.setElementScalar(prop::distortion, d);
  const std::string path = tmp / "written.om";
  writeMesh(path, mesh);
  return bytesOf(path);
}

void appendU32(std::string& s, std::uint32_t v) {
  for (int b = 0; b < 4; ++b) s += static_cast<char>((v >> (8 * b)) & 0xff);
}
void appendU16(std::string& s, std::uint16_t v) {
  s += static_cast<char>(v & 0xff);
  s += static_cast<char>(v >> 8);
}
void appendF32(std::string& s, float f) {
  std::uint32_t v;
  std::memcpy(&v, &f, 4);
  appendU32(s, v);
}

/// A chunk descriptor: entity, type, float flag, dimension, size code (format of om.cpp).
std::uint16_t chunk(unsigned entity, unsigned type, bool isFloat, unsigned dim, unsigned size) {
  return static_cast<std::uint16_t>(entity << 2 | type << 5 | (isFloat ? 1u : 0u) << 10 |
                                    (dim - 1) << 11 | size << 14);
}

}  // namespace

TEST_CASE("OM files OpenMesh writes read back exactly", "[mesh][om]") {
  TempDir tmp;
  Mesh mesh;
  const std::string bytes = writtenOm(tmp, mesh);
  const Mesh back = parseOm(bytes, "w.om");
  CHECK(back.positions() == mesh.positions());
  CHECK(back.elements() == mesh.elements());
  CHECK(back.vertexScalar(prop::weight) == mesh.vertexScalar(prop::weight));
  CHECK(back.elementScalar(prop::distortion) == mesh.elementScalar(prop::distortion));

  SECTION("the same faces, in the same order and rotation, as OpenMesh's reader") {
    TriMesh ref;
    std::istringstream in(bytes);
    OpenMesh::IO::Options opt = OpenMesh::IO::Options::Binary;
    REQUIRE(OpenMesh::IO::read_mesh(ref, in, ".om", opt));
    CHECK(Mesh(ref).elements() == back.elements());
  }
  SECTION("float positions, normals and status chunks") {
    OpenMesh::TriMesh_ArrayKernelT<> single;  // float points
    std::vector<OpenMesh::TriMesh_ArrayKernelT<>::VertexHandle> v;
    for (int i = 0; i < 4; ++i)
      v.push_back(single.add_vertex({float(i % 2) + 0.1f, float(i / 2) / 3.0f, 0.5f}));
    single.add_face(v[0], v[1], v[3]);
    single.add_face(v[0], v[3], v[2]);
    single.request_vertex_normals();
    single.request_face_normals();
    single.request_vertex_status();
    single.update_normals();
    std::ostringstream out;
    OpenMeshQuiet quiet;
    OpenMesh::IO::Options opt = OpenMesh::IO::Options::Binary |
                                OpenMesh::IO::Options::VertexNormal |
                                OpenMesh::IO::Options::FaceNormal | OpenMesh::IO::Options::Status;
    REQUIRE(OpenMesh::IO::write_mesh(single, out, ".om", opt));
    const Mesh m = parseOm(out.str(), "f.om");
    REQUIRE(m.numVertices() == 4);
    REQUIRE(m.numElements() == 2);
    for (int i = 0; i < 4; ++i)
      for (int k = 0; k < 3; ++k) CHECK(m.positions()(i, k) == double(single.point(v[i])[k]));
    CHECK(m.elements().row(0).sum() == 4);
  }
}

TEST_CASE("OM files before version 2 list each face's vertices", "[mesh][om]") {
  std::string s("OMT", 3);
  s += static_cast<char>(1 << 5 | 2);  // version 1.2
  appendU32(s, 4);
  appendU32(s, 2);
  appendU32(s, 0);
  appendU16(s, chunk(0, 0, true, 3, 0));  // float positions
  for (int i = 0; i < 4; ++i) {
    appendF32(s, float(i % 2));
    appendF32(s, float(i / 2));
    appendF32(s, 0.0f);
  }
  appendU16(s, chunk(2, 7, false, 1, 2));  // faces, 32-bit vertex ids
  for (std::uint32_t id : {0u, 1u, 3u, 0u, 3u, 2u}) appendU32(s, id);
  appendU16(s, chunk(7, 0, false, 1, 0));  // end
  const Mesh m = parseOm(s, "old.om");
  REQUIRE(m.numElements() == 2);
  CHECK(m.kind() == MeshKind::Planar);
  CHECK(m.positions()(3, 0) == 1.0);
  SECTION("a vertex id out of range is named") {
    s[s.size() - 6] = 9;  // the last face's last id
    CHECK_THAT(
        messageOf<InvalidMesh>([&] { parseOm(s, "old.om"); }),
        Catch::Contains("old.om") && Catch::Contains("face 1") && Catch::Contains("out of range"));
  }
}

TEST_CASE("corrupt OM files end in an error naming the file", "[mesh][om][hostile]") {
  TempDir tmp;
  Mesh mesh;
  const std::string bytes = writtenOm(tmp, mesh);
  setQuiet(true);  // thousands of files: their warnings (split faces, ...) are not the point
  struct Loud {
    ~Loud() { setQuiet(false); }
  } loud;
  const auto readsOrRefuses = [](const std::string& data) {
    try {
      const Mesh m = parseOm(data, "bad.om");
      validateMesh(m, "bad.om");
      return m.numVertices() > 0;
    } catch (const InvalidMesh& e) {
      return std::string(e.what()).rfind("bad.om", 0) == 0;
    }
  };
  SECTION("every truncation") {
    int refused = 0;
    for (size_t n = 0; n < bytes.size(); ++n) {
      INFO("first " << n << " bytes");
      REQUIRE(readsOrRefuses(bytes.substr(0, n)));
      try {
        parseOm(bytes.substr(0, n), "bad.om");
      } catch (const InvalidMesh&) {
        ++refused;
      }
    }
    CHECK(refused > 0);
  }
  SECTION("every byte changed") {
    for (size_t i = 0; i < bytes.size(); ++i) {
      for (int x : {0x01, 0x80, 0xff}) {
        std::string b = bytes;
        b[i] = static_cast<char>(b[i] ^ x);
        INFO("byte " << i << " xor " << x);
        REQUIRE(readsOrRefuses(b));
      }
    }
  }
  SECTION("inputs that stopped OpenMesh's reader") {
    // A chunk of positions with 16-bit "doubles", then half-edges whose next pointers run in a
    // cycle that never returns to the face's half-edge.
    std::string s("OMTB", 4);
    appendU32(s, 4);
    appendU32(s, 2);
    appendU32(s, 5);
    appendU16(s, chunk(0, 0, true, 3, 1));
    s += std::string(4 * 24, '\0');
    appendU16(s, chunk(6, 7, false, 1, 0));  // 8-bit half-edge records
    for (int h = 0; h < 10; ++h) {
      s += static_cast<char>((h + 2) % 10);   // next
      s += static_cast<char>(h % 4);          // vertex
      s += static_cast<char>(h < 6 ? 0 : 1);  // face
    }
    appendU16(s, chunk(2, 7, false, 1, 0));
    s += '\0';
    s += '\1';
    CHECK_THAT(messageOf<InvalidMesh>([&] { parseOm(s, "loop.om"); }),
               Catch::Contains("loop.om") && Catch::Contains("does not close"));
  }
  SECTION("a header newer than the reader, an unknown entity") {
    std::string newer = bytes;
    newer[3] = static_cast<char>(3 << 5);
    CHECK_THAT(messageOf<InvalidMesh>([&] { parseOm(newer, "n.om"); }),
               Catch::Contains("version 3.0"));
    std::string entity = bytes;
    entity[16] = static_cast<char>(entity[16] | (3 << 2));
    CHECK_THAT(messageOf<InvalidMesh>([&] { parseOm(entity, "e.om"); }),
               Catch::Contains("e.om") && Catch::Contains("unknown entity"));
  }
}
