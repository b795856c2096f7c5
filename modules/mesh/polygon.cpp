#include <diffreg/mesh/polygon.h>

#include <diffreg/core/error.h>

#include <Eigen/Geometry>

#include <cmath>
#include <list>

namespace diffreg {
namespace {

using Vec2 = Eigen::Vector2d;

double cross(const Vec2& a, const Vec2& b, const Vec2& c) {
  return (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
}

/// True when the closed segments ab and cd share a point.
bool segmentsMeet(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d) {
  const double d1 = cross(c, d, a), d2 = cross(c, d, b), d3 = cross(a, b, c), d4 = cross(a, b, d);
  if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0)))
    return true;
  const auto onSegment = [](const Vec2& p, const Vec2& q, const Vec2& r, double o) {
    return o == 0 && std::min(p.x(), q.x()) <= r.x() && r.x() <= std::max(p.x(), q.x()) &&
           std::min(p.y(), q.y()) <= r.y() && r.y() <= std::max(p.y(), q.y());
  };
  return onSegment(c, d, a, d1) || onSegment(c, d, b, d2) || onSegment(a, b, c, d3) ||
         onSegment(a, b, d, d4);
}

/// The polygon in its Newell plane, counter-clockwise about the Newell normal.
std::vector<Vec2> project(const std::vector<Eigen::Vector3d>& p, const std::string& where) {
  const size_t n = p.size();
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  for (const auto& q : p) center += q / static_cast<double>(n);
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  double diameter = 0.0;
  for (size_t i = 0; i < n; ++i) {
    normal += (p[i] - center).cross(p[(i + 1) % n] - center);
    for (size_t j = 0; j < i; ++j) diameter = std::max(diameter, (p[i] - p[j]).norm());
  }
  if (!(normal.norm() > 1e-14 * diameter * diameter)) {
    throw InvalidMesh(where +
                      " is a polygon without area (degenerate, or self-intersecting so "
                      "that its parts cancel)");
  }
  normal.normalize();
  for (const auto& q : p) {
    if (std::abs((q - center).dot(normal)) > 0.05 * diameter) {
      throw InvalidMesh(where + " is a non-planar polygon (a corner lies " +
                        std::to_string(std::abs((q - center).dot(normal)) / diameter) +
                        " diameters off its plane)");
    }
  }
  const Eigen::Vector3d u = normal.unitOrthogonal(), v = normal.cross(u);
  std::vector<Vec2> out;
  for (const auto& q : p) out.emplace_back((q - center).dot(u), (q - center).dot(v));
  return out;
}

void requireSimple(const std::vector<Vec2>& q, const std::string& where) {
  const size_t n = q.size();
  for (size_t i = 0; i < n; ++i) {
    for (size_t j = i + 1; j < n; ++j) {
      if (q[i] == q[j]) throw InvalidMesh(where + " is a polygon with two corners at one point");
      const bool adjacent = j == i + 1 || (i == 0 && j == n - 1);
      if (!adjacent && segmentsMeet(q[i], q[(i + 1) % n], q[j], q[(j + 1) % n])) {
        throw InvalidMesh(where + " is a self-intersecting polygon (its edges " +
                          std::to_string(i) + " and " + std::to_string(j) + " meet)");
      }
    }
  }
}

/// True when no corner of `ring` other than a, b, c lies in or on the triangle abc.
bool isEar(const std::list<size_t>& ring, const std::vector<Vec2>& q, size_t a, size_t b,
           size_t c) {
  if (!(cross(q[a], q[b], q[c]) > 0)) return false;
  for (size_t k : ring) {
    if (k == a || k == b || k == c) continue;
    if (cross(q[a], q[b], q[k]) >= 0 && cross(q[b], q[c], q[k]) >= 0 &&
        cross(q[c], q[a], q[k]) >= 0)
      return false;
  }
  return true;
}

}  // namespace

std::vector<std::array<long long, 3>> triangulatePolygon(const std::vector<Eigen::Vector3d>& points,
                                                         const std::vector<long long>& ids,
                                                         const std::string& where) {
  const size_t n = ids.size();
  if (n > kMaxPolygonCorners) {
    throw InvalidMesh(where + " is a polygon with " + std::to_string(n) + " corners (at most " +
                      std::to_string(kMaxPolygonCorners) + ")");
  }
  std::vector<Eigen::Vector3d> p;
  for (long long id : ids) p.push_back(points[id]);
  const std::vector<Vec2> q = project(p, where);
  requireSimple(q, where);
  std::list<size_t> ring;
  for (size_t i = 0; i < n; ++i) ring.push_back(i);
  std::vector<std::array<long long, 3>> out;
  auto it = ring.begin();
  size_t misses = 0;
  while (ring.size() > 3) {
    const auto prev = it == ring.begin() ? std::prev(ring.end()) : std::prev(it);
    const auto next = std::next(it) == ring.end() ? ring.begin() : std::next(it);
    if (isEar(ring, q, *prev, *it, *next)) {
      out.push_back({ids[*prev], ids[*it], ids[*next]});
      it = ring.erase(it);
      if (it == ring.end()) it = ring.begin();
      misses = 0;
    } else if (++misses > ring.size()) {
      throw InvalidMesh(where + " is a polygon that cannot be triangulated (nearly degenerate)");
    } else {
      it = next;
    }
  }
  const auto a = ring.begin(), b = std::next(a), c = std::next(b);
  if (!(cross(q[*a], q[*b], q[*c]) > 0)) {
    throw InvalidMesh(where + " is a polygon that cannot be triangulated (nearly degenerate)");
  }
  out.push_back({ids[*a], ids[*b], ids[*c]});
  return out;
}

}  // namespace diffreg
