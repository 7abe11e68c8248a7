// A hole seen from its wall: the plate's Ø12 bore with its wall cut off at a depth that varies round it
// (as a scan that looked part way down leaves it) is found from that border loop, with the wall's
// circle, axis, entry and seen depth; a rim loop lying in the top face (no wall) is not a wall's.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>

#include "geometry/analytic_parts.hpp"
#include "geometry/boundary_loops.hpp"
#include "geometry/feature_model.hpp"
#include "geometry/wall_hole.hpp"

namespace cmm::geometry {
namespace {

const Vec3 kCentre(70, 25, 0);  // the plate's Ø12 hole at (70, 25), 10 mm deep
constexpr double kRadius = 6;

// The seen depth below the top at angle θ round the hole: 3 to 7 mm.
double seen_depth(const Vec3& p) { return 5 + 2 * std::sin(std::atan2(p.y() - kCentre.y(), p.x() - kCentre.x())); }

// The mesh without the facets `drop` names by centroid and normal, as a scan that did not see them.
template <class Drop>
TriangleMesh without(TriangleMesh mesh, Drop drop) {
  const FaceGeometry faces = face_geometry(mesh);
  Triangles kept(mesh.faces.rows(), 3);
  Eigen::Index count = 0;
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
    if (!drop(face_centroid(mesh, static_cast<int>(f)), Vec3(faces.normals.row(f).transpose()))) kept.row(count++) = mesh.faces.row(f);
  kept.conservativeResize(count, 3);
  mesh.faces = kept;
  return mesh;
}

// The plate without its underside and with the Ø12 wall below the seen depth; `keep_wall` false drops
// that wall entirely (the scan never saw it). With `notch`, the scan also missed the wall and 1 mm of
// the top face over 20° of the rim: its crease is no closed curve, only the wall says it is a hole.
TriangleMesh seen_plate(bool keep_wall, double noise_mm, bool notch = false) {
  TriangleMesh mesh = make_plate_with_holes(0.4).mesh;
  if (noise_mm > 0) mesh = with_gaussian_noise(mesh, noise_mm, 20261206);
  return without(mesh, [&](const Vec3& c, const Vec3& n) {
    const double from_axis = std::hypot(c.x() - kCentre.x(), c.y() - kCentre.y());
    const bool underside = c.z() < 0.3 && n.z() < -0.7;
    const bool this_wall = std::abs(from_axis - kRadius) < 0.3 && std::abs(n.z()) < 0.7;
    const bool notched = notch && std::abs(std::atan2(c.y() - kCentre.y(), c.x() - kCentre.x())) < 10 * std::numbers::pi / 180 &&
                         (this_wall || (n.z() > 0.7 && from_axis < kRadius + 1));
    return underside || notched || (this_wall && (!keep_wall || c.z() < 10 - seen_depth(c)));
  });
}

// The hole loop nearest the Ø12 hole's axis.
BoundaryLoop loop_round_the_hole(const TriangleMesh& mesh) {
  const EdgeAdjacency adjacency = edge_adjacency(mesh);
  BoundaryLoop best;
  double nearest = 1e300;
  for (const BoundaryLoop& loop : boundary_loops(mesh, adjacency)) {
    Vec3 centre = Vec3::Zero();
    for (int v : loop.vertices) centre += vertex(mesh, v) / static_cast<double>(loop.vertices.size());
    const double off = std::hypot(centre.x() - kCentre.x(), centre.y() - kCentre.y());
    if (off < nearest) nearest = off, best = loop;
  }
  return best;
}

TEST(WallHole, APartlySeenWallGivesItsCircleAxisEntryAndSeenDepth) {
  for (const double noise : {0.0, 0.02}) {
    const TriangleMesh mesh = seen_plate(true, noise);
    const BoundaryLoop loop = loop_round_the_hole(mesh);
    const auto hole = wall_hole(mesh, edge_adjacency(mesh), face_geometry(mesh), loop, 0.05);
    ASSERT_TRUE(hole) << "noise " << noise;
    EXPECT_GT(hole->axis.z(), 0.999) << "out of the material at the entry";
    EXPECT_NEAR(hole->radius, kRadius, 0.01 * kRadius) << "noise " << noise;
    EXPECT_LT(std::hypot(hole->entry_centre.x() - kCentre.x(), hole->entry_centre.y() - kCentre.y()), 0.05) << "noise " << noise;
    EXPECT_NEAR(hole->entry_centre.z(), 10, 0.4) << "noise " << noise;
    EXPECT_NEAR(hole->seen_depth_mm, 7, 0.5) << "noise " << noise;
  }
}

// The plate without its underside and with the wall of the hole of `radius` round `centre` seen down to
// seen(θ) below the top (θ round the axis from +x), as a scan's views left it.
template <class Seen>
TriangleMesh plate_with_wall_seen(const Vec3& centre, double radius, double noise, Seen seen) {
  TriangleMesh mesh = make_plate_with_holes(0.4).mesh;
  if (noise > 0) mesh = with_gaussian_noise(mesh, noise, 20261207);
  return without(mesh, [&](const Vec3& c, const Vec3& n) {
    const bool this_wall = std::hypot(c.x() - centre.x(), c.y() - centre.y()) < radius + 0.3 && std::abs(n.z()) < 0.7;
    return (c.z() < 0.3 && n.z() < -0.7) || (this_wall && c.z() < 10 - seen(std::atan2(c.y() - centre.y(), c.x() - centre.x())));
  });
}

// The wall hole of a loop round the axis through `centre` (its vertices' mean within `within` of it).
std::optional<WallHole> wall_hole_near(const TriangleMesh& mesh, const Vec3& centre, double within) {
  const EdgeAdjacency adjacency = edge_adjacency(mesh);
  for (const BoundaryLoop& loop : boundary_loops(mesh, adjacency)) {
    Vec3 mean = Vec3::Zero();
    for (int v : loop.vertices) mean += vertex(mesh, v) / static_cast<double>(loop.vertices.size());
    if (std::hypot(mean.x() - centre.x(), mean.y() - centre.y()) < within)
      if (auto hole = wall_hole(mesh, adjacency, face_geometry(mesh), loop, 0.05)) return hole;
  }
  return std::nullopt;
}

// The Ø6 hole at (100, 20) as one grazing view leaves it: its wall seen on the +x half only, 7 mm down
// where the view looked straight in and up to the rim at ±y, the −x half not at all. The loop runs along
// the rim on one side and deep down the wall on the other: deeper than the hole is wide, so neither the
// loop's spread nor its facets' normals show the axis (the merged partial views of the plate at σ ε/4).
TEST(WallHole, AWallSeenOnOneSideDeeperThanTheHoleIsWide) {
  const Vec3 centre(100, 20, 0);
  for (const double noise : {0.0, 0.02}) {
    const TriangleMesh mesh = plate_with_wall_seen(centre, 3, noise, [](double angle) { return 7 * std::cos(angle); });
    const std::optional<WallHole> hole = wall_hole_near(mesh, centre, 3);
    ASSERT_TRUE(hole) << "noise " << noise;
    EXPECT_GT(hole->axis.z(), 0.999) << "noise " << noise;
    EXPECT_NEAR(hole->radius, 3, 0.02 * 3) << "noise " << noise;
    EXPECT_LT(std::hypot(hole->entry_centre.x() - centre.x(), hole->entry_centre.y() - centre.y()), 0.05) << "noise " << noise;
    EXPECT_NEAR(hole->entry_centre.z(), 10, 0.4) << "noise " << noise;
  }
}

// The Ø8 hole at (100, 60) as the merged partial views left it: its wall seen 5.5 to 9.5 mm down over two
// thirds of the way round, not at all over the last third. The loop runs along the rim there only and
// straight down the wall at either end of it.
TEST(WallHole, AWallSeenDeepTwoThirdsOfTheWayRound) {
  const Vec3 centre(100, 60, 0);
  for (const double noise : {0.0, 0.02}) {
    const TriangleMesh mesh = plate_with_wall_seen(centre, 4, noise, [](double angle) {
      return std::cos(angle) > -0.5 ? 7.5 + 2 * std::sin(3 * angle) : 0.0;
    });
    const std::optional<WallHole> hole = wall_hole_near(mesh, centre, 4);
    ASSERT_TRUE(hole) << "noise " << noise;
    EXPECT_GT(hole->axis.z(), 0.999) << "noise " << noise;
    EXPECT_NEAR(hole->radius, 4, 0.02 * 4) << "noise " << noise;
    EXPECT_LT(std::hypot(hole->entry_centre.x() - centre.x(), hole->entry_centre.y() - centre.y()), 0.05) << "noise " << noise;
  }
}

TEST(WallHole, ARimLoopInTheTopFaceIsNoWalls) {
  const TriangleMesh mesh = seen_plate(false, 0);
  const BoundaryLoop loop = loop_round_the_hole(mesh);
  EXPECT_FALSE(wall_hole(mesh, edge_adjacency(mesh), face_geometry(mesh), loop, 0.05));
}

// Through the feature model: the noisy plate's hole, its rim crease broken by the notch, is a bore with
// its rim points on the entry circle, and one hole only.
TEST(WallHole, TheFeatureModelMeasuresItAsABore) {
  const FeatureModel model = extract_features(seen_plate(true, 0.02, true), {});
  int found = 0;
  for (const Hole& hole : model.holes) {
    if (std::hypot(hole.centre.x() - kCentre.x(), hole.centre.y() - kCentre.y()) > 0.2) continue;
    ++found;
    EXPECT_EQ(hole.source, HoleSource::bore);
    EXPECT_NEAR(hole.radius, kRadius, 0.02 * kRadius);
    EXPECT_GE(hole.rim_point_ids.size(), 10u);
    for (int id : hole.rim_point_ids) {
      const Vec3 p = model.points[static_cast<std::size_t>(id)].position;
      EXPECT_NEAR(std::hypot(p.x() - kCentre.x(), p.y() - kCentre.y()), kRadius, 0.4);
      EXPECT_NEAR(p.z(), 10, 0.4);
    }
  }
  EXPECT_EQ(found, 1);
}

// Where the rim is a closed crease that fits badly and the wall well, the wall's circle is the hole's:
// the rim 0.4 mm out of round (three lobes) and 0.1 mm off the axis, as a small noisy rim's crease
// points lie, over a wall tapering 1° (so its draft keeps the bore from taking its wall's circle).
TEST(WallHole, TheRounderOfTheRimsAndTheWallsCirclesIsTheHoles) {
  // Seen 6 mm down all round: a tapered wall seen deeper on one side would pull its circle that way.
  TriangleMesh mesh = without(make_plate_with_holes(0.4).mesh, [&](const Vec3& c, const Vec3& n) {
    const bool this_wall = std::abs(std::hypot(c.x() - kCentre.x(), c.y() - kCentre.y()) - kRadius) < 0.3 && std::abs(n.z()) < 0.7;
    return (c.z() < 0.3 && n.z() < -0.7) || (this_wall && c.z() < 4);
  });
  const double taper = std::tan(std::numbers::pi / 180);
  for (Eigen::Index v = 0; v < mesh.vertices.rows(); ++v) {
    const Vec3 p = vertex(mesh, v);
    const double from_axis = std::hypot(p.x() - kCentre.x(), p.y() - kCentre.y()), angle = std::atan2(p.y() - kCentre.y(), p.x() - kCentre.x());
    if (std::abs(from_axis - kRadius) > 1e-6 || p.z() < 1e-6) continue;
    const double radius = std::abs(p.z() - 10) < 1e-6 ? kRadius + 0.2 * std::sin(3 * angle) : kRadius - taper * (10 - p.z());
    const Vec3 shift = std::abs(p.z() - 10) < 1e-6 ? Vec3(0.1, 0, 0) : Vec3::Zero();
    mesh.vertices.row(v) = (kCentre + Vec3(radius * std::cos(angle), radius * std::sin(angle), p.z()) + shift).transpose();
  }
  const FeatureModel model = extract_features(mesh, {});
  int found = 0;
  for (const Hole& hole : model.holes) {
    if (std::hypot(hole.centre.x() - kCentre.x(), hole.centre.y() - kCentre.y()) > 0.3) continue;
    ++found;
    EXPECT_LT(std::hypot(hole.centre.x() - kCentre.x(), hole.centre.y() - kCentre.y()), 0.02);
    EXPECT_NEAR(hole.radius, kRadius - 3 * taper, 0.02) << "the wall's circle halfway down its seen depth";
    EXPECT_LT(hole.roundness_mm, 0.2);
  }
  EXPECT_EQ(found, 1);
}

}  // namespace
}  // namespace cmm::geometry
