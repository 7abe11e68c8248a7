// Bores on a closed mesh: closed circular feature curves with a wall facing their axis are rims;
// rims sharing a wall are one bore, whose axis, draft and depth come from the whole wall.
#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <map>

#include "geometry/edge_point.hpp"
#include "geometry/feature_extractor.hpp"
#include "geometry/wall_hole.hpp"

namespace cmm::geometry::detail {

// A closed circular curve (`circle`, from rim_circle) with one side a wall around the axis whose normals
// face the axis.
std::optional<Rim> Extractor::bore_rim(int curve, const Circle3& circle, const std::vector<CurveSample>& samples) {
  if (samples.empty()) return std::nullopt;
  auto faces_axis = [&](const Vec3& n, const Vec3& p) {
    return std::abs(n.dot(circle.normal)) < 0.5 && n.dot(circle.centre - p) > 0;
  };
  int left = 0, right = 0;
  for (const CurveSample& s : samples) {
    left += faces_axis(s.left.normal, s.at.position);
    right += faces_axis(s.right.normal, s.at.position);
  }
  const int needed = static_cast<int>(std::ceil(0.8 * samples.size()));
  if ((left >= needed) == (right >= needed)) return std::nullopt;
  const bool wall_is_left = left >= needed;
  Vec3 face_normal = Vec3::Zero();
  for (const CurveSample& s : samples) face_normal += wall_is_left ? s.right.normal : s.left.normal;
  const Vec3 axis = face_normal.dot(circle.normal) >= 0 ? circle.normal : Vec3(-circle.normal);
  return Rim{curve, circle, wall_is_left, wall_is_left ? samples[0].left_face : samples[0].right_face, axis};
}

// Rims whose walls are one patch belong to one bore; returns the hole id per curve (or -1).
std::vector<int> Extractor::bores(SideRegionFinder& finder, std::vector<Rim>& rims) {
  std::vector<int> hole_of_curve(model_.features.curves.size(), -1);
  std::map<int, std::vector<const Rim*>> by_wall;
  std::map<int, std::vector<int>> wall_faces;
  for (Rim& rim : rims) {
    const std::vector<int>& wall = finder.patch(rim.wall_face);
    const int key = *std::min_element(wall.begin(), wall.end());
    fit_wall_axis(rim, wall);
    measure_wall_draft(rim, wall);
    by_wall[key].push_back(&rim);
    wall_faces.try_emplace(key, wall);
  }
  for (const auto& [key, group] : by_wall) {
    const Rim* entry = group.front();
    for (const Rim* rim : group) {
      const bool convex = model_.features.curves[rim->curve].convex;
      const bool entry_convex = model_.features.curves[entry->curve].convex;
      if (convex != entry_convex ? convex : is_up_side(rim->axis, entry->axis) && rim->axis != entry->axis) entry = rim;
    }
    Hole hole;
    hole.id = static_cast<int>(model_.holes.size());
    hole.source = HoleSource::bore;
    hole.centre = entry->circle.centre;
    hole.axis = entry->axis;
    hole.radius = entry->circle.radius;
    hole.perimeter = model_.features.curves[entry->curve].length;
    hole.roundness_mm = entry->circle.roundness_mm;
    // A straight wall's own circle is the diameter (a drafted one's varies along it, and the rim's
    // stands): a noisy mesh rounds the rim's crease, and a scan's crease points lie where the faces'
    // fitted planes meet, a wall's plane fitted over an arc lying inside it (r θ²/6 for a half-angle θ:
    // the plate's Ø6 rim 0.09 mm small from a scan without noise, its wall's vertices 0.007 mm).
    std::vector<int> round_axis;  // the patch's facets facing the rim's axis from about its radius
    for (int f : wall_faces[key]) {
      Vec3 to_axis = hole.centre - face_centroid(mesh_, f);
      to_axis -= to_axis.dot(hole.axis) * hole.axis;
      const double d = to_axis.norm();
      if (d > 0.5 * hole.radius && d < 1.5 * hole.radius && faces_.normals.row(f).dot(to_axis.transpose()) > 0.5 * d) round_axis.push_back(f);
    }
    if (entry->draft == 0)
      if (const std::optional<Circle3> wall = wall_circle(mesh_, faces_, wall_middle(mesh_, round_axis, hole.axis, kRimZoneMm), hole.axis)) {
        hole.centre = wall->centre + (hole.centre - wall->centre).dot(hole.axis) * hole.axis;
        hole.radius = wall->radius;
        hole.roundness_mm = wall->roundness_mm;
      }
    // Depth: between the fitted planes of the bore's two rims (a through hole, or a blind hole's
    // entry and bottom); with one rim, over the wall itself, trimming the 2 % extremes that
    // noise makes.
    if (group.size() >= 2) {
      double deepest = 0;
      for (const Rim* rim : group) deepest = std::max(deepest, std::abs((rim->circle.centre - hole.centre).dot(hole.axis)));
      hole.depth = deepest;
    } else {
      std::vector<double> along;
      for (int f : wall_faces[key]) {
        if (std::abs(faces_.normals.row(f).dot(hole.axis.transpose())) > 0.3) continue;
        for (int k = 0; k < 3; ++k) along.push_back((vertex(mesh_, mesh_.faces(f, k)) - hole.centre).dot(hole.axis));
      }
      if (along.size() >= 3) {
        std::sort(along.begin(), along.end());
        const std::size_t trim = along.size() / 50;
        hole.depth = along[along.size() - 1 - trim] - along[trim];
      }
    }
    for (const Rim* rim : group) hole_of_curve[rim->curve] = hole.id;
    model_.holes.push_back(hole);
  }
  return hole_of_curve;
}

// The bore's axis from its wall: the direction all wall normals are square to (the smallest
// eigenvector of their scatter), from hundreds of faces rather than one noisy rim's plane. Its
// covariance is the eigenvector's first-order perturbation, facet by facet (a sandwich estimate):
// each facet's normal off square to the axis (n·a) pulls the axis toward eₖ by (n·a)(n·eₖ)/(λₖ − λ₀).
// Facets are taken as independent; neighbours' noise tilts them opposite ways, so that overstates it.
// With too few wall facets the rim circle's own plane is kept, its scatter over its radius the error.
void Extractor::fit_wall_axis(Rim& rim, const std::vector<int>& wall) const {
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  std::vector<int> used;
  for (int f : wall) {
    const Vec3 n = faces_.normals.row(f).transpose();
    if (std::abs(n.dot(rim.axis)) > 0.5) continue;  // not wall
    scatter += faces_.areas[f] * n * n.transpose();
    used.push_back(f);
  }
  const double fallback = rim.circle.rms_mm / rim.circle.radius;
  rim.axis_covariance = fallback * fallback * (Eigen::Matrix3d::Identity() - rim.axis * rim.axis.transpose());
  if (used.size() < 8) return;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(scatter);
  const Vec3 axis = eigen.eigenvectors().col(0);
  const Eigen::Vector3d lambda = eigen.eigenvalues();
  if (!(lambda(1) - lambda(0) > 0)) return;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (int f : used) {
    const Vec3 n = faces_.normals.row(f).transpose();
    Vec3 pull = Vec3::Zero();
    for (int k = 1; k < 3; ++k) pull += eigen.eigenvectors().col(k) * n.dot(eigen.eigenvectors().col(k)) / (lambda(k) - lambda(0));
    pull *= faces_.areas[f] * n.dot(axis);
    covariance += pull * pull.transpose();
  }
  rim.axis = axis.dot(rim.axis) >= 0 ? axis : Vec3(-axis);
  rim.axis_covariance = covariance;
}

// The wall's mean tilt along the axis over the whole bore. Taken as zero (a cylinder) unless 3 standard
// errors away from it.
void Extractor::measure_wall_draft(Rim& rim, const std::vector<int>& patch) const {
  const auto radial = [&](int f) {
    Vec3 to_axis = rim.circle.centre - face_centroid(mesh_, f);
    to_axis -= to_axis.dot(rim.axis) * rim.axis;
    return faces_.normals.row(f).dot(to_axis.normalized().transpose());
  };
  std::vector<int> wall;
  for (int f : patch)
    if (radial(f) >= 0.5) wall.push_back(f);
  // The wall's facets within a rim zone of its ends are left out: a noisy mesh rounds the wall into
  // its rims, a scan's crease points (where the faces' fitted planes meet) tilt the facets beside them,
  // and where the scan saw one rim those folds do not cancel against the other's (the plate's Ø6 bore
  // scanned without noise read a draft of 0.7° from them). A wall too short for a middle keeps them all.
  if (std::vector<int> middle = wall_middle(mesh_, wall, rim.axis, kRimZoneMm); !middle.empty()) wall = std::move(middle);
  double w_sum = 0, w2_sum = 0, sum = 0, squares = 0;
  for (int f : wall) {
    const Vec3 n = faces_.normals.row(f).transpose();
    const double w = faces_.areas[f], draft = n.dot(rim.axis) / radial(f);
    w_sum += w, w2_sum += w * w, sum += w * draft, squares += w * draft * draft;
  }
  if (w_sum <= 0) return;
  const double mean = sum / w_sum;
  const double standard_error = std::sqrt(std::max(0.0, squares / w_sum - mean * mean) * w2_sum) / w_sum;
  rim.draft = std::abs(mean) > 3 * standard_error ? mean : 0.0;
  // A draft taken as zero may still be up to |mean|: that stays in the error, with the noise's.
  rim.draft_error = std::hypot(standard_error, mean - rim.draft);
}

// A bore wall's normal at a rim point is known far better from the circle fitted to the whole rim
// than from the few wall faces near the point (on a Ø6 bore the wall turns 30° within 1.6 mm):
// the radial direction to the axis, tilted by the wall's draft measured over the whole wall.
void Extractor::wall_normals_from_bore(const Rim& rim, std::vector<CurveSample>& samples) {
  auto radial = [&](const Vec3& p) {
    Vec3 to_axis = rim.circle.centre - p;
    to_axis -= to_axis.dot(rim.axis) * rim.axis;
    return Vec3(to_axis.normalized());
  };
  const double draft = rim.draft;
  for (CurveSample& s : samples) {
    SideNormal& wall = rim.wall_is_left ? s.left : s.right;
    const Vec3 to_axis = radial(s.at.position);
    const Vec3 fitted = (to_axis + draft * rim.axis).normalized();
    // Its turn about the rim's tangent is the draft's error plus the axis's tilt toward the point.
    const double tilt = std::sqrt(std::max(0.0, to_axis.dot(rim.axis_covariance * to_axis)));
    wall.uncertainty_rad = std::hypot(tilt, rim.draft_error);
    wall.normal = fitted;
  }
}

}  // namespace cmm::geometry::detail
