// Holes are joined to the outline by bridges (Eberly, "Triangulation by Ear Clipping", 2002): each
// hole's rightmost vertex to a vertex of the outline it sees along +x, the bridge walked both ways.
// Then ears are clipped; a corner is an ear when it turns left and no non-convex corner lies in it.
#include "geometry/polygon_triangulation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>

namespace cmm::geometry {
namespace {

using Point2 = Eigen::Vector2d;

double cross(const Point2& a, const Point2& b, const Point2& c) {
  return (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
}

bool in_triangle(const Point2& p, const Point2& a, const Point2& b, const Point2& c) {
  return cross(a, b, p) >= 0 && cross(b, c, p) >= 0 && cross(c, a, p) >= 0;
}

// Splices the hole (indices into points) into the loop at the outline vertex its rightmost point sees.
void bridge(std::vector<int>& loop, const std::vector<int>& hole, const std::vector<Point2>& points) {
  const auto rightmost = std::max_element(hole.begin(), hole.end(), [&](int a, int b) {
    return points[a].x() < points[b].x() || (points[a].x() == points[b].x() && points[a].y() > points[b].y());
  });
  const Point2 m = points[*rightmost];
  // The nearest loop edge the ray m + t(1, 0) crosses, and its endpoint farther along +x.
  double nearest = std::numeric_limits<double>::infinity();
  int candidate = -1;
  const std::size_t n = loop.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Point2 &a = points[loop[i]], &b = points[loop[(i + 1) % n]];
    if ((a.y() > m.y()) == (b.y() > m.y()) && a.y() != m.y()) continue;
    if (a.y() == b.y()) continue;
    const double x = a.x() + (m.y() - a.y()) * (b.x() - a.x()) / (b.y() - a.y());
    if (x < m.x() || x >= nearest) continue;
    nearest = x;
    // The endpoint farther along +x; of a vertical edge's two, the one nearer the ray.
    const bool take_a = a.x() != b.x() ? a.x() > b.x() : std::abs(a.y() - m.y()) < std::abs(b.y() - m.y());
    candidate = static_cast<int>(take_a ? i : (i + 1) % n);
  }
  if (candidate < 0) throw std::invalid_argument("triangulate_polygon: a hole lies outside the outline");
  // A non-convex loop vertex inside (m, the crossing, the candidate) hides the candidate: take the one of
  // them closest in angle to the ray.
  const Point2 crossing(nearest, m.y()), p = points[loop[candidate]];
  double best_angle = std::numeric_limits<double>::infinity();
  int best = candidate;
  for (std::size_t i = 0; i < n; ++i) {
    const Point2& v = points[loop[i]];
    const bool convex = cross(points[loop[(i + n - 1) % n]], v, points[loop[(i + 1) % n]]) > 0;
    if (convex || v == m) continue;
    const bool inside = p.y() >= m.y() ? in_triangle(v, m, crossing, p) : in_triangle(v, m, p, crossing);
    if (!inside) continue;
    const double angle = std::atan2(std::abs(v.y() - m.y()), v.x() - m.x());
    if (angle < best_angle) best_angle = angle, best = static_cast<int>(i);
  }
  // A vertex an earlier bridge left twice in the loop: the copy whose corner opens toward m.
  for (std::size_t i = 0; i < n; ++i) {
    if (points[loop[i]] != points[loop[best]]) continue;
    const Point2 &prev = points[loop[(i + n - 1) % n]], &at = points[loop[i]], &next = points[loop[(i + 1) % n]];
    const bool convex = cross(prev, at, next) > 0;
    const bool left_in = cross(prev, at, m) > 0, left_out = cross(at, next, m) > 0;
    if (convex ? left_in && left_out : left_in || left_out) {
      best = static_cast<int>(i);
      break;
    }
  }
  std::vector<int> spliced(loop.begin(), loop.begin() + best + 1);
  const std::size_t start = static_cast<std::size_t>(rightmost - hole.begin());
  for (std::size_t k = 0; k <= hole.size(); ++k) spliced.push_back(hole[(start + k) % hole.size()]);
  spliced.insert(spliced.end(), loop.begin() + best, loop.end());
  loop = std::move(spliced);
}

}  // namespace

std::vector<std::array<int, 3>> triangulate_polygon(const Polygon2d& outer, const std::vector<Polygon2d>& holes) {
  std::vector<Point2> points(outer.begin(), outer.end());
  std::vector<int> loop(outer.size());
  std::iota(loop.begin(), loop.end(), 0);
  std::vector<std::vector<int>> hole_indices;
  for (const Polygon2d& hole : holes) {
    std::vector<int> indices;
    for (const Point2& p : hole) indices.push_back(static_cast<int>(points.size())), points.push_back(p);
    hole_indices.push_back(std::move(indices));
  }
  auto max_x = [&](const std::vector<int>& h) {
    double x = -std::numeric_limits<double>::infinity();
    for (int i : h) x = std::max(x, points[i].x());
    return x;
  };
  std::sort(hole_indices.begin(), hole_indices.end(), [&](const auto& a, const auto& b) { return max_x(a) > max_x(b); });
  for (const auto& hole : hole_indices) bridge(loop, hole, points);

  std::vector<std::array<int, 3>> triangles;
  auto corner = [&](std::size_t i) -> const Point2& { return points[loop[i % loop.size()]]; };
  std::size_t i = 0, since_last_ear = 0;
  while (loop.size() > 3) {
    const std::size_t n = loop.size();
    const std::size_t prev = (i + n - 1) % n, next = (i + 1) % n;
    const Point2 &a = corner(prev), &b = corner(i), &c = corner(next);
    bool ear = cross(a, b, c) > 0;
    for (std::size_t k = 0; ear && k < n; ++k) {
      if (k == prev || k == i || k == next) continue;
      const Point2& v = corner(k);
      if (v == a || v == b || v == c) continue;  // a bridge's two copies of one point
      if (cross(corner(k + n - 1), v, corner(k + 1)) > 0) continue;  // a convex corner cannot be inside an ear
      ear = !in_triangle(v, a, b, c);
    }
    if (ear) {
      triangles.push_back({loop[prev], loop[i], loop[next]});
      loop.erase(loop.begin() + static_cast<std::ptrdiff_t>(i));
      i = i % loop.size();
      since_last_ear = 0;
      continue;
    }
    if (++since_last_ear > loop.size()) throw std::invalid_argument("triangulate_polygon: no ear left (does the polygon cross itself?)");
    i = (i + 1) % loop.size();
  }
  if (cross(corner(0), corner(1), corner(2)) > 0) triangles.push_back({loop[0], loop[1], loop[2]});
  return triangles;
}

}  // namespace cmm::geometry
