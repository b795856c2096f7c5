// libFuzzer entry point for diffreg's readers. Built once per input kind (fuzz_obj, fuzz_off,
// fuzz_ply, fuzz_om, fuzz_medit, fuzz_tetgen, fuzz_handles, fuzz_pp, fuzz_mlx): the bytes are
// parsed as that kind, then (for meshes) built and validated as readMesh does. A diffreg::Error is
// the expected answer to bad input; any other exception, a crash, a sanitizer report, a hang or an
// allocation over libFuzzer's -malloc_limit_mb is a finding.
#include <diffreg/core/error.h>
#include <diffreg/core/log.h>
#include <diffreg/core/xml.h>
#include <diffreg/handles/handles.h>
#include <diffreg/mesh/io.h>
#include <diffreg/mesh/om.h>
#include <diffreg/mesh/parse.h>
#include <diffreg/mesh/shapes.h>
#include <diffreg/pipeline/mlx.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

namespace {

using namespace diffreg;

/// A stand-in for the built-in filters (which need the whole library): one parameter of every
/// type, under the name of the seed script's filter.
class ParamsOnly : public Filter {
 public:
  std::string name() const override { return "diffuse_weights"; }
  std::string description() const override { return "fuzzing stand-in"; }
  std::vector<ParamSpec> params() const override {
    return {floatParam("t", "0.01", 0.0, 1e6, ""),
            intParam("steps", "100", 1, 100000, ""),
            boolParam("clip", false, ""),
            enumParam("order", "second", {"second", "first", "implicit_euler"}, ""),
            stringParam("file", "", ""),
            floatParam("beta", "0.5", -1e300, 1e300, "")};
  }
  FilterResult apply(Document&, const ParamMap&) const override { return {}; }
};

Registry mlxRegistry() {
  Registry r;
  r.add(std::make_unique<ParamsOnly>());
  return r;
}

void checkTriangles(RawMesh raw) {
  const Mesh mesh = buildMesh(std::move(raw), "fuzz");  // with any named values
  validateMesh(mesh, "fuzz");
}

void checkTets(TetMesh tet) {
  Mesh mesh(std::move(tet));
  validateMesh(mesh, "fuzz");
}

void parse(std::string_view bytes) {
#if defined(DIFFREG_FUZZ_TARGET_obj)
  checkTriangles(parseObj(bytes, "fuzz"));
#elif defined(DIFFREG_FUZZ_TARGET_off)
  checkTriangles(parseOff(bytes, "fuzz"));
#elif defined(DIFFREG_FUZZ_TARGET_ply)
  checkTriangles(parsePly(bytes, "fuzz"));
#elif defined(DIFFREG_FUZZ_TARGET_om)
  Mesh mesh = parseOm(bytes, "fuzz");
  validateMesh(mesh, "fuzz");
#elif defined(DIFFREG_FUZZ_TARGET_medit)
  checkTets(parseMedit(bytes, "fuzz"));
#elif defined(DIFFREG_FUZZ_TARGET_tetgen)
  // The .node and .ele files, separated by a line "--ele--".
  const size_t cut = bytes.find("--ele--");
  const std::string_view node = bytes.substr(0, cut);
  const std::string_view ele = cut == std::string_view::npos ? "" : bytes.substr(cut + 7);
  checkTets(parseTetgen(node, "fuzz.node", ele, "fuzz.ele"));
#elif defined(DIFFREG_FUZZ_TARGET_handles)
  static const Mesh mesh = makeRectangle(2.0, 1.0, 4, 2);
  parseHandles(std::string(bytes), mesh, "fuzz.json", "/nonexistent-fuzz-dir");
#elif defined(DIFFREG_FUZZ_TARGET_pp)
  parsePickedPoints(std::string(bytes), "fuzz.pp");
#elif defined(DIFFREG_FUZZ_TARGET_mlx)
  static const Registry registry = mlxRegistry();
  parseFilterScript(std::string(bytes), "fuzz.mlx", registry);
#else
#error "define DIFFREG_FUZZ_TARGET_<kind>"
#endif
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, size_t size) {
  static const bool quiet = (diffreg::setQuiet(true), true);
  (void)quiet;
  try {
    parse(std::string_view(reinterpret_cast<const char*>(data), size));
  } catch (const diffreg::Error&) {
    // the one-line error a user sees: expected
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fuzz: unexpected exception: %s\n", e.what());
    std::abort();
  }
  return 0;
}
