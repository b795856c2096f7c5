// CGAL stays in this file: its headers are heavy and no other header needs them.
#include <diffreg/handles/vertex_search.h>

#include <CGAL/Orthogonal_k_neighbor_search.h>
#include <CGAL/Search_traits_3.h>
#include <CGAL/Search_traits_adapter.h>
#include <CGAL/Simple_cartesian.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace diffreg {
namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using Point = Kernel::Point_3;

/// Building the tree costs as much as 150 to 220 scans (measured on meshes of 300 to 300K
/// vertices; a query in the tree then costs about 1 us): the first queries scan, and a file with
/// more builds the tree, which at most doubles the least possible time.
constexpr int kScanQueries = 128;

/// The squared distance every query compares, left to right as Eigen's squaredNorm() of a
/// 3-vector: the scan and the tree compare the very same numbers.
inline double squaredDistance(double x, double y, double z, const Eigen::Vector3d& p) {
  const double dx = x - p[0], dy = y - p[1], dz = z - p[2];
  return dx * dx + dy * dy + dz * dz;
}

/// The position of a group of coincident vertices; the tree holds one key per group.
struct GroupPointMap {
  using key_type = int;
  using value_type = Point;
  using reference = const Point&;
  using category = boost::lvalue_property_map_tag;
  const std::vector<Point>* points = nullptr;
  friend reference get(const GroupPointMap& map, int group) { return (*map.points)[group]; }
};

using Traits = CGAL::Search_traits_adapter<int, GroupPointMap, CGAL::Search_traits_3<Kernel>>;
using NeighborSearch = CGAL::Orthogonal_k_neighbor_search<Traits>;
using KdTree = NeighborSearch::Tree;

/// A CGAL fuzzy query for the groups whose squared distance d to `center` passes `accept`
/// (monotone: true for d implies true for every smaller d). A box is tested with the smallest
/// and largest squared distance any point inside it can have, computed with the same roundings
/// as squaredDistance (rounding is monotone), so no point is lost or wrongly reported.
template <class Accept>
struct Ball {
  const std::vector<Point>* points;
  Eigen::Vector3d center;
  Accept accept;

  bool contains(int group) const {
    const Point& p = (*points)[group];
    return accept(squaredDistance(p.x(), p.y(), p.z(), center));
  }
  template <class Box>
  bool inner_range_intersects(const Box& box) const {
    double d[3];
    for (int i = 0; i < 3; ++i) {
      const double lo = box.min_coord(i), hi = box.max_coord(i), c = center[i];
      d[i] = c < lo ? lo - c : (c > hi ? c - hi : 0.0);
    }
    return accept(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  }
  template <class Box>
  bool outer_range_contains(const Box& box) const {
    double d[3];
    for (int i = 0; i < 3; ++i) {
      d[i] =
          std::max(std::abs(box.min_coord(i) - center[i]), std::abs(box.max_coord(i) - center[i]));
    }
    return accept(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  }
};

template <class Accept>
Ball<Accept> makeBall(const std::vector<Point>& points, const Eigen::Vector3d& center,
                      Accept accept) {
  return Ball<Accept>{&points, center, accept};
}

}  // namespace

/// Referenced vertices grouped by position (coincident vertices are one key of the tree, so a
/// nearest query meets each position once and takes its lowest id).
struct VertexSearch::Tree {
  std::vector<int> ids;       ///< referenced vertex ids sorted by position, then id
  std::vector<int> start;     ///< group g is ids[start[g]] .. ids[start[g + 1] - 1]
  std::vector<Point> points;  ///< group g's position
  int lowest = -1;            ///< the lowest referenced id
  std::unique_ptr<KdTree> tree;

  Tree(const Eigen::MatrixXd& x, const std::vector<bool>& referenced) {
    for (int v = 0; v < static_cast<int>(x.rows()); ++v)
      if (referenced[v]) ids.push_back(v);
    if (!ids.empty()) lowest = ids.front();
    const auto less = [&x](int a, int b) {
      for (int c = 0; c < 3; ++c)
        if (x(a, c) != x(b, c)) return x(a, c) < x(b, c);
      return a < b;
    };
    std::sort(ids.begin(), ids.end(), less);
    for (size_t i = 0; i < ids.size(); ++i) {
      const int v = ids[i];
      if (i == 0 || x.row(v) != x.row(ids[i - 1])) {
        start.push_back(static_cast<int>(i));
        points.emplace_back(x(v, 0), x(v, 1), x(v, 2));
      }
    }
    start.push_back(static_cast<int>(ids.size()));
    std::vector<int> groups(points.size());
    std::iota(groups.begin(), groups.end(), 0);
    tree = std::make_unique<KdTree>(groups.begin(), groups.end(), KdTree::Splitter(),
                                    Traits(GroupPointMap{&points}));
    tree->build();
  }
};

VertexSearch::VertexSearch(const Eigen::MatrixXd& points, const std::vector<bool>& referenced,
                           Mode mode)
    : points_(points), referenced_(referenced), mode_(mode) {
  for (Eigen::Index v = 0; v < points_.rows() && finite_; ++v)
    if (referenced_[v] && !points_.row(v).allFinite()) finite_ = false;
}

VertexSearch::~VertexSearch() = default;

bool VertexSearch::useTree() {
  ++queries_;
  if (tree_) return true;
  if (!finite_ || mode_ == Mode::Scan || (mode_ == Mode::Adaptive && queries_ <= kScanQueries))
    return false;
  tree_ = std::make_unique<Tree>(points_, referenced_);
  return true;
}

int VertexSearch::nearest(const Eigen::Vector3d& p) {
  const Eigen::MatrixXd& x = points_;
  if (!useTree()) {
    int best = -1;
    double bestDist = 0.0;
    for (int v = 0; v < x.rows(); ++v) {
      if (!referenced_[v]) continue;
      const double d = squaredDistance(x(v, 0), x(v, 1), x(v, 2), p);
      if (best < 0 || d < bestDist) {
        best = v;
        bestDist = d;
      }
    }
    return best;
  }
  const Tree& t = *tree_;
  if (t.ids.empty()) return -1;
  // CGAL's nearest neighbour bounds the smallest squared distance from above (its own sums
  // may round differently); every group within that bound is then compared exactly. When
  // even the nearest is at inf, only a group at a finite distance can beat the lowest id.
  double bound = std::numeric_limits<double>::max();
  const NeighborSearch search(*t.tree, Point(p[0], p[1], p[2]), 1, 0.0, true,
                              NeighborSearch::Distance(GroupPointMap{&t.points}));
  if (search.begin() != search.end()) {
    const Point& q = t.points[search.begin()->first];
    bound = std::min(bound, squaredDistance(q.x(), q.y(), q.z(), p));
  }
  std::vector<int> groups;
  t.tree->search(std::back_inserter(groups),
                 makeBall(t.points, p, [bound](double d) { return d <= bound; }));
  if (groups.empty()) return t.lowest;  // every vertex at inf: the scan keeps the first
  int best = -1;
  double bestDist = 0.0;
  for (int g : groups) {
    const Point& q = t.points[g];
    const double d = squaredDistance(q.x(), q.y(), q.z(), p);
    const int v = t.ids[t.start[g]];  // the group's lowest id
    if (best < 0 || d < bestDist || (d == bestDist && v < best)) {
      best = v;
      bestDist = d;
    }
  }
  return best;
}

std::vector<int> VertexSearch::within(const Eigen::Vector3d& c, double r) {
  std::vector<int> out;
  const Eigen::MatrixXd& x = points_;
  if (!useTree()) {
    for (int v = 0; v < x.rows(); ++v) {
      if (referenced_[v] && std::sqrt(squaredDistance(x(v, 0), x(v, 1), x(v, 2), c)) <= r)
        out.push_back(v);
    }
    return out;
  }
  const Tree& t = *tree_;
  std::vector<int> groups;
  t.tree->search(std::back_inserter(groups),
                 makeBall(t.points, c, [r](double d) { return std::sqrt(d) <= r; }));
  for (int g : groups)
    out.insert(out.end(), t.ids.begin() + t.start[g], t.ids.begin() + t.start[g + 1]);
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace diffreg
