// Handle selection through the kd-tree (modules/handles/vertex_search): the same vertices as
// scanning every vertex, ties (the lowest id), coincident and unreferenced vertices, points far
// outside the mesh and overflowing distances included.

#include <diffreg/core/error.h>
#include <diffreg/handles/handles.h>
#include <diffreg/handles/vertex_search.h>
#include <diffreg/mesh/shapes.h>

#include <catch2/catch.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <random>
#include <set>
#include <sstream>

#include <unistd.h>

using namespace diffreg;
using Catch::Contains;

namespace {

/// The selections as handles.cpp made them before the kd-tree: every vertex, in id order,
/// the first of equal squared distances.
int scanNearest(const Eigen::MatrixXd& x, const std::vector<bool>& used, const Eigen::Vector3d& p) {
  int best = -1;
  double bestDist = 0.0;
  for (int v = 0; v < x.rows(); ++v) {
    if (!used[v]) continue;
    const double d = (x.row(v).transpose() - p).squaredNorm();
    if (best < 0 || d < bestDist) {
      best = v;
      bestDist = d;
    }
  }
  return best;
}

std::vector<int> scanWithin(const Eigen::MatrixXd& x, const std::vector<bool>& used,
                            const Eigen::Vector3d& c, double r) {
  std::vector<int> ids;
  for (int v = 0; v < x.rows(); ++v)
    if (used[v] && (x.row(v).transpose() - c).norm() <= r) ids.push_back(v);
  return ids;
}

/// A lattice of k^3 (or k^2 at z = 0) points 0.25 apart, so that many distances tie exactly,
/// numbered in a random order, with coincident copies and unreferenced vertices.
struct PointSet {
  Eigen::MatrixXd x;
  std::vector<bool> used;
};

PointSet lattice(int k, bool planar, std::mt19937& rng) {
  std::vector<Eigen::Vector3d> p;
  for (int i = 0; i < k; ++i)
    for (int j = 0; j < k; ++j)
      for (int l = 0; l < (planar ? 1 : k); ++l) p.emplace_back(0.25 * i, 0.25 * j, 0.25 * l);
  const size_t base = p.size();
  for (size_t c = 0; c < base / 8; ++c) p.push_back(p[rng() % base]);  // coincident copies
  std::shuffle(p.begin(), p.end(), rng);
  PointSet s;
  s.x.resize(static_cast<Eigen::Index>(p.size()), 3);
  for (size_t v = 0; v < p.size(); ++v) s.x.row(static_cast<Eigen::Index>(v)) = p[v].transpose();
  s.used.assign(p.size(), true);
  for (size_t c = 0; c < p.size() / 10; ++c) s.used[rng() % p.size()] = false;
  return s;
}

PointSet randomCloud(int n, std::mt19937& rng) {
  std::normal_distribution<double> g(0.0, 1.0);
  PointSet s;
  s.x.resize(n, 3);
  for (int v = 0; v < n; ++v) {
    // Two clusters of very different scales.
    const double scale = v % 3 == 0 ? 1e-6 : 10.0;
    s.x.row(v) << scale * g(rng), scale * g(rng), scale * g(rng);
  }
  s.used.assign(n, true);
  s.used[0] = false;
  return s;
}

/// Query points: on vertices, on the midpoints of lattice edges, faces and cells (ties), at
/// random, far outside the mesh, and so far that squared distances overflow to inf.
std::vector<Eigen::Vector3d> queries(const PointSet& s, std::mt19937& rng) {
  std::vector<Eigen::Vector3d> q;
  std::uniform_real_distribution<double> u(-1.0, 4.0);
  const bool planar = (s.x.col(2).array() == 0.0).all();
  for (int i = 0; i < 60; ++i) {
    const Eigen::Vector3d a = s.x.row(rng() % s.x.rows()).transpose();
    const Eigen::Vector3d b = s.x.row(rng() % s.x.rows()).transpose();
    q.push_back(a);
    q.push_back(0.5 * (a + b));
    Eigen::Vector3d half = a + Eigen::Vector3d(0.125, 0.125, planar ? 0.0 : 0.125);
    q.push_back(half);
    q.push_back(a + Eigen::Vector3d(0.125, 0.0, 0.0));
    q.push_back(Eigen::Vector3d(u(rng), u(rng), planar ? 0.0 : u(rng)));
    q.push_back(Eigen::Vector3d(u(rng), u(rng), u(rng)));  // off the plane of a planar set
  }
  for (double far :
       {1e3, 1e6, 1e12, 1e100, 1e150, 1.3e154, 1.35e154, 1e160, 1e200, 1e300, 1.7e308}) {
    q.emplace_back(far, 0.0, 0.0);
    q.emplace_back(-far, far, 0.0);
    q.emplace_back(0.5, 0.5, -far);
  }
  return q;
}

void checkSame(const PointSet& s, const std::vector<Eigen::Vector3d>& points, std::mt19937& rng) {
  VertexSearch tree(s.x, s.used, VertexSearch::Mode::Tree);
  VertexSearch scan(s.x, s.used, VertexSearch::Mode::Scan);
  VertexSearch adaptive(s.x, s.used);
  for (const Eigen::Vector3d& p : points) {
    INFO("nearest to " << p.transpose());
    const int expect = scanNearest(s.x, s.used, p);
    CHECK(tree.nearest(p) == expect);
    CHECK(scan.nearest(p) == expect);
    CHECK(adaptive.nearest(p) == expect);
  }
  CHECK(tree.indexed());
  CHECK_FALSE(scan.indexed());
  CHECK(adaptive.indexed());

  // Radii equal to lattice distances (boundary ties), random, tiny and huge.
  std::uniform_real_distribution<double> u(0.0, 1.5);
  const std::vector<double> radii = {0.25, std::sqrt(0.125), 0.5, 0.75, 1e-300, 1e300, 1e155};
  for (size_t i = 0; i < points.size(); ++i) {
    const double r = i % 2 ? u(rng) : radii[i / 2 % radii.size()];
    INFO("within " << r << " of " << points[i].transpose());
    const std::vector<int> expect = scanWithin(s.x, s.used, points[i], r);
    CHECK(tree.within(points[i], r) == expect);
    CHECK(scan.within(points[i], r) == expect);
  }
}

}  // namespace

TEST_CASE("the kd-tree selects the vertices a scan selects", "[handles][search]") {
  std::mt19937 rng(20240611);
  SECTION("3D lattice with ties, coincident and unreferenced vertices") {
    const PointSet s = lattice(9, false, rng);
    checkSame(s, queries(s, rng), rng);
  }
  SECTION("planar lattice at z = 0") {
    const PointSet s = lattice(25, true, rng);
    checkSame(s, queries(s, rng), rng);
  }
  SECTION("random points of two scales") {
    const PointSet s = randomCloud(3000, rng);
    checkSame(s, queries(s, rng), rng);
  }
}

TEST_CASE("equidistant vertices: the lowest id wins", "[handles][search]") {
  // The unit square's corners, numbered against their order in space.
  Eigen::MatrixXd x(5, 3);
  x << 1, 1, 0,  //
      1, 0, 0,   //
      0, 1, 0,   //
      0, 0, 0,   //
      1, 1, 0;   // a copy of vertex 0
  for (const bool referenced0 : {true, false}) {
    std::vector<bool> used(5, true);
    used[0] = referenced0;
    for (const auto mode : {VertexSearch::Mode::Tree, VertexSearch::Mode::Scan}) {
      VertexSearch search(x, used, mode);
      const int centre = referenced0 ? 0 : 1;
      CHECK(search.nearest({0.5, 0.5, 0}) == centre);
      CHECK(search.nearest({0.5, 0.5, 7}) == centre);
      CHECK(search.nearest({0.5, 0.0, 0}) == 1);  // 1 and 3
      CHECK(search.nearest({0.0, 0.5, 0}) == 2);  // 2 and 3
      CHECK(search.nearest({1.0, 1.0, 0}) == (referenced0 ? 0 : 4));
      CHECK(search.nearest({1e300, 0, 0}) == (referenced0 ? 0 : 1));  // every distance is inf
      CHECK(search.within({1, 1, 0}, 1.0) ==
            (referenced0 ? std::vector<int>{0, 1, 2, 4} : std::vector<int>{1, 2, 4}));
    }
  }
}

TEST_CASE("handle files with many selectors: the same vertices as before", "[handles][search]") {
  std::mt19937 rng(7);
  for (const Mesh& mesh : {makeTetBox(1.0, 1.0, 1.0, 6, 6, 6), makeRectangle(2.0, 1.0, 16, 8),
                           makeSphere(1.0, 24, 12)}) {
    const Eigen::MatrixXd x = mesh.positions();
    const std::vector<bool> used = mesh.referenced();
    const bool planar = mesh.kind() == MeshKind::Planar;
    const auto point = [&](const Eigen::Vector3d& p) {
      std::ostringstream out;
      out.precision(17);
      out << "[" << p[0] << ", " << p[1];
      if (!planar) out << ", " << p[2];
      out << "]";
      return out.str();
    };
    // Nearest points at vertices, edge midpoints (ties) and far away; small balls; each kept
    // only if its vertices are in no earlier handle, as a file must be.
    std::set<int> taken;
    std::vector<std::vector<int>> expect;
    std::string json = "{\"handles\": [";
    std::uniform_real_distribution<double> jitter(-0.02, 0.02);
    for (int h = 0; h < 300; ++h) {
      const Eigen::Vector3d a = x.row(rng() % x.rows()).transpose();
      const Eigen::Vector3d b = x.row(rng() % x.rows()).transpose();
      std::vector<int> ids;
      std::string selector;
      if (h % 3 == 2) {
        const double r = 0.01 + 0.1 * (h % 5);
        ids = scanWithin(x, used, a, r);
        std::ostringstream radius;
        radius.precision(17);
        radius << r;
        selector = "\"within\": {\"center\": " + point(a) + ", \"radius\": " + radius.str() + "}";
      } else {
        Eigen::Vector3d p = h % 3 ? 0.5 * (a + b) : a;
        if (h % 7 == 0) p = 1e6 * (a - b);
        if (h % 11 == 0) p += Eigen::Vector3d(jitter(rng), jitter(rng), 0);
        if (planar) p[2] = 0.0;
        ids = {scanNearest(x, used, p)};
        selector = "\"nearest\": " + point(p);
      }
      if (ids.empty() || std::any_of(ids.begin(), ids.end(), [&](int v) { return taken.count(v); }))
        continue;
      taken.insert(ids.begin(), ids.end());
      expect.push_back(ids);
      json += std::string(expect.size() > 1 ? ", " : "") + "{" + selector + "}";
    }
    json += "]}";
    REQUIRE(expect.size() > 60);  // enough to build the tree
    const HandleSet set = parseHandles(json, mesh, "h.json");
    REQUIRE(set.handles.size() == expect.size());
    for (size_t h = 0; h < expect.size(); ++h) {
      INFO("handle " << h);
      CHECK(set.handles[h].vertices == expect[h]);
    }
  }
}

TEST_CASE("overlapping handles: the first overlap is reported as before", "[handles][search]") {
  const Mesh mesh = makeRectangle(1.0, 1.0, 3, 3);
  // Many balls that each hold every vertex: the second one ends the parse.
  std::string json = "{\"handles\": [";
  for (int h = 0; h < 2000; ++h) {
    json += std::string(h ? ", " : "") + "{\"name\": \"b" + std::to_string(h) +
            "\", \"within\": {\"center\": [0.5, 0.5], \"radius\": 1e300}}";
  }
  json += "]}";
  try {
    parseHandles(json, mesh, "h.json");
    FAIL("no error");
  } catch (const InvalidParameter& e) {
    CHECK_THAT(e.what(), Contains("h.json: vertex 0 is in handles 'b0' and 'b1'"));
  }
}

TEST_CASE("many picked points chosen by name", "[handles][search][picked]") {
  const Mesh mesh = makeRectangle(1.0, 1.0, 40, 30);
  const Eigen::MatrixXd x = mesh.positions();
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("diffreg-search-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  // A point near every vertex, named p<id>, every 7th inactive.
  std::ostringstream pp, names, nearest;
  pp.precision(17);
  nearest.precision(17);
  pp << "<PickedPoints>\n";
  std::vector<int> expect;
  for (int v = static_cast<int>(x.rows()) - 1; v >= 0; --v) {
    const double dx = 1e-3 * (v % 3), dy = -1e-3 * (v % 5);
    pp << " <point x='" << x(v, 0) + dx << "' y='" << x(v, 1) + dy << "' z='0' active='"
       << (v % 7 ? 1 : 0) << "' name='p" << v << "'/>\n";
    if (v % 7 == 0) continue;
    names << (expect.empty() ? "" : ", ") << "\"p" << v << "\"";
    nearest << (expect.empty() ? "" : ", ") << "[" << x(v, 0) + dx << ", " << x(v, 1) + dy << "]";
    expect.push_back(v);
  }
  pp << "</PickedPoints>\n";
  std::ofstream(dir / "points.pp") << pp.str();
  const auto read = [&](const std::string& json) {
    return parseHandles(json, mesh, "h.json", dir.string());
  };
  const auto error = [&](const std::string& json) {
    try {
      read(json);
    } catch (const InvalidParameter& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  REQUIRE(expect.size() > 1000);
  CHECK(read(R"({"handles": [{"picked": {"file": "points.pp", "names": [)" + names.str() + "]}}]}")
            .handles[0]
            .vertices == expect);
  CHECK(read(R"({"handles": [{"nearest": [)" + nearest.str() + "]}]}").handles[0].vertices ==
        expect);
  CHECK(read(R"({"handles": [{"picked": "points.pp"}]})").handles[0].vertices == expect);
  CHECK(read(R"({"handles_from_picked": {"file": "points.pp", "names": [)" + names.str() + "]}}")
            .handles.size() == expect.size());
  // A name given twice: its point is nearest to the same vertex again.
  CHECK_THAT(
      error(R"({"handles": [{"picked": {"file": "points.pp", "names": ["p1", "p2", "p1"]}}]})"),
      Contains("picked points 'p1' (line ") && Contains(" are both nearest to vertex 1"));
  CHECK_THAT(
      error(R"({"handles_from_picked": {"file": "points.pp", "names": ["p1", "p2", "p1"]}})"),
      Contains("two handles are named 'p1'"));
  // Names are checked before points are chosen, whatever comes first in the list.
  CHECK_THAT(
      error(R"({"handles": [{"picked": {"file": "points.pp", "names": ["p1", "p1", "q"]}}]})"),
      Contains("no point named 'q'"));
  CHECK_THAT(
      error(R"({"handles": [{"picked": {"file": "points.pp", "names": ["p1", "p1", "p7"]}}]})"),
      Contains("point 'p7' in ") && Contains("is not active"));
  std::filesystem::remove_all(dir);
}
