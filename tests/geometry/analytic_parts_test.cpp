// The analytic parts are the ground truth of the feature-edge tests and the simulated CMM, so their
// meshes are held here to what those tests take for granted: closed, outward, one piece of the right
// genus and volume, well-shaped triangles, and vertices exactly on every true edge.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <iostream>
#include <map>
#include <numbers>
#include <numeric>
#include <string>
#include <utility>
#include <vector>

#include "geometry/analytic_parts.hpp"

namespace cmm::geometry {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kOnEdge = 1e-9;  // mm: "exactly on a true edge", allowing for rounding

enum class Shape { box, revolved };

struct PartCase {
  std::string name;
  std::function<AnalyticPart()> make;
  double edge_length;
  Shape shape;
  int genus;      // through holes
  double volume;  // of the true part, mm³
};

double box_volume(double x, double y, double z, const std::vector<double>& hole_radii) {
  double volume = x * y * z;
  for (double r : hole_radii) volume -= kPi * r * r * z;
  return volume;
}

double bicone_volume(double r, double h) { return 2 * kPi * r * r * h / 3; }
double hemisphere_cone_volume(double r, double h) { return 2 * kPi * r * r * r / 3 + kPi * r * r * h / 3; }

const std::vector<PartCase>& part_cases() {
  static const std::vector<PartCase> cases{
      {"cube_h1", [] { return make_cube(40, 1); }, 1, Shape::box, 0, 40 * 40 * 40},
      {"case3_block_h1", [] { return make_case3_block(1); }, 1, Shape::box, 5,
       box_volume(88, 95, 41, {21, 5, 5, 5, 5})},
      {"plate_with_holes_h1", [] { return make_plate_with_holes(1); }, 1, Shape::box, 5,
       box_volume(120, 80, 10, {10, 6, 6, 3, 4})},
      {"bicone_h1", [] { return make_bicone(25, 37.5, 1); }, 1, Shape::revolved, 0, bicone_volume(25, 37.5)},
      {"bicone_h2_5", [] { return make_bicone(25, 37.5, 2.5); }, 2.5, Shape::revolved, 0, bicone_volume(25, 37.5)},
      {"hemisphere_cone_low_h1", [] { return make_hemisphere_cone(25, 12.5, 1); }, 1, Shape::revolved, 0,
       hemisphere_cone_volume(25, 12.5)},
      {"hemisphere_cone_low_h2_5", [] { return make_hemisphere_cone(25, 12.5, 2.5); }, 2.5, Shape::revolved, 0,
       hemisphere_cone_volume(25, 12.5)},
      {"hemisphere_cone_high_h1", [] { return make_hemisphere_cone(25, 25, 1); }, 1, Shape::revolved, 0,
       hemisphere_cone_volume(25, 25)},
      {"hemisphere_cone_high_h2_5", [] { return make_hemisphere_cone(25, 25, 2.5); }, 2.5, Shape::revolved, 0,
       hemisphere_cone_volume(25, 25)},
  };
  return cases;
}

// Each part is made once per test run: several tests look at it.
const AnalyticPart& part_for(const PartCase& c) {
  static std::map<std::string, AnalyticPart> made;
  auto it = made.find(c.name);
  if (it == made.end()) it = made.emplace(c.name, c.make()).first;
  return it->second;
}

const AnalyticPart& part_named(const std::string& name) {
  const auto& cases = part_cases();
  return part_for(*std::find_if(cases.begin(), cases.end(), [&](const PartCase& c) { return c.name == name; }));
}

// The loops over every face and vertex read the row-major storage directly: Eigen expressions are
// slow in the unoptimised sanitizer build.
const double* xyz(const TriangleMesh& m, int v) { return m.vertices.data() + 3 * static_cast<std::ptrdiff_t>(v); }
const int* corners(const TriangleMesh& m, int f) { return m.faces.data() + 3 * static_cast<std::ptrdiff_t>(f); }

// The edges of all faces, run as the faces run them, listed by their first vertex.
class DirectedEdges {
 public:
  explicit DirectedEdges(const TriangleMesh& m) : first_(m.vertices.rows() + 1, 0), to_(3 * m.faces.rows()) {
    for (int f = 0; f < m.faces.rows(); ++f)
      for (int k = 0; k < 3; ++k) ++first_[corners(m, f)[k] + 1];
    std::partial_sum(first_.begin(), first_.end(), first_.begin());
    std::vector<int> filled(first_.begin(), first_.end() - 1);
    for (int f = 0; f < m.faces.rows(); ++f)
      for (int k = 0; k < 3; ++k) to_[filled[corners(m, f)[k]]++] = corners(m, f)[(k + 1) % 3];
  }
  int vertices() const { return static_cast<int>(first_.size()) - 1; }
  // Calls visit(a, b) for every directed edge.
  template <class Visit>
  void for_each(Visit visit) const {
    for (int a = 0; a < vertices(); ++a)
      for (int i = first_[a]; i < first_[a + 1]; ++i) visit(a, to_[i]);
  }
  int count(int a, int b) const {
    return static_cast<int>(std::count(to_.begin() + first_[a], to_.begin() + first_[a + 1], b));
  }

 private:
  std::vector<int> first_;  // edges from a are to_[first_[a] .. first_[a + 1])
  std::vector<int> to_;
};

double signed_volume(const TriangleMesh& m) {
  double six_volume = 0;
  for (int f = 0; f < m.faces.rows(); ++f) {
    const double *a = xyz(m, corners(m, f)[0]), *b = xyz(m, corners(m, f)[1]), *c = xyz(m, corners(m, f)[2]);
    six_volume +=
        a[0] * (b[1] * c[2] - b[2] * c[1]) + a[1] * (b[2] * c[0] - b[0] * c[2]) + a[2] * (b[0] * c[1] - b[1] * c[0]);
  }
  return six_volume / 6;
}

struct TriangleShapes {
  double min_angle_deg = 180, shortest_edge = 1e300, longest_edge = 0;
};

TriangleShapes triangle_shapes(const TriangleMesh& m) {
  TriangleShapes shapes;
  for (int f = 0; f < m.faces.rows(); ++f) {
    std::array<double, 3> squared{};  // edge k runs from corner k to corner k + 1
    for (std::size_t k = 0; k < 3; ++k) {
      const double *a = xyz(m, corners(m, f)[k]), *b = xyz(m, corners(m, f)[(k + 1) % 3]);
      squared[k] = (b[0] - a[0]) * (b[0] - a[0]) + (b[1] - a[1]) * (b[1] - a[1]) + (b[2] - a[2]) * (b[2] - a[2]);
    }
    for (std::size_t k = 0; k < 3; ++k) {
      const double opposite = squared[k], b = squared[(k + 1) % 3], c = squared[(k + 2) % 3];
      const double cosine = std::clamp((b + c - opposite) / (2 * std::sqrt(b * c)), -1.0, 1.0);
      shapes.min_angle_deg = std::min(shapes.min_angle_deg, std::acos(cosine) * 180 / kPi);
      shapes.shortest_edge = std::min(shapes.shortest_edge, std::sqrt(opposite));
      shapes.longest_edge = std::max(shapes.longest_edge, std::sqrt(opposite));
    }
  }
  return shapes;
}

// Area of the polygon of mesh vertices on a hole's rim (the inscribed polygon the bore is built on).
double rim_polygon_area(const TriangleMesh& m, const TrueHole& hole) {
  std::vector<std::pair<double, Eigen::Vector2d>> rim;
  for (int v = 0; v < m.vertices.rows(); ++v) {
    const double* p = xyz(m, v);
    const double dx = p[0] - hole.centre.x(), dy = p[1] - hole.centre.y();
    if (std::abs(p[2] - hole.centre.z()) < kOnEdge && std::abs(std::hypot(dx, dy) - hole.radius) < kOnEdge)
      rim.emplace_back(std::atan2(dy, dx), Eigen::Vector2d(dx, dy));
  }
  std::sort(rim.begin(), rim.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  double twice_area = 0;
  for (std::size_t i = 0; i < rim.size(); ++i) {
    const Eigen::Vector2d &a = rim[i].second, &b = rim[(i + 1) % rim.size()].second;
    twice_area += a.x() * b.y() - a.y() * b.x();
  }
  return twice_area / 2;
}

// n_up has the larger +z component, then +y, then +x (ties within 1e-9).
bool is_up_side(const Vec3& a, const Vec3& b) {
  for (int k : {2, 1, 0})
    if (std::abs(a[k] - b[k]) > 1e-9) return a[k] > b[k];
  return false;
}

// All true edges of the parts are horizontal circles (closed) or straight segments (open); this is
// the exact curve, recovered from the samples.
struct TrueCurve {
  explicit TrueCurve(const TrueEdge& edge)
      : closed(edge.closed), start(edge.samples.front().position), end(edge.samples.back().position) {
    for (const TrueEdgeSample& s : edge.samples) centre += s.position / static_cast<double>(edge.samples.size());
    radius = (start - centre).norm();
    const Vec3 reach = closed ? Vec3(radius, radius, 0) : Vec3::Zero();
    for (int k = 0; k < 3; ++k) {
      low[k] = (closed ? centre[k] - reach[k] : std::min(start[k], end[k])) - kOnEdge;
      high[k] = (closed ? centre[k] + reach[k] : std::max(start[k], end[k])) + kOnEdge;
    }
  }
  double distance(const Vec3& p) const {
    if (closed) return std::hypot(std::hypot(p.x() - centre.x(), p.y() - centre.y()) - radius, p.z() - centre.z());
    const Vec3 along = end - start;
    const double t = std::clamp((p - start).dot(along) / along.squaredNorm(), 0.0, 1.0);
    return (start + t * along - p).norm();
  }
  // Bounding-box rejection first: most vertices are far from any one edge.
  bool passes_through(const double* p) const {
    for (std::size_t k : {2, 1, 0})  // z first: all true edges of the parts lie in z = const or run along z
      if (p[k] < low[k] || p[k] > high[k]) return false;
    return distance(Vec3(p[0], p[1], p[2])) < kOnEdge;
  }
  double length() const { return closed ? 2 * kPi * radius : (end - start).norm(); }

  bool closed;
  Vec3 start, end, centre = Vec3::Zero();
  double radius = 0;
  std::array<double, 3> low{}, high{};  // bounding box, widened by kOnEdge
};

class AnalyticPartMesh : public ::testing::TestWithParam<PartCase> {
 protected:
  const AnalyticPart& part() const { return part_for(GetParam()); }
  const TriangleMesh& mesh() const { return part().mesh; }
  double h() const { return GetParam().edge_length; }
};

TEST_P(AnalyticPartMesh, IsClosedAndConsistentlyOriented) {
  // Every directed edge once, its reverse once: each edge has two faces that run it oppositely.
  const DirectedEdges edges(mesh());
  int defects = 0;
  edges.for_each([&](int a, int b) { defects += edges.count(a, b) != 1 || edges.count(b, a) != 1; });
  EXPECT_EQ(defects, 0);
}

TEST_P(AnalyticPartMesh, IsOnePieceOfTheRightGenus) {
  const DirectedEdges edges(mesh());
  std::vector<int> root(edges.vertices());
  std::iota(root.begin(), root.end(), 0);
  const auto find = [&](int v) {
    while (root[v] != v) v = root[v] = root[root[v]];
    return v;
  };
  long undirected = 0;
  edges.for_each([&](int a, int b) {
    root[find(a)] = find(b);
    undirected += a < b || edges.count(b, a) == 0;
  });
  int components = 0;
  for (int v = 0; v < edges.vertices(); ++v) components += find(v) == v;
  EXPECT_EQ(components, 1) << "or unreferenced vertices";
  EXPECT_EQ(edges.vertices() - undirected + mesh().faces.rows(), 2 - 2 * GetParam().genus);
}

TEST_P(AnalyticPartMesh, EnclosesTheTrueVolume) {
  const double volume = signed_volume(mesh());
  ASSERT_GT(volume, 0) << "faces point inward";
  EXPECT_NEAR(volume, GetParam().volume, 0.005 * GetParam().volume);
  if (GetParam().shape == Shape::box) {
    // Bores are prisms on the inscribed rim polygons: the mesh volume follows exactly.
    const Vec3 size = mesh().vertices.colwise().maxCoeff().transpose();
    double expected = size.prod();
    for (const TrueHole& hole : part().holes) expected -= rim_polygon_area(mesh(), hole) * hole.depth;
    EXPECT_NEAR(volume, expected, 1e-9 * expected);
  } else {
    // Vertices on a convex body's surface span a polyhedron inside it.
    EXPECT_LT(volume, GetParam().volume);
  }
}

TEST_P(AnalyticPartMesh, StandsOnZAndSpansItsSize) {
  const Vec3 low = mesh().vertices.colwise().minCoeff().transpose();
  const Vec3 high = mesh().vertices.colwise().maxCoeff().transpose();
  EXPECT_EQ(low.z(), 0.0);
  EXPECT_NEAR((high - low).norm(), part().size, 0.01 * part().size);
}

TEST_P(AnalyticPartMesh, HasWellShapedTriangles) {
  const TriangleShapes shapes = triangle_shapes(mesh());
  std::cout << "[          ] " << GetParam().name << ": " << mesh().faces.rows() << " triangles, "
            << mesh().vertices.rows() << " vertices, min angle " << shapes.min_angle_deg << "°, edges "
            << shapes.shortest_edge / h() << "–" << shapes.longest_edge / h() << " h\n";
  RecordProperty("triangles", static_cast<int>(mesh().faces.rows()));
  RecordProperty("min_angle_deg", std::to_string(shapes.min_angle_deg));
  EXPECT_GT(shapes.min_angle_deg, 10);
  EXPECT_GE(shapes.shortest_edge, 0.3 * h());
  EXPECT_LE(shapes.longest_edge, 2.5 * h());
}

TEST_P(AnalyticPartMesh, TrueEdgeSamplesFollowTheConventions) {
  ASSERT_FALSE(part().sharp_edges.empty());
  for (std::size_t e = 0; e < part().sharp_edges.size(); ++e) {
    const TrueEdge& edge = part().sharp_edges[e];
    const auto& s = edge.samples;
    ASSERT_GE(s.size(), 2u);
    EXPECT_TRUE(edge.convex);
    const TrueCurve curve(edge);
    double worst_norm = 0, worst_distance = 0, closest = 1e300, farthest = 0;
    int upside_down = 0;
    for (std::size_t i = 0; i < s.size(); ++i) {
      worst_norm = std::max({worst_norm, std::abs(s[i].n_up.norm() - 1), std::abs(s[i].n_down.norm() - 1)});
      upside_down += !is_up_side(s[i].n_up, s[i].n_down);
      worst_distance = std::max(worst_distance, curve.distance(s[i].position));
      if (i + 1 < s.size() || edge.closed) {
        const double spacing = (s[(i + 1) % s.size()].position - s[i].position).norm();
        closest = std::min(closest, spacing);
        farthest = std::max(farthest, spacing);
      }
    }
    EXPECT_LT(worst_norm, 1e-12) << "true edge " << e;
    EXPECT_EQ(upside_down, 0) << "true edge " << e;
    EXPECT_LT(worst_distance, kOnEdge) << "true edge " << e;
    EXPECT_GT(closest, 0) << "true edge " << e << " repeats a sample";
    EXPECT_LE(farthest, 0.1) << "true edge " << e;
  }
}

TEST_P(AnalyticPartMesh, HasVerticesExactlyOnEveryTrueEdge) {
  for (std::size_t e = 0; e < part().sharp_edges.size(); ++e) {
    const TrueCurve curve(part().sharp_edges[e]);
    int on_edge = 0;
    for (int v = 0; v < mesh().vertices.rows(); ++v) on_edge += curve.passes_through(xyz(mesh(), v));
    EXPECT_GT(on_edge, curve.length() / (2 * h())) << "true edge " << e;
  }
}

INSTANTIATE_TEST_SUITE_P(AnalyticPart, AnalyticPartMesh, ::testing::ValuesIn(part_cases()),
                         [](const ::testing::TestParamInfo<PartCase>& info) { return info.param.name; });

double interior_angle_deg(const TrueEdgeSample& s) { return 180 - std::acos(s.n_up.dot(s.n_down)) * 180 / kPi; }

// How far the samples stray from the circle of radius r about the z axis at height z.
double worst_distance_from_circle(const TrueEdge& edge, double r, double z) {
  double worst = 0;
  for (const TrueEdgeSample& s : edge.samples)
    worst = std::max(worst, std::hypot(s.position.head<2>().norm() - r, s.position.z() - z));
  return worst;
}

// The sample's interior angle farthest from `expected`.
double worst_interior_angle_deg(const TrueEdge& edge, double expected) {
  double worst = expected;
  for (const TrueEdgeSample& s : edge.samples)
    if (std::abs(interior_angle_deg(s) - expected) > std::abs(worst - expected)) worst = interior_angle_deg(s);
  return worst;
}

TEST(AnalyticPartTruth, Case3BlockHasItsBoxEdgesRimsAndHoles) {
  const AnalyticPart& part = part_named("case3_block_h1");
  EXPECT_NEAR(part.size, std::sqrt(88.0 * 88 + 95 * 95 + 41 * 41), 1e-9);
  int straight = 0, rims = 0;
  for (const TrueEdge& edge : part.sharp_edges) {
    (edge.closed ? rims : straight) += 1;
    EXPECT_NEAR(worst_interior_angle_deg(edge, 90), 90, 1e-9);
  }
  EXPECT_EQ(straight, 12);
  EXPECT_EQ(rims, 10);
  const std::vector<std::pair<Eigen::Vector2d, double>> expected{
      {{44, 47.5}, 21}, {{13, 12.5}, 5}, {{75, 12.5}, 5}, {{13, 82.5}, 5}, {{75, 82.5}, 5}};
  ASSERT_EQ(part.holes.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const TrueHole& hole = part.holes[i];
    EXPECT_EQ(hole.centre, Vec3(expected[i].first.x(), expected[i].first.y(), 41));
    EXPECT_EQ(hole.axis, Vec3::UnitZ());
    EXPECT_EQ(hole.radius, expected[i].second);
    EXPECT_EQ(hole.depth, 41);
  }
}

TEST(AnalyticPartTruth, BoreSideOfARimFacesTheAxis) {
  const AnalyticPart& part = part_named("plate_with_holes_h1");
  ASSERT_EQ(part.holes.size(), 5u);
  int rims = 0, wrong = 0;
  for (const TrueEdge& edge : part.sharp_edges) {
    if (!edge.closed) continue;
    ++rims;
    const TrueEdgeSample& first = edge.samples.front();
    const auto hole = std::find_if(part.holes.begin(), part.holes.end(), [&](const TrueHole& h) {
      return std::abs((first.position - h.centre).head<2>().norm() - h.radius) < kOnEdge;
    });
    ASSERT_NE(hole, part.holes.end());
    for (const TrueEdgeSample& s : edge.samples) {
      // The face's normal is ±z, the bore's horizontal towards the axis.
      const bool top = s.position.z() == hole->centre.z();
      Vec3 toward_axis = hole->centre - s.position;
      toward_axis.z() = 0;
      const Vec3 face = top ? Vec3::UnitZ() : Vec3(-Vec3::UnitZ());
      wrong +=
          (top ? s.n_up : s.n_down) != face || ((top ? s.n_down : s.n_up) - toward_axis.normalized()).norm() > 1e-12;
    }
  }
  EXPECT_EQ(rims, 10);
  EXPECT_EQ(wrong, 0);
}

TEST(AnalyticPartTruth, BiconeRimAngleIsTwiceTheConeSlope) {
  const double r = 25, h = 37.5;
  const AnalyticPart& part = part_named("bicone_h2_5");
  ASSERT_EQ(part.sharp_edges.size(), 1u);
  const TrueEdge& rim = part.sharp_edges.front();
  EXPECT_TRUE(rim.closed);
  EXPECT_LT(worst_distance_from_circle(rim, r, h), 1e-12);
  const double expected = 2 * std::atan(h / r) * 180 / kPi;
  EXPECT_NEAR(worst_interior_angle_deg(rim, expected), expected, 1e-9);
  EXPECT_TRUE(part.holes.empty());
}

TEST(AnalyticPartTruth, HemisphereConeRimAngleIsRightAnglePlusConeSlope) {
  for (const auto& [name, h] : {std::pair{"hemisphere_cone_low_h2_5", 12.5}, {"hemisphere_cone_high_h2_5", 25.0}}) {
    const double r = 25;
    const AnalyticPart& part = part_named(name);
    ASSERT_EQ(part.sharp_edges.size(), 1u);
    const TrueEdge& rim = part.sharp_edges.front();
    EXPECT_LT(worst_distance_from_circle(rim, r, r), 1e-12) << name;
    const double expected = 90 + std::atan(h / r) * 180 / kPi;
    EXPECT_NEAR(worst_interior_angle_deg(rim, expected), expected, 1e-9) << name;
    for (const TrueEdgeSample& s : rim.samples) ASSERT_NEAR(s.n_down.z(), 0, 1e-15) << "the sphere's equator";
  }
}

TEST(AnalyticPartNoise, IsReproducibleBySeed) {
  const TriangleMesh& mesh = part_named("cube_h1").mesh;
  const TriangleMesh a = with_gaussian_noise(mesh, 0.05, 7), b = with_gaussian_noise(mesh, 0.05, 7);
  const TriangleMesh c = with_gaussian_noise(mesh, 0.05, 8);
  EXPECT_EQ(a.vertices, b.vertices);
  EXPECT_NE(a.vertices, c.vertices);
  EXPECT_EQ(a.faces, mesh.faces);
  EXPECT_EQ(a.vertex_normals.rows(), 0);
}

TEST(AnalyticPartNoise, DisplacesEveryCoordinateBySigma) {
  const TriangleMesh& mesh = part_named("cube_h1").mesh;
  const double sigma = 0.02;
  const Points displacement = with_gaussian_noise(mesh, sigma, 42).vertices - mesh.vertices;
  const double n = static_cast<double>(displacement.size());
  const double mean = displacement.sum() / n;
  const double std_dev = std::sqrt((displacement.array() - mean).square().sum() / (n - 1));
  EXPECT_NEAR(mean, 0, 3 * sigma / std::sqrt(n));
  EXPECT_NEAR(std_dev, sigma, 0.03 * sigma);
  for (int k = 0; k < 3; ++k) {
    const double axis_std = std::sqrt(displacement.col(k).array().square().mean());
    EXPECT_NEAR(axis_std, sigma, 0.03 * sigma) << "axis " << k;
  }
}

}  // namespace
}  // namespace cmm::geometry
