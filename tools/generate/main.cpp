// diffreg-generate: writes the meshes the project ships (meshes/) from the shape generators,
// byte for byte. Every coordinate is rounded to float and then to 9 significant digits, as the
// shipped files hold them: planar and tet sizes are chosen so that their coordinates are exact
// in float, the disc's and cylinder's cosines and sines are rounded.
#include <diffreg/core/error.h>
#include <diffreg/mesh/io.h>
#include <diffreg/mesh/shapes.h>

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <functional>
#include <iostream>
#include <string>
#include <vector>

namespace {

struct Shipped {
  const char* file;
  const char* description;
  std::function<diffreg::Mesh()> make;
};

const std::vector<Shipped>& shippedMeshes() {
  using namespace diffreg;
  static const std::vector<Shipped> meshes{
      {"bar.obj", "planar rectangle 8 x 1, 32 x 4 cells",
       [] { return makeRectangle(8.0, 1.0, 32, 4); }},
      {"lshape.obj", "planar L, size 2, arm 1, 8 cells per unit",
       [] { return makeLShape(2.0, 1.0, 8); }},
      {"ushape.obj", "planar U, arm 1, gap 1, height 4, 4 cells per unit",
       [] { return makeUShape(1.0, 1.0, 4.0, 4); }},
      {"disc.obj", "planar disc, radius 1, 8 rings", [] { return makeDisc(1.0, 8); }},
      {"cylinder.obj", "open cylinder surface, radius 1, height 4, 24 x 16 quads",
       [] { return makeCylinder(1.0, 4.0, 24, 16); }},
      {"tetbar.mesh", "tet box 4 x 1 x 1, 16 x 4 x 4 cubes",
       [] { return makeTetBox(4.0, 1.0, 1.0, 16, 4, 4); }},
  };
  return meshes;
}

/// x rounded to float, then to 9 significant digits (what the files hold).
double shippedCoordinate(double x) {
  char text[32];
  std::snprintf(text, sizeof text, "%.9g", static_cast<double>(static_cast<float>(x)));
  return std::strtod(text, nullptr);
}

void printUsage(std::ostream& out) {
  out << "Usage: diffreg-generate [--help] OUTDIR\n\n"
         "Writes the meshes that diffreg ships into OUTDIR (created when missing):\n";
  for (const Shipped& s : shippedMeshes())
    out << "  " << s.file << std::string(14 - std::string(s.file).size(), ' ') << s.description
        << "\n";
  out << "The scenario handle files (*.json) beside them are written by hand.\n";
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> positional;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      printUsage(std::cout);
      return 0;
    }
    if (arg.size() > 1 && arg[0] == '-') {
      std::cerr << "diffreg-generate: unknown option '" << arg << "' (see --help)\n";
      return 2;
    }
    positional.push_back(arg);
  }
  if (positional.size() != 1) {
    std::cerr << "diffreg-generate: expected exactly one output directory (see --help)\n";
    return 2;
  }
  const std::filesystem::path dir = positional[0];
  try {
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec || !std::filesystem::is_directory(dir))
      throw diffreg::IoError("cannot create output directory '" + dir.string() + "'");
    for (const Shipped& s : shippedMeshes()) {
      diffreg::Mesh mesh = s.make();
      mesh.setPositions(mesh.positions().unaryExpr(&shippedCoordinate));
      const std::string path = (dir / s.file).string();
      diffreg::writeMesh(path, mesh);
      std::cout << path << ": " << mesh.numVertices() << " vertices, " << mesh.numElements()
                << (mesh.isTet() ? " tets\n" : " triangles\n");
    }
  } catch (const std::exception& e) {
    std::cerr << "diffreg-generate: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
