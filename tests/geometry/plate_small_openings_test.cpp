// The plate with small true openings (a Ø3 hole and a 2 × 10 mm slot) that the scan front end must keep
// open: its meshes are closed, manifold, outward, of genus 7, and its slot's rims are exact.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <numeric>
#include <string>
#include <utility>
#include <vector>

#include "geometry/analytic_parts.hpp"

namespace cmm::geometry {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr int kThroughOpenings = 7;  // the plate's five holes, the Ø3 hole and the slot

// The slot: half circles of radius 1 centred at (36, 10) and (44, 10).
double slot_distance(double x, double y) { return std::hypot(x - std::clamp(x, 36.0, 44.0), y - 10) - 1; }

// Directed edges counted; a closed manifold consistently oriented surface has each exactly once, its
// reverse exactly once, and forms one piece with Euler characteristic 2 − 2 genus.
struct Topology {
  int defects = 0, components = 0;
  long euler = 0;
};

Topology topology(const TriangleMesh& mesh) {
  std::vector<std::pair<int, int>> directed;
  for (int f = 0; f < mesh.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) directed.emplace_back(mesh.faces(f, k), mesh.faces(f, (k + 1) % 3));
  std::sort(directed.begin(), directed.end());
  const auto count = [&](int a, int b) {
    const auto range = std::equal_range(directed.begin(), directed.end(), std::pair{a, b});
    return range.second - range.first;
  };
  Topology t;
  std::vector<int> root(mesh.vertices.rows());
  std::iota(root.begin(), root.end(), 0);
  const auto find = [&](int v) {
    while (root[v] != v) v = root[v] = root[root[v]];
    return v;
  };
  long undirected = 0;
  for (const auto& [a, b] : directed) {
    t.defects += count(a, b) != 1 || count(b, a) != 1;
    undirected += a < b;
    root[find(a)] = find(b);
  }
  for (int v = 0; v < static_cast<int>(root.size()); ++v) t.components += find(v) == v;
  t.euler = mesh.vertices.rows() - undirected + mesh.faces.rows();
  return t;
}

double signed_volume(const TriangleMesh& m) {
  double six = 0;
  for (int f = 0; f < m.faces.rows(); ++f) {
    const Vec3 a = vertex(m, m.faces(f, 0)), b = vertex(m, m.faces(f, 1)), c = vertex(m, m.faces(f, 2));
    six += a.dot(b.cross(c));
  }
  return six / 6;
}

// The smallest angle of any triangle, degrees.
double min_angle_deg(const TriangleMesh& m) {
  double smallest = 180;
  for (int f = 0; f < m.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const Vec3 at = vertex(m, m.faces(f, k)), u = vertex(m, m.faces(f, (k + 1) % 3)) - at,
                 v = vertex(m, m.faces(f, (k + 2) % 3)) - at;
      smallest = std::min(smallest, std::atan2(u.cross(v).norm(), u.dot(v)) * 180 / kPi);
    }
  return smallest;
}

double true_volume() {
  double open = kPi * (10 * 10 + 6 * 6 + 6 * 6 + 3 * 3 + 4 * 4 + 1.5 * 1.5) + (kPi * 1 * 1 + 2 * 8);
  return (120 * 80 - open) * 10;
}

TEST(PlateSmallOpenings, IsAKnownPartByName) {
  const auto& names = analytic_part_names();
  EXPECT_NE(std::find(names.begin(), names.end(), "plate_small_openings"), names.end());
  EXPECT_EQ(make_analytic_part("plate_small_openings", 2.0).name, "plate_small_openings");
}

TEST(PlateSmallOpenings, MeshesAreClosedManifoldOutwardOfGenus7) {
  struct Case {
    std::string name;
    AnalyticPart part;
    double volume_tolerance;  // relative: rims are inscribed polygons, a Ø3 one at 5 mm edges a triangle
  };
  std::vector<Case> parts;
  for (double h : {1.0, 2.0, 5.0}) {
    char name[32];
    std::snprintf(name, sizeof name, "uniform, h = %g mm", h);
    parts.push_back({name, make_plate_small_openings(h), h <= 2 ? 0.005 : 0.02});
  }
  parts.push_back({"cad", make_plate_small_openings(Tessellation{Tessellation::Style::cad, 1.0, 0.025}), 0.005});
  parts.push_back({"slivers", make_plate_small_openings(Tessellation{Tessellation::Style::slivers, 1.0, 0.025}), 0.005});
  for (const auto& [name, part, volume_tolerance] : parts) {
    const Topology t = topology(part.mesh);
    EXPECT_EQ(t.defects, 0) << name;
    EXPECT_EQ(t.components, 1) << name << " (or unreferenced vertices)";
    EXPECT_EQ(t.euler, 2 - 2 * kThroughOpenings) << name;
    const double volume = signed_volume(part.mesh);
    EXPECT_NEAR(volume, true_volume(), volume_tolerance * true_volume()) << name;  // > 0: the faces point outward
    EXPECT_EQ(part.mesh.vertices.colwise().minCoeff(), Vec3(0, 0, 0).transpose()) << name;
    EXPECT_EQ(part.mesh.vertices.colwise().maxCoeff(), Vec3(120, 80, 10).transpose()) << name;
    if (name.starts_with("uniform")) {
      std::printf("plate_small_openings %s: %ld triangles, min angle %.1f°\n", name.c_str(),
                  static_cast<long>(part.mesh.faces.rows()), min_angle_deg(part.mesh));
      EXPECT_GT(min_angle_deg(part.mesh), 10) << name;  // as the analytic-part suite holds the others
    }
  }
}

// The slot's rims are no circle, so the analytic-part suite's circle checks do not apply: held here.
TEST(PlateSmallOpenings, SlotRimsAreExactInTheMeshAndTheTruth) {
  const double h = 1.0;
  const AnalyticPart part = make_plate_small_openings(h);
  EXPECT_EQ(part.holes.size(), 6u);  // the Ø3 hole is a cylinder, the slot is not
  EXPECT_EQ(part.holes.back().radius, 1.5);
  EXPECT_EQ(part.holes.back().centre, Vec3(10, 70, 10));
  const double perimeter = 2 * 8 + 2 * kPi;
  int slot_rims = 0;
  for (const TrueEdge& edge : part.sharp_edges) {
    if (!edge.closed || std::abs(slot_distance(edge.samples.front().position.x(), edge.samples.front().position.y())) > 1e-9)
      continue;
    ++slot_rims;
    const double z = edge.samples.front().position.z();
    EXPECT_TRUE(z == 0 || z == 10);
    EXPECT_GE(edge.samples.size(), perimeter / 0.05);
    for (const TrueEdgeSample& s : edge.samples) {
      ASSERT_LT(std::abs(slot_distance(s.position.x(), s.position.y())), 1e-12);
      ASSERT_EQ(s.position.z(), z);
      // Up side: the top face (+z) at the top rim, the slot wall at the bottom rim (its normal is horizontal).
      const Vec3 face = z == 10 ? Vec3::UnitZ() : Vec3(-Vec3::UnitZ()), wall = z == 10 ? s.n_down : s.n_up;
      ASSERT_EQ(z == 10 ? s.n_up : s.n_down, face);
      ASSERT_NEAR(wall.norm(), 1, 1e-12);
      ASSERT_EQ(wall.z(), 0);
      // The wall's outward normal points into the slot: a step along it leaves the material.
      const Vec3 step = s.position + 0.01 * wall;
      ASSERT_LT(slot_distance(step.x(), step.y()), 0);
    }
  }
  EXPECT_EQ(slot_rims, 2);
  int on_rim = 0, inside = 0;
  for (int v = 0; v < part.mesh.vertices.rows(); ++v) {
    const double d = slot_distance(part.mesh.vertices(v, 0), part.mesh.vertices(v, 1));
    on_rim += std::abs(d) < 1e-9;
    inside += d < -1e-9;
  }
  EXPECT_GT(on_rim, 2 * perimeter / (2 * h));  // both rims, at least a vertex every 2 h
  EXPECT_EQ(inside, 0);
}

TEST(PlateSmallOpenings, OpeningsAreClearOfThePlateSides) {
  const AnalyticPart part = make_plate_small_openings(1.0);
  for (const TrueEdge& edge : part.sharp_edges) {
    if (!edge.closed) continue;
    for (const TrueEdgeSample& s : edge.samples) {
      ASSERT_GE(std::min({s.position.x(), 120 - s.position.x(), s.position.y(), 80 - s.position.y()}), 8.0);
    }
  }
}

}  // namespace
}  // namespace cmm::geometry
