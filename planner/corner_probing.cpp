// Lays the corner and fiducial touches out in the plate frame, where the faces are simple, and maps
// them into M through the approximate pose; fits planes to the returned ball centres.
#include "planner/corner_probing.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "planner/number_text.hpp"
#include "planner/registration.hpp"

namespace cmm::planner {
namespace {

using Kind = RegistrationError::Kind;


[[noreturn]] void refuse(std::vector<int> corners, const std::string& message) {
  throw RegistrationError(Kind::probing, std::move(corners), message);
}

// Depths below the top for the upper and lower contacts on a vertical face: around mid-thickness,
// `margin` below the top edge and the ball `margin` clear of whatever the plate stands on.
std::pair<double, double> contact_depths(double height, double ball_radius, double margin, const std::string& what) {
  const double h = std::min(height / 4, height / 2 - ball_radius - margin);
  if (!(h >= 0.5))
    refuse({}, what + " is " + fixed(height) + " mm thick: too thin for three touches at two heights with a Ø" +
                   fixed(2 * ball_radius) + " mm ball and " + fixed(margin) + " mm margins");
  return {height / 2 - h, height / 2 + h};
}

// Signed distance of a top-face point from the side id → next(id), positive inside the plate.
double inside_distance(const description::Plate& plate, int id, const Vec3& p) {
  return -description::side_normal(plate, id).dot(p - plate.corner(id));
}

struct PlannedContact {
  Vec3 surface_P;
  Vec3 direction_P;
  int face;
};

class TouchWriter {
 public:
  TouchWriter(const Eigen::Isometry3d& T_M_P, const CornerProbingOptions& options, int first_id)
      : T_M_P_(T_M_P), options_(options), next_id_(first_id) {}

  void add(TouchTarget target, int corner, const PlannedContact& contact, double search_mm, double retract_mm) {
    Touch t;
    t.id = next_id_++;
    t.target = target;
    t.corner = corner;
    t.face = contact.face;
    t.surface_point = T_M_P_ * contact.surface_P;
    t.direction = (T_M_P_.linear() * contact.direction_P).normalized();
    t.nominal_centre = t.surface_point - options_.ball_radius_mm * t.direction;
    t.start = t.nominal_centre - search_mm * t.direction;
    t.max_travel_mm = 2 * search_mm;
    t.min_travel_mm = min_travel_for(t.max_travel_mm);
    t.retract_mm = retract_mm;
    touches.push_back(t);
  }

  std::vector<Touch> touches;

 private:
  const Eigen::Isometry3d& T_M_P_;
  const CornerProbingOptions& options_;
  int next_id_;
};

// Ball centres of one group of touches, and their mean approach direction.
struct Group {
  std::vector<Vec3> centres;
  Vec3 approach = Vec3::Zero();
};

Group collect(std::span<const Touch> touches, std::span<const Vec3> centres, TouchTarget target, int corner, int face) {
  if (touches.size() != centres.size())
    refuse({}, std::to_string(touches.size()) + " touches but " + std::to_string(centres.size()) + " ball centres");
  Group g;
  for (std::size_t i = 0; i < touches.size(); ++i) {
    const Touch& t = touches[i];
    if (t.target != target || (corner != 0 && t.corner != corner) || (face >= 0 && t.face != face)) continue;
    g.centres.push_back(centres[i]);
    g.approach += t.direction;
  }
  if (g.approach.norm() > 0) g.approach.normalize();
  return g;
}

// The surface plane under one face's ball centres: their plane moved back in by r along the approach.
Plane surface_plane(const Group& g, double ball_radius, double min_spread_ratio, double* rms) {
  const PlaneFit fit = fit_plane(g.centres, min_spread_ratio);
  Plane plane = oriented_along(fit.plane, -g.approach);  // outward: against the approach
  plane.offset -= ball_radius;
  if (rms) *rms = fit.rms_mm;
  return plane;
}

const char* face_name(int face) {
  switch (face) {
    case 0: return "face 0 (top)";
    case 1: return "face 1 (side toward the next corner)";
    default: return "face 2 (side toward the previous corner)";
  }
}

}  // namespace

std::vector<Touch> plan_corner_touches(const description::Plate& plate, const Eigen::Isometry3d& T_M_P,
                                       const CornerProbingOptions& options, int first_id) {
  const double r = options.ball_radius_mm, m = options.edge_margin_mm, s = options.spread_mm;
  const double t = plate.thickness_mm;
  const Vec3 up = Vec3::UnitZ();
  const auto [upper, lower] = contact_depths(t, r, m, "the plate");
  TouchWriter writer(T_M_P, options, first_id);
  const bool chamfered = plate.fiducial.kind == description::PlateFiducial::Kind::chamfer;

  for (int k = 1; k <= plate.corner_count(); ++k) {
    const Vec3& c = plate.corner(k);
    const Vec3 u1 = (plate.corner(plate.next(k)) - c).normalized();
    const Vec3 u2 = (plate.corner(plate.previous(k)) - c).normalized();
    const double sine = std::abs(u1.cross(u2).z());
    // Every corner keeps clear of the chamfer's size, not only the chamfered one: if the rough pose
    // has the corners mislabelled, the corner touches still land on true faces and only the
    // fiducial's touches notice.
    const double cut = chamfered ? plate.fiducial.size_mm : 0.0;

    // Top: an L of three contacts, `inset` from both sides (and clear of a chamfer's cut).
    const double inset = (m + cut) / sine;
    const std::array<std::pair<double, double>, 3> top{{{inset, inset}, {inset + s, inset}, {inset, inset + s}}};
    for (const auto& [a, b] : top) {
      const Vec3 p = c + a * u1 + b * u2;
      for (int side = 1; side <= plate.corner_count(); ++side)
        if (inside_distance(plate, side, p) < m - 1e-9)
          refuse({k}, "corner " + std::to_string(k) + ": the plate is too small for top touches " + fixed(s) +
                          " mm apart with " + fixed(m) + " mm margins");
      writer.add(TouchTarget::plate_face, k, {p, -up, 0}, options.search_mm, options.retract_mm);
    }
    // Sides: two contacts above mid-thickness, one below, between them along the side.
    for (int face : {1, 2}) {
      const Vec3 u = face == 1 ? u1 : u2;
      const int other = face == 1 ? plate.next(k) : plate.previous(k);
      const Vec3 outward = description::side_normal(plate, face == 1 ? k : plate.previous(k));
      const double length = (plate.corner(other) - c).norm();
      const double e0 = m + cut;
      if (e0 + s > length - cut - m)
        refuse({k}, "corner " + std::to_string(k) + ": the side toward corner " + std::to_string(other) + " (" +
                        fixed(length) + " mm) is too short for touches " + fixed(s) + " mm apart");
      const std::array<std::pair<double, double>, 3> pattern{{{e0, upper}, {e0 + s, upper}, {e0 + s / 2, lower}}};
      for (const auto& [along, depth] : pattern)
        writer.add(TouchTarget::plate_face, k, {c + along * u - depth * up, -outward, face}, options.search_mm,
                   options.retract_mm);
    }
  }

  const description::FiducialGeometry g = description::fiducial_geometry(plate);
  if (chamfered) {
    const int k = plate.fiducial.corner;
    const double q = g.half_width_mm - m;
    if (!(q >= 0.25))
      refuse({k}, "the chamfer at corner " + std::to_string(k) + " is " + fixed(2 * g.half_width_mm) +
                      " mm wide: too narrow for three touches with " + fixed(m) + " mm margins");
    const Vec3 mid_top = g.point + t / 2 * up;
    // Search from beyond where the unchamfered corner's apex would be: should the corners be
    // mislabelled and this be a plain corner, the touches meet its sides early instead of starting
    // inside the material.
    const double apex_mm = (plate.corner(k) - mid_top).norm();
    const double search = std::max(options.search_mm, apex_mm + m);
    const std::array<std::pair<double, double>, 3> pattern{{{-q, upper}, {q, upper}, {0, lower}}};
    int face = 0;
    for (const auto& [across, depth] : pattern)
      writer.add(TouchTarget::fiducial, k, {mid_top + across * g.along - depth * up, -g.normal, face++}, search,
                 options.retract_mm);
  } else {
    const double radius = g.half_width_mm, depth = plate.fiducial.depth_mm > 0 ? plate.fiducial.depth_mm : t;
    const double room = radius - r;
    if (!(room >= 0.1))
      refuse({}, "the fiducial hole (Ø" + fixed(2 * radius) + " mm) is too small for a Ø" + fixed(2 * r) + " mm ball");
    // Mid-depth, with the ball clear of the hole's bottom or of the table under a through hole.
    const double touch_depth = std::min(depth / 2, depth - r - m);
    if (!(touch_depth >= std::min(m, depth / 2)))
      refuse({}, "the fiducial hole is " + fixed(depth) + " mm deep: too shallow for a Ø" + fixed(2 * r) + " mm ball");
    const Vec3 axis_point(plate.fiducial.centre.x(), plate.fiducial.centre.y(), plate.top_z() - touch_depth);
    const std::array<Vec3, 4> outward{Vec3::UnitX(), Vec3::UnitY(), -Vec3::UnitX(), -Vec3::UnitY()};
    for (int face = 0; face < 4; ++face)
      writer.add(TouchTarget::fiducial, -1,
                 {axis_point + radius * outward[static_cast<std::size_t>(face)], outward[static_cast<std::size_t>(face)],
                  face},
                 room, std::min(options.retract_mm, room));
  }
  return std::move(writer.touches);
}

CornerFit fit_corner(int corner, std::span<const Touch> touches, std::span<const Vec3> ball_centres,
                     const CornerProbingOptions& options) {
  CornerFit fit;
  fit.corner = corner;
  for (int face = 0; face < 3; ++face) {
    const Group g = collect(touches, ball_centres, TouchTarget::plate_face, corner, face);
    const std::string where = "corner " + std::to_string(corner) + ", " + face_name(face);
    if (g.centres.size() < 3)
      refuse({corner}, where + ": " + std::to_string(g.centres.size()) + " touches, a plane needs three");
    for (const Vec3& c : g.centres)
      if (!c.allFinite()) refuse({corner}, where + ": a ball centre is not finite");
    try {
      fit.faces[static_cast<std::size_t>(face)] =
          surface_plane(g, options.ball_radius_mm, options.min_spread_ratio, &fit.face_rms_mm[static_cast<std::size_t>(face)]);
    } catch (const PlaneFitError& e) {
      refuse({corner}, where + ": " + e.what());
    }
  }
  fit.conditioning = intersection_conditioning(fit.faces[0], fit.faces[1], fit.faces[2]);
  try {
    fit.position = intersect_planes(fit.faces[0], fit.faces[1], fit.faces[2], options.min_conditioning);
  } catch (const PlaneFitError& e) {
    refuse({corner}, "corner " + std::to_string(corner) + ": " + e.what());
  }
  return fit;
}

Vec3 corner_from_touches(int corner, std::span<const Touch> touches, std::span<const Vec3> ball_centres,
                         const CornerProbingOptions& options) {
  return fit_corner(corner, touches, ball_centres, options).position;
}

std::vector<CornerFit> fit_corners(const description::Plate& plate, std::span<const Touch> touches,
                                   std::span<const Vec3> ball_centres, const CornerProbingOptions& options) {
  std::vector<CornerFit> fits;
  for (int k = 1; k <= plate.corner_count(); ++k) fits.push_back(fit_corner(k, touches, ball_centres, options));
  return fits;
}

FiducialFit locate_fiducial(const description::Plate& plate, const Eigen::Isometry3d& T_M_P, std::span<const Touch> touches,
                            std::span<const Vec3> ball_centres, const CornerProbingOptions& options) {
  const Group g = collect(touches, ball_centres, TouchTarget::fiducial, 0, -1);
  const bool chamfer = plate.fiducial.kind == description::PlateFiducial::Kind::chamfer;
  const std::size_t needed = 3;  // a hole is planned with four; three still fix a circle
  if (g.centres.size() < needed)
    refuse({}, "the fiducial: " + std::to_string(g.centres.size()) + " touches, needs at least " +
                   std::to_string(needed));
  for (const Vec3& c : g.centres)
    if (!c.allFinite()) refuse({}, "the fiducial: a ball centre is not finite");
  FiducialFit result;
  if (chamfer) {
    try {
      const PlaneFit fit = fit_plane(g.centres, options.min_spread_ratio);
      const Plane centres_plane = oriented_along(fit.plane, -g.approach);
      result.point = fit.centroid - options.ball_radius_mm * centres_plane.normal;
      result.rms_mm = fit.rms_mm;
    } catch (const PlaneFitError& e) {
      refuse({plate.fiducial.corner}, std::string("the chamfer's touches: ") + e.what());
    }
    return result;
  }
  // Hole: the ball centres lie on a circle of radius R − r about the axis, in a plane square to it.
  const Vec3 axis = (T_M_P.linear() * Vec3::UnitZ()).normalized();
  const Vec3 e1 = axis.unitOrthogonal(), e2 = axis.cross(e1);
  Vec3 origin = Vec3::Zero();
  for (const Vec3& c : g.centres) origin += c;
  origin /= static_cast<double>(g.centres.size());
  const auto n = static_cast<Eigen::Index>(g.centres.size());
  Eigen::MatrixX3d a(n, 3);
  Eigen::VectorXd b(n);
  std::vector<Eigen::Vector2d> planar;
  for (Eigen::Index i = 0; i < n; ++i) {
    const Vec3 d = g.centres[static_cast<std::size_t>(i)] - origin;
    planar.emplace_back(d.dot(e1), d.dot(e2));
    a.row(i) << planar.back().x(), planar.back().y(), 1.0;
    b(i) = -planar.back().squaredNorm();
  }
  // Kåsa's algebraic circle, x² + y² + D x + E y + F = 0: exact for points on a circle, and the
  // touches are spread round the whole wall, where its bias toward small radii does not arise.
  const Eigen::Vector3d kasa = a.colPivHouseholderQr().solve(b);
  const Eigen::Vector2d centre(-kasa(0) / 2, -kasa(1) / 2);
  const double radius_sq = centre.squaredNorm() - kasa(2);
  if (!(radius_sq > 0) || !centre.allFinite())
    refuse({}, "the fiducial hole's touches do not lie on a circle (collinear or repeated)");
  const double radius = std::sqrt(radius_sq);
  double sum_squares = 0;
  for (const auto& p : planar) sum_squares += std::pow((p - centre).norm() - radius, 2);
  result.point = origin + centre.x() * e1 + centre.y() * e2;
  result.diameter_mm = 2 * (radius + options.ball_radius_mm);
  result.rms_mm = std::sqrt(sum_squares / static_cast<double>(n));
  return result;
}

}  // namespace cmm::planner
