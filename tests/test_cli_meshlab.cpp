// Round trip through real MeshLab: diffreg's PLY (weights as vertex quality and colours,
// distortion as face quality, smoothness as a property of its own name) read and written again by
// Debian's meshlabserver keeps its qualities and colours. Skipped, saying why, when meshlabserver
// or xvfb-run is not installed.
#include "cli_fixture.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace diffreg::testing;

namespace {

/// One element of a PLY file: its properties in file order and their values, scalars by
/// property name, lists (vertex_indices) as integer vectors.
struct PlyElement {
  std::string name;
  long count = 0;
  struct Property {
    std::string name, type, countType;  // countType set for lists
  };
  std::vector<Property> properties;
  std::map<std::string, std::vector<double>> scalars;
  std::map<std::string, std::vector<std::vector<long>>> lists;

  bool has(const std::string& property) const {
    return std::any_of(properties.begin(), properties.end(),
                       [&](const Property& p) { return p.name == property; });
  }
};

struct Ply {
  std::string format;
  std::vector<PlyElement> elements;
  const PlyElement& element(const std::string& name) const {
    for (const auto& e : elements)
      if (e.name == name) return e;
    throw std::runtime_error("PLY has no element " + name);
  }
};

int typeSize(const std::string& type) {
  if (type == "char" || type == "uchar" || type == "int8" || type == "uint8") return 1;
  if (type == "short" || type == "ushort" || type == "int16" || type == "uint16") return 2;
  if (type == "int" || type == "uint" || type == "int32" || type == "uint32" || type == "float" ||
      type == "float32")
    return 4;
  if (type == "double" || type == "float64") return 8;
  throw std::runtime_error("PLY: unknown type " + type);
}

/// Reads one little-endian binary value of `type` at `p` (advanced past it).
double readBinary(const std::string& type, const char*& p, const char* end) {
  const int size = typeSize(type);
  if (end - p < size) throw std::runtime_error("PLY: body ends early");
  double value = 0.0;
  auto take = [&](auto sample) {
    std::memcpy(&sample, p, sizeof(sample));
    value = static_cast<double>(sample);
  };
  if (type == "char" || type == "int8")
    take(std::int8_t{});
  else if (type == "uchar" || type == "uint8")
    take(std::uint8_t{});
  else if (type == "short" || type == "int16")
    take(std::int16_t{});
  else if (type == "ushort" || type == "uint16")
    take(std::uint16_t{});
  else if (type == "int" || type == "int32")
    take(std::int32_t{});
  else if (type == "uint" || type == "uint32")
    take(std::uint32_t{});
  else if (type == "float" || type == "float32")
    take(float{});
  else
    take(double{});
  p += size;
  return value;
}

/// Parses an ASCII or binary little-endian PLY (the test machine is little endian).
Ply readPly(const fs::path& path) {
  const std::string data = slurp(path);
  const std::size_t headerEnd = data.find("end_header\n");
  if (data.compare(0, 4, "ply\n") != 0 || headerEnd == std::string::npos)
    throw std::runtime_error("not a PLY file: " + path.string());
  Ply ply;
  std::istringstream header(data.substr(0, headerEnd));
  std::string line;
  while (std::getline(header, line)) {
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    if (keyword == "format") {
      words >> ply.format;
    } else if (keyword == "element") {
      PlyElement e;
      words >> e.name >> e.count;
      ply.elements.push_back(e);
    } else if (keyword == "property") {
      PlyElement::Property p;
      words >> p.type;
      if (p.type == "list") words >> p.countType >> p.type;
      words >> p.name;
      if (ply.elements.empty()) throw std::runtime_error("PLY: property before element");
      ply.elements.back().properties.push_back(p);
    }
  }
  if (ply.format != "ascii" && ply.format != "binary_little_endian")
    throw std::runtime_error("PLY: unsupported format " + ply.format);

  const std::size_t bodyStart = headerEnd + std::strlen("end_header\n");
  const char* p = data.data() + bodyStart;
  const char* end = data.data() + data.size();
  std::istringstream ascii(data.substr(bodyStart));
  const bool binary = ply.format == "binary_little_endian";
  auto next = [&](const std::string& type) {
    if (binary) return readBinary(type, p, end);
    double v;
    if (!(ascii >> v)) throw std::runtime_error("PLY: ASCII body ends early");
    return v;
  };
  for (PlyElement& e : ply.elements)
    for (long i = 0; i < e.count; ++i)
      for (const auto& prop : e.properties) {
        if (prop.countType.empty()) {
          e.scalars[prop.name].push_back(next(prop.type));
        } else {
          const long n = static_cast<long>(next(prop.countType));
          std::vector<long> items;
          for (long k = 0; k < n; ++k) items.push_back(static_cast<long>(next(prop.type)));
          e.lists[prop.name].push_back(items);
        }
      }
  return ply;
}

bool onPath(const std::string& program) {
  return std::system(("command -v " + program + " > /dev/null 2>&1").c_str()) == 0;
}

/// Equal as the single-precision floats both files store.
bool sameFloat(double a, double b) { return std::abs(a - b) <= 1e-6 * std::max(1.0, std::abs(a)); }

}  // namespace

TEST_CASE("MeshLab reads and writes back diffreg's PLY with weights, distortion and colours",
          "[cli][meshlab]") {
  if (!fs::exists(DIFFREG_TOOL)) return;
  for (const char* program : {"meshlabserver", "xvfb-run"})
    if (!onPath(program)) {
      WARN("skipped: " << program << " is not installed (Debian: apt-get install meshlab xvfb)");
      return;
    }

  Scratch s("cli-meshlab");
  const ToolRun r = s.run("-i '" + shipped("bar.obj") + "' --handles '" + shipped("bar-bend.json") +
                          "' --filter 'diffuse_weights t=0.01' --filter 'deform "
                          "regularization=nonuniform iterations=10' -o out.ply -q");
  INFO(r.err);
  REQUIRE(r.code == 0);
  REQUIRE(s.has("out.ply"));

  // meshlabserver needs an X display even without a window; xvfb-run provides one. A run takes
  // a few seconds; `timeout` ends a hung one (and the test fails rather than hanging).
  const std::string command = "cd '" + s.dir.string() +
                              "' && timeout -k 5 120 xvfb-run -a meshlabserver -i out.ply -o "
                              "back.ply -m vq fq vc > meshlab.log 2>&1";
  const int status = std::system(command.c_str());
  INFO(slurp(s.dir / "meshlab.log"));
  REQUIRE(WIFEXITED(status));
  REQUIRE(WEXITSTATUS(status) == 0);
  REQUIRE(s.has("back.ply"));

  const Ply ours = readPly(s.dir / "out.ply");
  const Ply back = readPly(s.dir / "back.ply");
  INFO("meshlab wrote format " << back.format);
  const PlyElement& ov = ours.element("vertex");
  const PlyElement& of = ours.element("face");
  const PlyElement& bv = back.element("vertex");
  const PlyElement& bf = back.element("face");
  for (const char* prop : {"x", "y", "z", "quality", "red", "green", "blue"}) {
    INFO("vertex property " << prop);
    CHECK(ov.has(prop));
    CHECK(bv.has(prop));
  }
  CHECK(of.has("quality"));
  CHECK(of.has("diffreg:smoothness"));  // a named property of its own, which MeshLab reads past
  REQUIRE(bf.has("quality"));
  REQUIRE(bv.has("quality"));
  REQUIRE(bv.count == ov.count);
  REQUIRE(bf.count == of.count);
  REQUIRE(bf.lists.at("vertex_indices") == of.lists.at("vertex_indices"));

  // Our own file carries real data: the weights span (0, 0.5] with the handles' magnitude 0.5
  // at the top, the distortion is non-negative and not all zero.
  const auto& weights = ov.scalars.at("quality");
  const auto& distortion = of.scalars.at("quality");
  CHECK(*std::max_element(weights.begin(), weights.end()) == Approx(0.5));
  CHECK(*std::min_element(weights.begin(), weights.end()) < 0.1);
  CHECK(*std::min_element(distortion.begin(), distortion.end()) >= 0.0);
  CHECK(*std::max_element(distortion.begin(), distortion.end()) > 0.0);

  // MeshLab keeps positions, weights, colours and distortion, vertex by vertex and face by face.
  int badVertices = 0, badFaces = 0;
  for (long i = 0; i < ov.count; ++i) {
    bool same = sameFloat(bv.scalars.at("quality")[i], weights[i]);
    for (const char* c : {"x", "y", "z"})
      same = same && sameFloat(bv.scalars.at(c)[i], ov.scalars.at(c)[i]);
    for (const char* c : {"red", "green", "blue"})
      same = same && bv.scalars.at(c)[i] == ov.scalars.at(c)[i];
    if (!same) ++badVertices;
  }
  for (long k = 0; k < of.count; ++k)
    if (!sameFloat(bf.scalars.at("quality")[k], distortion[k])) ++badFaces;
  CHECK(badVertices == 0);
  CHECK(badFaces == 0);
}
