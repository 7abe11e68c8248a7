// The planner on every kind of reference mesh users bring: the analytic parts × their tessellations
// (CAD-style, a coarser fan, uniform fine, slivers, quadric-decimated, noisy), each held to the true
// part: the vertex-noise estimate, the side normals and the uncertainty they state, every window
// against the true feasible fan at the δ the plan states, the probeable fraction against what the
// true part and the stylus allow, and the real ball swept along every planned approach.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <numbers>
#include <ostream>
#include <random>
#include <string>

#include "edge_truth.hpp"
#include "geometry/analytic_parts.hpp"
#include "geometry/ball_sweep.hpp"
#include "geometry/feature_model.hpp"
#include "geometry/mesh_io.hpp"
#include "planner/probe_window.hpp"
#include "planner/reference_model.hpp"
#include "planner/touch_planning.hpp"
#include "true_edge_checks.hpp"

namespace cmm::planner {
namespace {

using geometry::AnalyticPart;
using geometry::Tessellation;
using geometry::testing::nearest_true_edge;
using testing::angle_in_fan;
using testing::distance_to;
constexpr double deg = std::numbers::pi / 180;

enum class Variant { cad, coarse_fan, uniform, slivers, decimated, noisy };

const char* name_of(Variant v) {
  switch (v) {
    case Variant::cad: return "cad";
    case Variant::coarse_fan: return "coarse_fan";
    case Variant::uniform: return "uniform";
    case Variant::slivers: return "slivers";
    case Variant::decimated: return "decimated";
    case Variant::noisy: return "noisy";
  }
  return "?";
}

struct Case {
  std::string part;
  Variant variant;
  double radius, delta;  // the ball, and the δ given for the scan
};

constexpr double min_coverage = 0.9;  // the least share of the true fan a window keeps

void PrintTo(const Case& c, std::ostream* os) { *os << c.part << "_" << name_of(c.variant); }

bool noise_free(Variant v) { return v != Variant::noisy; }

// The true part, its sharp polyline and a sweeper, made once per part: parts with circles need 0.25 mm
// edges for the true chords to stay within a fraction of a µm of the circle.
struct Truth {
  AnalyticPart part;
  std::vector<testing::Segment> edges;
  std::unique_ptr<geometry::BallSweeper> sweeper;
};

const Truth& truth(const std::string& part) {
  static std::map<std::string, std::unique_ptr<Truth>> cache;
  auto& slot = cache[part];
  if (!slot) {
    slot = std::make_unique<Truth>();
    slot->part = geometry::make_analytic_part(part, part == "cube" ? 2.0 : 0.25);
    slot->edges = testing::sharp_segments(slot->part.mesh);
    slot->sweeper = std::make_unique<geometry::BallSweeper>(slot->part.mesh);
  }
  return *slot;
}

geometry::TriangleMesh reference_mesh(const Case& c) {
  switch (c.variant) {
    case Variant::cad:
      return geometry::make_analytic_part(c.part, Tessellation{Tessellation::Style::cad, 0, c.delta / 4}).mesh;
    case Variant::coarse_fan:
      return geometry::make_analytic_part(c.part, Tessellation{Tessellation::Style::cad, 0, 4 * c.delta}).mesh;
    case Variant::uniform: return geometry::make_analytic_part(c.part, 1.0).mesh;
    case Variant::slivers:
      return geometry::make_analytic_part(c.part, Tessellation{Tessellation::Style::slivers, 0, c.delta / 4}).mesh;
    case Variant::decimated:
      return geometry::read_mesh(std::string(CMMD_TEST_DATA_DIR) + "/decimated/" + c.part + ".off");
    case Variant::noisy: return geometry::with_gaussian_noise(geometry::make_analytic_part(c.part, 1.0).mesh, 0.1, 20261124);
  }
  return {};
}

description::MachineDescription machine_for(double radius) {
  description::MachineDescription machine = description::default_machine();
  machine.tips.front().ball_radius_mm = radius;
  machine.tips.front().shaft_length_mm = 60;  // long enough to reach the foot of every wall
  return machine;
}

// The true edges as reference points with exact normals, every `spacing` along them: what the part
// itself lets the stylus measure.
std::vector<geometry::EdgePoint> true_points(const AnalyticPart& part, double spacing) {
  std::vector<geometry::EdgePoint> points;
  for (const geometry::TrueEdge& edge : part.sharp_edges) {
    double along = spacing / 2, walked = 0;
    for (std::size_t i = 0; i < edge.samples.size(); ++i) {
      if (i > 0) walked += (edge.samples[i].position - edge.samples[i - 1].position).norm();
      if (walked < along) continue;
      along += spacing;
      const geometry::TrueEdgeSample& s = edge.samples[i];
      geometry::EdgePoint p;
      p.id = static_cast<int>(points.size());
      p.position = s.position;
      p.n_up = s.n_up;
      p.n_down = s.n_down;
      p.tangent = s.n_up.cross(s.n_down).normalized();
      p.convex = edge.convex;
      const double turn = std::acos(std::clamp(s.n_up.dot(s.n_down), -1.0, 1.0));
      p.interior_angle_rad = edge.convex ? std::numbers::pi - turn : std::numbers::pi + turn;
      points.push_back(p);
    }
  }
  return points;
}

double planned_fraction(const std::vector<geometry::EdgePoint>& points, const StylusClearance& clearance,
                        const TouchPlanOptions& options) {
  int planned = 0;
  for (const geometry::EdgePoint& p : points)
    planned += plan_edge_point(p, Eigen::Isometry3d::Identity(), clearance, options).method != EdgeMethod::none;
  return points.empty() ? 0 : static_cast<double>(planned) / static_cast<double>(points.size());
}

class TessellationMatrix : public ::testing::TestWithParam<Case> {};

TEST_P(TessellationMatrix, PlansAsTheTruePartAllows) {
  const Case& c = GetParam();
  const Truth& t = truth(c.part);
  const geometry::TriangleMesh reference = reference_mesh(c);
  const geometry::FeatureModel model = geometry::extract_features(reference);
  PlanInputs inputs;
  settle_delta(inputs, c.delta, "the matrix", model);
  const auto& noise = model.features.noise;

  // The noise estimate measures the vertices: below 1 µm on an exact mesh, below the vertices' real
  // deviation on a decimated one, near the 0.1 mm put on the noisy one.
  double vertex_deviation = 0;
  for (Eigen::Index v = 0; v < reference.vertices.rows(); ++v)
    vertex_deviation = std::max(vertex_deviation, t.sweeper->closest_to_point(geometry::vertex(reference, static_cast<int>(v))).distance);
  if (c.variant == Variant::noisy) {
    EXPECT_NEAR(noise.sigma_mm, 0.1, 0.01);
    EXPECT_TRUE(model.features.noisy);
  } else if (c.variant == Variant::decimated) {
    EXPECT_LT(noise.sigma_mm, vertex_deviation + 1e-3);
  } else {
    EXPECT_LT(noise.sigma_mm, 1e-3);
    EXPECT_FALSE(model.features.noisy);
  }

  const description::MachineDescription machine = machine_for(c.radius);
  TouchPlanOptions options;
  options.radius = c.radius, options.delta = inputs.delta;
  const geometry::BallSweeper reference_part(reference);
  const StylusClearance clearance(reference_part, reference.vertices.col(2).minCoeff() - 1e-6, machine, c.radius, 100, inputs.delta);
  const StylusClearance true_clearance(*t.sweeper, -1e-6, machine, c.radius, 100, inputs.delta);

  std::mt19937_64 rng(4242);
  std::normal_distribution<double> gauss;
  std::uniform_real_distribution<double> unit(0, 1);
  int on_edges = 0, windows = 0, outside = 0, narrow = 0, uncovered = 0, touches = 0, planned = 0, deviated = 0, beyond_delta = 0, beyond_stated = 0;
  double worst_normal = 0, worst_ratio = 0, least_coverage = 1, worst_contact = 0;
  std::map<std::string, int> reasons;
  std::vector<geometry::EdgePoint> near_truth;
  for (const geometry::EdgePoint& p : model.points) {
    const auto nearest = nearest_true_edge(t.part, p.position);
    if (nearest.distance > std::max(0.5, 2 * p.mesh_deviation_mm) || !p.n_down) continue;
    near_truth.push_back(p);
    // The δ the plan states for a point bounds how far it lies from the true edge: always on an exact
    // mesh, with the odds of 3 standard errors in the cross-section (1 in 90) on a noisy one.
    const bool beyond = nearest.distance > geometry::delta_at(p, inputs.delta);
    beyond_delta += beyond;
    if (getenv("MATRIX_DEBUG") && beyond)
      std::printf("  point %d lies %.4f mm from the true edge, beyond its delta %.4f (position sigma %.4f)\n", p.id,
                  nearest.distance, geometry::delta_at(p, inputs.delta), p.position_sigma_mm);
    if (!p.convex) continue;
    if (!p.probeable) {  // the extractor refused it, naming the mesh's fault: nothing will be planned on it
      ++reasons["extractor: " + p.reason.substr(0, 80)];
      continue;
    }
    ++on_edges;
    deviated += p.mesh_deviation_mm > c.delta / 4;
    const Vec3 t_true = nearest.at.n_up.cross(nearest.at.n_down).normalized();
    // Side normals at the edge, in the true cross-section: within 0.5° or within what the plan states
    // of them, the margin a window takes (3.5 σ + 0.1°); 2° on the noisy mesh.
    double errors[2] = {0, 0};
    for (int side = 0; side < 2; ++side) {
      const Vec3 estimated = side == 0 ? p.n_up : *p.n_down, exact = side == 0 ? nearest.at.n_up : nearest.at.n_down;
      const double sigma = side == 0 ? p.n_up_uncertainty_rad : p.n_down_uncertainty_rad;
      const double error = angle_in_fan(estimated, exact, t_true), stated = 3.5 * sigma + 0.1 * deg;
      errors[side] = error;
      worst_normal = std::max(worst_normal, error);
      worst_ratio = std::max(worst_ratio, error / std::max(0.5 * deg, stated));
      uncovered += error > std::max(noise_free(c.variant) ? 0.5 * deg : 0.0, stated);
      beyond_stated += error > stated;  // what a window's margin takes: it must cover the truth, 0.5° or not
      EXPECT_LE(error, noise_free(c.variant) ? std::max(0.5 * deg, stated) : std::min(2 * deg, stated))
          << c.part << " " << name_of(c.variant) << " point " << p.id << " side " << side << " at " << p.position.transpose()
          << ": " << error / deg << " deg off, states " << stated / deg;
    }
    const double delta = geometry::delta_at(p, inputs.delta);
    const WindowResult window = probe_window(p, c.radius, delta);
    if (!window.usable) {
      ++reasons["window: " + window.reason.substr(0, 80)];
      continue;
    }
    ++windows;
    const Vec3 axis_true = -(nearest.at.n_up + nearest.at.n_down).normalized();
    const double alpha_true = std::numbers::pi - std::acos(std::clamp(nearest.at.n_up.dot(nearest.at.n_down), -1.0, 1.0));
    const double phi_true = feasible_half_angle(alpha_true, c.radius, delta);
    const ProbeWindow& w = window.window;
    double widest = 0;
    for (double s : {-1.0, 1.0}) widest = std::max(widest, angle_in_fan(direction_in_window(w, s * w.half_angle_rad), axis_true, t_true));
    outside += widest > phi_true + 1e-9;
    EXPECT_LE(widest, phi_true + 1e-9) << c.part << " " << name_of(c.variant) << " point " << p.id << ": window reaches "
                                      << widest / deg << " deg, the true fan " << phi_true / deg;
    least_coverage = std::min(least_coverage, w.half_angle_rad / phi_true);
    if (getenv("MATRIX_DEBUG") && w.half_angle_rad < min_coverage * phi_true)
      std::printf("  narrow point %d at %s hole %d: %.3f of %.2f deg, margins %.2f %.2f, sigma %.3f %.3f, errors %.3f %.3f\n", p.id,
                  (std::to_string(p.position.x()) + "," + std::to_string(p.position.y()) + "," + std::to_string(p.position.z())).c_str(),
                  p.hole, w.half_angle_rad / phi_true, phi_true / deg, w.margin_up_rad / deg, w.margin_down_rad / deg,
                  p.n_up_uncertainty_rad / deg, p.n_down_uncertainty_rad / deg, errors[0] / deg, errors[1] / deg);
    // A coarse fan's windows only have to be safe: it is planned with its larger δ or refused.
    narrow += c.variant != Variant::coarse_fan && w.half_angle_rad < min_coverage * phi_true;

    // The real ball along the planned approaches, from the true point moved anywhere within δ.
    std::vector<Vec3> offsets = {Vec3::Zero()};
    const Vec3 across = t_true.cross(axis_true);
    for (const Vec3& v : {across, Vec3(-across), axis_true, Vec3(-axis_true)}) offsets.push_back(delta * v);
    const Vec3 random = Vec3(gauss(rng), gauss(rng), gauss(rng)).normalized();
    offsets.push_back(delta * std::cbrt(unit(rng)) * random);
    for (const Vec3& offset : offsets) {
      geometry::EdgePoint perturbed = p;
      perturbed.position = nearest.at.position + offset;
      if (p.hole >= 0) geometry::align_to_hole(perturbed, model.holes[static_cast<std::size_t>(p.hole)]);
      const EdgePlan plan = plan_edge_point(perturbed, Eigen::Isometry3d::Identity(), clearance, options);
      if (plan.method != EdgeMethod::two_touch) continue;
      ++planned;
      for (const Touch& touch : plan.touches) {
        const auto hit = t.sweeper->first_hit(touch.start, touch.direction, touch.max_travel_mm, c.radius);
        ++touches;
        ASSERT_TRUE(hit.has_value()) << c.part << " " << name_of(c.variant) << " point " << p.id << ": the search missed the part";
        const double off = distance_to(t.edges, hit->contact);
        worst_contact = std::max(worst_contact, off);
        EXPECT_LE(off, 1e-3) << c.part << " " << name_of(c.variant) << " point " << p.id << " met the part "
                             << off * 1e3 << " um off the true edge";
      }
    }
  }

  // What the mesh lets the planner measure against what the true part lets the stylus measure.
  std::map<std::string, int> refusals;
  int probeable = 0;
  for (const geometry::EdgePoint& p : near_truth) {
    const EdgePlan plan = plan_edge_point(p, Eigen::Isometry3d::Identity(), clearance, options);
    if (plan.method != EdgeMethod::none) ++probeable;
    else ++refusals[plan.reason.substr(0, 100)];
  }
  const double fraction = near_truth.empty() ? 0 : static_cast<double>(probeable) / static_cast<double>(near_truth.size());
  const double reachable = planned_fraction(true_points(t.part, 2.0), true_clearance, options);

  std::printf("[ %s %s ] %ld faces, noise %.4f um (vertices off the surface up to %.4f um), delta %.3f: %d convex edge points "
              "(%d with mesh deviation over delta/4), normals worst %.3f deg (%.2f x max(0.5 deg, stated bound)), %d uncovered, "
              "%d beyond the stated bound; "
              "%d windows (least %.3f of the true fan, %d below its minimum), %d outside; probeable %.3f, reachable %.3f; "
              "%d perturbed plans, %d touches, worst %.4f um off the edge; %d of %zu points beyond their delta\n",
              c.part.c_str(), name_of(c.variant), static_cast<long>(reference.faces.rows()), noise.sigma_mm * 1e3,
              vertex_deviation * 1e3, inputs.delta, on_edges, deviated, worst_normal / deg, worst_ratio, uncovered, beyond_stated, windows,
              least_coverage, narrow, outside, fraction, reachable, planned, touches, worst_contact * 1e3, beyond_delta,
              near_truth.size());
  for (const auto& [reason, count] : reasons) std::printf("    %5d x %s\n", count, reason.c_str());
  for (const auto& [reason, count] : refusals) std::printf("    %5d refused: %s\n", count, reason.c_str());

  EXPECT_GT(on_edges, 20);
  EXPECT_LE(beyond_delta, noise_free(c.variant) ? 0.0 : 0.02 * static_cast<double>(near_truth.size()))
      << beyond_delta << " of " << near_truth.size() << " points lie beyond their delta";
  EXPECT_EQ(uncovered, 0);
  EXPECT_EQ(beyond_stated, 0) << "the stated uncertainty must cover the truth";
  EXPECT_EQ(outside, 0);
  EXPECT_EQ(narrow, 0);
  if (noise_free(c.variant) && c.variant != Variant::coarse_fan) {
    EXPECT_NEAR(fraction, reachable, 0.05);
  }
  if (c.variant == Variant::coarse_fan) {
    EXPECT_GT(deviated, 0) << "the coarse fan's chords should widen delta";
  }
}

std::vector<Case> cases() {
  std::vector<Case> all;
  const std::vector<std::tuple<std::string, double, double>> parts = {
      {"cube", 1.0, 0.2}, {"case3_block", 1.0, 0.2}, {"plate_with_holes", 1.0, 0.2}, {"bicone", 2.0, 0.1}, {"hemisphere_cone", 2.0, 0.1}};
#ifdef CMMD_SANITIZED
  // One variant of each kind, spread over the parts: the sanitizers are after memory, not the figures.
  const std::vector<std::pair<int, Variant>> chosen = {{0, Variant::cad},       {4, Variant::coarse_fan}, {4, Variant::uniform},
                                                       {3, Variant::slivers},   {1, Variant::decimated}, {0, Variant::noisy}};
  for (const auto& [part, variant] : chosen)
    all.push_back({std::get<0>(parts[part]), variant, std::get<1>(parts[part]), std::get<2>(parts[part])});
#else
  for (const auto& [part, radius, delta] : parts)
    for (Variant v : {Variant::cad, Variant::coarse_fan, Variant::uniform, Variant::slivers, Variant::decimated, Variant::noisy}) {
      // The coarser fan is a cone's: a box's bores cut that coarsely are polygons with creases of their own.
      if (v == Variant::coarse_fan && part != "bicone" && part != "hemisphere_cone") continue;
      all.push_back({part, v, radius, delta});
    }
#endif
  return all;
}

INSTANTIATE_TEST_SUITE_P(Parts, TessellationMatrix, ::testing::ValuesIn(cases()),
                         [](const auto& info) { return info.param.part + "_" + name_of(info.param.variant); });

}  // namespace
}  // namespace cmm::planner
