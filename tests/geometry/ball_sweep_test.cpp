// The ball sweep decides whether a probe move collides, so it is held to closed forms on hand-built
// contacts, to a loop over every face on the analytic parts, and to distances computed independently here.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "geometry/analytic_parts.hpp"
#include "geometry/ball_sweep.hpp"
#include "geometry/triangle_bvh.hpp"

namespace cmm::geometry {
namespace {

constexpr double kExact = 1e-9;  // mm
const double kSqrt2 = std::sqrt(2.0), kSqrt3 = std::sqrt(3.0);

TriangleMesh square(double size, const Vec3& offset = Vec3::Zero()) {  // [0, size]² in z = 0, normal +z
  TriangleMesh m;
  m.vertices.resize(4, 3);
  m.vertices << 0, 0, 0, size, 0, 0, size, size, 0, 0, size, 0;
  m.vertices.rowwise() += offset.transpose();
  m.faces.resize(2, 3);
  m.faces << 0, 1, 2, 0, 2, 3;
  return m;
}

TriangleMesh shifted(TriangleMesh m, const Vec3& offset) {
  m.vertices.rowwise() += offset.transpose();
  return m;
}

// Distances computed apart from the code under test: the triangle by its normal equations, else its edges.
double point_segment_distance(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double t = ab.squaredNorm() > 0 ? std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0) : 0.0;
  return (p - a - t * ab).norm();
}

double point_triangle_distance(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 u = b - a, v = c - a, w = p - a;
  const double uu = u.dot(u), uv = u.dot(v), vv = v.dot(v), wu = w.dot(u), wv = w.dot(v);
  const double det = uu * vv - uv * uv;
  if (det > 1e-12 * uu * vv) {
    const double s = (vv * wu - uv * wv) / det, t = (uu * wv - uv * wu) / det;
    if (s >= 0 && t >= 0 && s + t <= 1) return (w - s * u - t * v).norm();
  }
  return std::min({point_segment_distance(p, a, b), point_segment_distance(p, b, c), point_segment_distance(p, c, a)});
}

// Faces bounded by balls as plain numbers, so that the checks below skip far faces cheaply even in the
// Debug + sanitizer build.
class IndependentDistance {
 public:
  explicit IndependentDistance(const TriangleMesh& mesh) : mesh_(mesh) {
    for (int f = 0; f < mesh.faces.rows(); ++f) {
      double half2 = 0;
      for (int k = 0; k < 3; ++k) {
        const double a = mesh.vertices(mesh.faces(f, 0), k), b = mesh.vertices(mesh.faces(f, 1), k),
                     c = mesh.vertices(mesh.faces(f, 2), k);
        const double lo = std::min({a, b, c}), hi = std::max({a, b, c});
        balls_.push_back((lo + hi) / 2);
        half2 += (hi - lo) * (hi - lo) / 4;
      }
      balls_.push_back(std::sqrt(half2));
    }
  }

  // Faces that may come within `reach` of segment a..b.
  std::vector<int> near_segment(const Vec3& a, const Vec3& b, double reach) const {
    const double ab[3] = {b.x() - a.x(), b.y() - a.y(), b.z() - a.z()}, start[3] = {a.x(), a.y(), a.z()};
    const double length2 = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2];
    const double* ball = balls_.data();
    std::vector<int> faces;
    for (int f = 0; f < mesh_.faces.rows(); ++f, ball += 4) {
      const double ac[3] = {ball[0] - start[0], ball[1] - start[1], ball[2] - start[2]};
      const double dot = ac[0] * ab[0] + ac[1] * ab[1] + ac[2] * ab[2];
      const double along = dot <= 0 ? 0.0 : dot >= length2 ? 1.0 : dot / length2;
      double gap2 = 0;
      for (int k = 0; k < 3; ++k) gap2 += (ac[k] - along * ab[k]) * (ac[k] - along * ab[k]);
      if (gap2 <= (reach + ball[3]) * (reach + ball[3])) faces.push_back(f);
    }
    return faces;
  }

  // Distance from p to the mesh if it is below `reach`, else something at least `reach`.
  double distance(const Vec3& p, const std::vector<int>& faces, double reach) const {
    const double at[3] = {p.x(), p.y(), p.z()};
    double best = std::numeric_limits<double>::infinity();
    for (int f : faces) {
      const double* ball = balls_.data() + 4 * f;
      const double gap2 = (ball[0] - at[0]) * (ball[0] - at[0]) + (ball[1] - at[1]) * (ball[1] - at[1]) +
                          (ball[2] - at[2]) * (ball[2] - at[2]);
      if (gap2 >= (reach + ball[3]) * (reach + ball[3])) continue;
      best = std::min(best, point_triangle_distance(p, corner(f, 0), corner(f, 1), corner(f, 2)));
    }
    return best;
  }

  TriangleMesh submesh(const std::vector<int>& faces) const {
    TriangleMesh m{mesh_.vertices, Triangles(static_cast<Eigen::Index>(faces.size()), 3), Points(0, 3)};
    for (std::size_t i = 0; i < faces.size(); ++i) m.faces.row(static_cast<Eigen::Index>(i)) = mesh_.faces.row(faces[i]);
    return m;
  }

 private:
  Vec3 corner(int f, int k) const { return vertex(mesh_, mesh_.faces(f, k)); }

  const TriangleMesh& mesh_;
  std::vector<double> balls_;  // per face: centre and radius of a ball around its box
};

// Each analytic part is meshed and swept once for the whole file.
struct Part {
  explicit Part(TriangleMesh m) : mesh(std::move(m)), sweeper(mesh), independent(mesh) {}
  Part(const Part&) = delete;
  TriangleMesh mesh;
  BallSweeper sweeper;
  IndependentDistance independent;
};

const Part& cube() {
  static const Part part(make_cube(40, 2).mesh);
  return part;
}
const Part& case3_block() {
  static const Part part(make_case3_block(2).mesh);
  return part;
}
const Part& hemisphere_cone() {
  static const Part part(make_hemisphere_cone(25, 25, 1).mesh);
  return part;
}

TEST(BallSweep, DropOntoSquareHitsItsInteriorAtTheExactTravel) {
  const BallSweeper sweeper(square(10));
  const auto hit = sweeper.first_hit(Vec3(3, 4, 5), Vec3(0, 0, -1), 100, 1);
  ASSERT_TRUE(hit);
  EXPECT_DOUBLE_EQ(hit->travel, 4);
  EXPECT_TRUE(hit->centre.isApprox(Vec3(3, 4, 1)));
  EXPECT_LT((hit->contact - Vec3(3, 4, 0)).norm(), kExact);
  EXPECT_EQ(hit->feature, ContactFeature::face);
  EXPECT_GE(hit->face, 0);
  // From below as well: faces are two-sided.
  const auto below = sweeper.first_hit(Vec3(6, 2, -5), Vec3(0, 0, 2), 100, 0.5);
  ASSERT_TRUE(below);
  EXPECT_NEAR(below->travel, 4.5, kExact);
}

TEST(BallSweep, DiagonalOntoCubeEdgeTouchesTheEdge) {
  const BallSweeper& sweeper = cube().sweeper;
  // Moving along (−1, 0, −1)/√2, the centre is 10√2 − travel from the edge x = z = 40, and until it
  // reaches the edge its foot on the top face lies beyond that face.
  const auto hit = sweeper.first_hit(Vec3(50, 20.3, 50), Vec3(-1, 0, -1), 100, 2);
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->travel, 10 * kSqrt2 - 2, kExact);
  EXPECT_LT((hit->contact - Vec3(40, 20.3, 40)).norm(), kExact);
  EXPECT_EQ(hit->feature, ContactFeature::edge);
}

TEST(BallSweep, DiagonalOntoCubeCornerTouchesTheVertex) {
  const BallSweeper& sweeper = cube().sweeper;
  const auto hit = sweeper.first_hit(Vec3(50, 50, 50), Vec3(-1, -1, -1), 100, 2);
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->travel, 10 * kSqrt3 - 2, kExact);
  EXPECT_LT((hit->contact - Vec3(40, 40, 40)).norm(), kExact);
  EXPECT_EQ(hit->feature, ContactFeature::vertex);
}

TEST(BallSweep, ParallelToAnEdgeHitsTheCornerAtItsEnd) {
  const BallSweeper& sweeper = cube().sweeper;
  // Centre 1 mm outside both faces at the edge x = z = 40, moving along it: the corner (40, 0, 40) is
  // the closest point until contact, at distance √(1 + 1 + y²) = 2.
  const auto hit = sweeper.first_hit(Vec3(41, -10, 41), Vec3(0, 1, 0), 100, 2);
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->travel, 10 - kSqrt2, kExact);
  EXPECT_LT((hit->contact - Vec3(40, 0, 40)).norm(), kExact);
  EXPECT_EQ(hit->feature, ContactFeature::vertex);
  // Sliding along the edge at exactly the radius touches it all the way and is no hit.
  const double off = 40 + kSqrt2;
  EXPECT_FALSE(sweeper.first_hit(Vec3(off, -10, off), Vec3(0, 1, 0), 100, 2));
}

TEST(BallSweep, StartOverlappingReturnsTravelZeroWithTheClosestPoint) {
  const BallSweeper sweeper(square(10));
  for (const Vec3& direction : {Vec3(0, 0, -1), Vec3(0, 0, 1), Vec3(1, 0, 0)}) {
    const auto hit = sweeper.first_hit(Vec3(3, 4, 0.5), direction, 100, 1);
    ASSERT_TRUE(hit);
    EXPECT_EQ(hit->travel, 0);
    EXPECT_EQ(hit->centre, Vec3(3, 4, 0.5));
    EXPECT_LT((hit->contact - Vec3(3, 4, 0)).norm(), kExact);
    EXPECT_EQ(hit->feature, ContactFeature::face);
  }
  // Overlapping an edge only.
  const auto edge = sweeper.first_hit(Vec3(10.5, 5, 0), Vec3(1, 0, 0), 100, 1);
  ASSERT_TRUE(edge);
  EXPECT_EQ(edge->travel, 0);
  EXPECT_EQ(edge->feature, ContactFeature::edge);
}

TEST(BallSweep, StartTouchingHitsOnlyWhenMovingIn) {
  const BallSweeper sweeper(square(10));
  const auto in = sweeper.first_hit(Vec3(3, 4, 1), Vec3(0, 0.1, -1), 100, 1);
  ASSERT_TRUE(in);
  EXPECT_EQ(in->travel, 0);
  EXPECT_EQ(in->feature, ContactFeature::face);
  EXPECT_FALSE(sweeper.first_hit(Vec3(3, 4, 1), Vec3(0, 0.1, 1), 100, 1));
  EXPECT_FALSE(sweeper.first_hit(Vec3(3, 4, 1 - 0.5 * kSweepTouch), Vec3(0, 0, 1), 100, 1));
  // Touching a corner sphere and leaving it.
  EXPECT_FALSE(sweeper.first_hit(Vec3(11, 0, 0), Vec3(1, 1, 0), 100, 1));
}

TEST(BallSweep, GrazingAlongAFaceIsNoHitButAnyDipIs) {
  const BallSweeper sweeper(square(10));
  // Across both triangles and their shared diagonal, at exactly the radius and a little inside the touch band.
  EXPECT_FALSE(sweeper.first_hit(Vec3(-5, 3, 1), Vec3(1, 0, 0), 20, 1));
  EXPECT_FALSE(sweeper.first_hit(Vec3(-5, 3, 1 - 0.5 * kSweepTouch), Vec3(1, 0, 0), 20, 1));
  EXPECT_FALSE(sweeper.first_hit(Vec3(-5, -5, 1), Vec3(1, 1, 0), 30, 1));
  // 1 µm lower it catches the square's edge x = 0, √(1 − h²) before reaching it.
  const double h = 1 - 1e-6;
  const auto hit = sweeper.first_hit(Vec3(-5, 3, h), Vec3(1, 0, 0), 20, 1);
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->travel, 5 - std::sqrt(1 - h * h), kExact);
  EXPECT_LT((hit->contact - Vec3(0, 3, 0)).norm(), kExact);
  EXPECT_EQ(hit->feature, ContactFeature::edge);
  // Over a whole cube face, across its many inner edges and corners.
  EXPECT_FALSE(cube().sweeper.first_hit(Vec3(-3, 13.7, 42), Vec3(1, 0.3, 0), 60, 2));
}

TEST(BallSweep, EndingJustTouchingIsNoHit) {
  const BallSweeper sweeper(square(10));
  EXPECT_FALSE(sweeper.first_hit(Vec3(3, 4, 5), Vec3(0, 0, -1), 4, 1));
  const auto past = sweeper.first_hit(Vec3(3, 4, 5), Vec3(0, 0, -1), 4 + 1e-6, 1);
  ASSERT_TRUE(past);
  EXPECT_DOUBLE_EQ(past->travel, 4);
  EXPECT_FALSE(sweeper.first_hit(Vec3(3, 4, 5), Vec3(0, 0, -1), 3.9, 1));
}

TEST(BallSweep, LongTravelAndMetreCoordinatesKeepNanometres) {
  const BallSweeper sweeper(square(10));
  const auto far = sweeper.first_hit(Vec3(3, 4, 1e5), Vec3(0, 0, -1), std::numeric_limits<double>::infinity(), 1);
  ASSERT_TRUE(far);
  EXPECT_NEAR(far->travel, 1e5 - 1, kExact);

  const Vec3 offset(1234.5, -987.25, 1000.125);
  const BallSweeper moved(shifted(cube().mesh, offset));
  const auto edge = moved.first_hit(offset + Vec3(50, 20.3, 50), Vec3(-1, 0, -1), 100, 2);
  ASSERT_TRUE(edge);
  EXPECT_NEAR(edge->travel, 10 * kSqrt2 - 2, kExact);
  EXPECT_LT((edge->contact - offset - Vec3(40, 20.3, 40)).norm(), kExact);
  const auto corner = moved.first_hit(offset + Vec3(50, 50, 50), Vec3(-1, -1, -1), 100, 2);
  ASSERT_TRUE(corner);
  EXPECT_NEAR(corner->travel, 10 * kSqrt3 - 2, kExact);
  // A shallow approach: 1 in 1000 down onto a square at 1 m, far from its origin.
  const BallSweeper big(square(2000, Vec3(-1000, -1000, 1000)));
  const Vec3 direction = Vec3(1000, 0, -1).normalized();
  const auto shallow = big.first_hit(Vec3(-900, 200, 1003), direction, 5000, 1.5);
  ASSERT_TRUE(shallow);
  EXPECT_NEAR(shallow->travel, 1.5 / -direction.z(), kExact);
  EXPECT_NEAR(shallow->centre.z() - 1000, 1.5, kExact);
}

TEST(BallSweep, DegenerateFacesAreTouchedOnTheirEdgesAndCorners) {
  TriangleMesh m = square(10);
  m.vertices.conservativeResize(7, 3);
  m.vertices.bottomRows(3) << 0, 0, 5, 10, 0, 5, 6, 0, 5;  // three points on one line
  m.faces.conservativeResize(4, 3);
  m.faces.bottomRows(2) << 4, 5, 6, 5, 5, 4;  // zero area: collinear corners, then a repeated corner
  const BallSweeper sweeper(m);
  const auto hit = sweeper.first_hit(Vec3(3, 0, 8), Vec3(0, 0, -1), 100, 1);
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->travel, 2, kExact);
  EXPECT_GE(hit->face, 2);
  EXPECT_LT((hit->contact - Vec3(3, 0, 5)).norm(), kExact);
  EXPECT_EQ(hit->feature, ContactFeature::edge);
  // Side on, along the line of the degenerate faces: its end is a corner.
  const auto end = sweeper.first_hit(Vec3(-10, 0, 5), Vec3(1, 0, 0), 100, 1);
  ASSERT_TRUE(end);
  EXPECT_NEAR(end->travel, 9, kExact);
  EXPECT_EQ(end->feature, ContactFeature::vertex);
}

TEST(BallSweep, EmptyMeshHasNothingToHit) {
  const BallSweeper sweeper(TriangleMesh{});
  EXPECT_FALSE(sweeper.first_hit(Vec3::Zero(), Vec3::UnitX(), 10, 1));
  EXPECT_FALSE(first_hit_brute_force(TriangleMesh{}, Vec3::Zero(), Vec3::UnitX(), 10, 1));
  EXPECT_EQ(sweeper.closest_to_point(Vec3::Zero()).face, -1);
  EXPECT_TRUE(std::isinf(sweeper.closest_to_segment(Vec3::Zero(), Vec3::UnitX()).distance));
}

TEST(BallSweep, RefusesBadArguments) {
  const BallSweeper sweeper(square(10));
  EXPECT_THROW(sweeper.first_hit(Vec3::Zero(), Vec3::Zero(), 1, 1), std::invalid_argument);
  EXPECT_THROW(sweeper.first_hit(Vec3::Zero(), Vec3::UnitX(), -1, 1), std::invalid_argument);
  EXPECT_THROW(sweeper.first_hit(Vec3::Zero(), Vec3::UnitX(), 1, 0), std::invalid_argument);
  TriangleMesh broken = square(10);
  broken.faces(1, 2) = 4;
  EXPECT_THROW(BallSweeper{broken}, std::invalid_argument);
}

TEST(TriangleBvh, EveryFaceSitsInOneLeafInsideEveryBoxAboveIt) {
  const TriangleMesh& mesh = cube().mesh;
  const TriangleBvh tree(mesh);
  const auto& nodes = tree.nodes();
  std::vector<int> seen(mesh.faces.rows(), 0);
  std::vector<int> depth(nodes.size(), 0);
  auto contains = [](const TriangleBvh::Node& n, const Vec3& lo, const Vec3& hi) {
    bool inside = true;
    for (int k = 0; k < 3; ++k) inside = inside && n.lo[k] <= lo[k] && n.hi[k] >= hi[k];
    return inside;
  };
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    const TriangleBvh::Node& n = nodes[i];
    if (n.count > 0) {
      for (int f : tree.leaf_faces(n)) {
        ++seen[f];
        for (int k = 0; k < 3; ++k) EXPECT_TRUE(contains(n, vertex(mesh, mesh.faces(f, k)), vertex(mesh, mesh.faces(f, k))));
      }
      continue;
    }
    for (int child : {n.first, n.first + 1}) {
      ASSERT_GT(child, static_cast<int>(i));
      EXPECT_TRUE(contains(n, nodes[child].lo.cast<double>(), nodes[child].hi.cast<double>()));
      depth[child] = depth[i] + 1;
      EXPECT_LE(depth[child], TriangleBvh::kMaxDepth);
    }
  }
  EXPECT_TRUE(std::all_of(seen.begin(), seen.end(), [](int s) { return s == 1; }));
}

struct PartCase {
  std::string name;
  const Part& (*part)();
};

class RandomSweeps : public testing::TestWithParam<PartCase> {};

// Random moves, half of them aimed at the surface, against the loop over every face near the path; every
// answer is also checked on distances computed here: the mesh is exactly `radius` away at the contact,
// farther just before, and never closer than radius − kSweepTouch anywhere before it (or on a free move).
TEST_P(RandomSweeps, MatchBruteForceAndIndependentDistances) {
  const auto& [mesh, sweeper, independent] = GetParam().part();
  const Vec3 lo = mesh.vertices.colwise().minCoeff().transpose(), hi = mesh.vertices.colwise().maxCoeff().transpose();
  std::mt19937_64 random(7);
  std::uniform_real_distribution<double> unit(0, 1);
  auto uniform = [&](double a, double b) { return a + (b - a) * unit(random); };
  auto random_direction = [&] {
    std::normal_distribution<double> normal;
    return Vec3(normal(random), normal(random), normal(random)).normalized();
  };

  int hits = 0, free = 0, overlaps = 0;
  for (int trial = 0; trial < 32; ++trial) {
    const double radius = uniform(0.5, 5), max_travel = uniform(1, 25);
    Vec3 start, direction;
    if (trial % 2 == 0) {
      start = Vec3(uniform(lo.x() - 8, hi.x() + 8), uniform(lo.y() - 8, hi.y() + 8), uniform(lo.z() - 8, hi.z() + 8));
      direction = random_direction();
    } else {
      const int f = static_cast<int>(uniform(0, static_cast<double>(mesh.faces.rows()) - 1));
      const Vec3 target = vertex(mesh, mesh.faces(f, 0));
      start = target + uniform(0, 15) * random_direction();
      direction = (target - start + 0.5 * random_direction()).normalized();
    }
    SCOPED_TRACE("trial " + std::to_string(trial));

    const Vec3 end = start + max_travel * direction;
    const std::vector<int> near = independent.near_segment(start, end, radius + 1e-3);
    const auto hit = sweeper.first_hit(start, direction, max_travel, radius);
    const auto reference = first_hit_brute_force(independent.submesh(near), start, direction, max_travel, radius);
    ASSERT_EQ(hit.has_value(), reference.has_value());
    auto distance_at = [&](double t) { return independent.distance(start + t * direction, near, radius + 1e-3); };

    if (hit && hit->travel == 0) {
      EXPECT_EQ(reference->travel, 0);
      EXPECT_LE(distance_at(0), radius + kExact);
      EXPECT_NEAR((hit->contact - start).norm(), distance_at(0), kExact);
      ++overlaps;
      continue;
    }
    const double free_until = hit ? hit->travel : max_travel;
    for (int i = 0; i <= 12; ++i) {
      const double t = free_until * i / 12;
      EXPECT_GE(distance_at(t), radius - kSweepTouch) << "at travel " << t;
    }
    if (!hit) {
      ++free;
      continue;
    }
    ++hits;
    EXPECT_NEAR(hit->travel, reference->travel, 1e-12);
    EXPECT_NEAR((hit->contact - hit->centre).norm(), radius, kExact);
    EXPECT_NEAR(distance_at(hit->travel), radius, kExact);
    if (hit->travel > 1e-7) {
      EXPECT_GT(distance_at(hit->travel - 1e-7), radius);
    }
    EXPECT_LT(point_triangle_distance(hit->contact, vertex(mesh, mesh.faces(hit->face, 0)),
                                      vertex(mesh, mesh.faces(hit->face, 1)), vertex(mesh, mesh.faces(hit->face, 2))),
              kExact);
  }
  // The mix must exercise all three outcomes to mean anything.
  EXPECT_GT(hits, 8);
  EXPECT_GT(free, 4);
  EXPECT_GT(overlaps, 0);
}

// Closest points against the same independent distances, at points and along segments near the part.
TEST_P(RandomSweeps, ClosestPointsMatchIndependentDistances) {
  const auto& [mesh, sweeper, independent] = GetParam().part();
  std::vector<int> all(mesh.faces.rows());
  for (int f = 0; f < static_cast<int>(all.size()); ++f) all[f] = f;
  std::mt19937_64 random(11);
  std::uniform_real_distribution<double> unit(-1, 1);
  auto offset = [&](double size) {
    Vec3 v;
    for (int k = 0; k < 3; ++k) v[k] = size * unit(random);
    return v;
  };
  for (int trial = 0; trial < 8; ++trial) {
    const Vec3 p = vertex(mesh, static_cast<int>((unit(random) + 1) / 2 * (mesh.vertices.rows() - 1))) + offset(3);
    const BallSweeper::Closest closest = sweeper.closest_to_point(p);
    // Looking only a little past the answer still finds any closer face the sweeper missed.
    EXPECT_NEAR(closest.distance, independent.distance(p, all, closest.distance + 1e-6), kExact);
    EXPECT_NEAR((closest.point - p).norm(), closest.distance, kExact);

    // Along a segment, the distance is attained at the returned point, is no more than at any sample,
    // and no less than that less half the spacing (it changes no faster than the point moves).
    const Vec3 q = p + offset(2);
    const BallSweeper::Closest along = sweeper.closest_to_segment(p, q);
    EXPECT_NEAR(independent.distance(along.point, all, kExact), 0, kExact);
    EXPECT_NEAR(point_segment_distance(along.point, p, q), along.distance, kExact);
    const std::vector<int> near = independent.near_segment(p, q, closest.distance + kExact);
    double sampled = closest.distance;
    for (int i = 1; i <= 40; ++i) sampled = std::min(sampled, independent.distance(p + (q - p) * i / 40.0, near, sampled + kExact));
    EXPECT_LE(along.distance, sampled + kExact);
    EXPECT_GE(along.distance, sampled - 0.5 * (q - p).norm() / 40 - kExact);

    // Bounded searches: just past the answer they find it, just short of it nothing.
    for (const auto& [bounded, exact] :
         {std::pair{sweeper.closest_to_point(p, closest.distance + 1e-9), closest},
          std::pair{sweeper.closest_to_segment(p, q, along.distance + 1e-9), along}}) {
      EXPECT_NEAR(bounded.distance, exact.distance, kExact);
      EXPECT_GE(bounded.face, 0);
    }
    for (const BallSweeper::Closest& none :
         {sweeper.closest_to_point(p, closest.distance - 1e-6), sweeper.closest_to_segment(p, q, along.distance - 1e-6)}) {
      EXPECT_EQ(none.face, -1);
      EXPECT_TRUE(std::isinf(none.distance));
    }
  }
}

INSTANTIATE_TEST_SUITE_P(AnalyticParts, RandomSweeps,
                         testing::Values(PartCase{"cube", cube}, PartCase{"case3_block", case3_block},
                                         PartCase{"hemisphere_cone", hemisphere_cone}),
                         [](const testing::TestParamInfo<PartCase>& info) { return info.param.name; });

}  // namespace
}  // namespace cmm::geometry
