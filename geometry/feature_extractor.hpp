// The extraction pipeline's internals, shared by feature_model.cpp (curves, reference points,
// boundary loops) and bore_detection.cpp (bores); not part of the geometry interface.
#pragma once

#include <cmath>
#include <numbers>
#include <optional>
#include <vector>

#include "geometry/circle_fit.hpp"
#include "geometry/face_geometry.hpp"
#include "geometry/feature_model.hpp"
#include "geometry/polyline_sampling.hpp"
#include "geometry/side_normal.hpp"
#include "geometry/wall_hole.hpp"

namespace cmm::geometry::detail {

// One sample on a feature curve with the normals of the face sides left and right of the curve
// direction (left: the face whose winding runs along the curve).
struct CurveSample {
  PolylineSample at;
  SideNormal left, right;
  int left_face = -1, right_face = -1;
  ChordDeviation chord;  // of the crease segment the sample lies on
  double position_sigma_mm = 0;  // the vertex noise left on its position after the crease's smoothing
};

// A closed feature curve found to be the rim of a bore.
struct Rim {
  int curve;
  Circle3 circle;
  bool wall_is_left;
  int wall_face;
  Vec3 axis;         // out of the material at this rim
  // Of the axis's tilt, from the wall facets' scatter about it: what a wall normal's turn about the
  // rim's tangent takes from the axis (a centre's error turns it about the axis, which moves no window).
  Eigen::Matrix3d axis_covariance = Eigen::Matrix3d::Zero();
  double draft = 0;  // tan of the wall's tilt toward the axis direction, over the whole wall
  double draft_error = 0;  // its standard error, and the mean dropped when within 3 of them
};

// Small residuals alone are not enough: nearly collinear points fit a huge circle well. A rim goes
// all the way round, so its length must be close to 2πR too (an inscribed octagon is 2.6 % short).
inline bool is_circle(const Circle3& c, double perimeter, double tolerance) {
  const double circumference = 2 * std::numbers::pi * c.radius;
  return c.radius > 0 && c.rms_mm < tolerance * c.radius && c.out_of_plane_mm < tolerance * c.radius &&
         std::abs(perimeter - circumference) < 2 * tolerance * circumference;
}

inline double angle_between(const Vec3& a, const Vec3& b) { return std::atan2(a.cross(b).norm(), a.dot(b)); }

class Extractor {
 public:
  Extractor(const TriangleMesh& mesh, const FeatureModelOptions& options);
  FeatureModel run();  // throws TooManyPoints, Cancelled

 private:
  // feature_model.cpp
  std::vector<CurveSample> sample_curve(SideRegionFinder& finder, const FeatureCurve& curve, const std::vector<Vec3>& points,
                                        const std::vector<double>& noise_gain, const std::optional<Circle3>& rim);
  double position_sigma(const std::vector<double>& noise_gain, int segment) const;
  void check_point_count() const;
  std::optional<Circle3> rim_circle(const std::vector<Vec3>& raw, bool closed, double length) const;
  std::vector<Vec3> smooth_curve(const std::vector<Vec3>& raw, bool closed, const std::optional<Circle3>& rim,
                                 std::vector<double>& noise_gain) const;
  bool two_distinct_sides(const std::vector<CurveSample>& samples) const;
  SideNormal side(SideRegionFinder& finder, int seed, int across, const PolylineSample& s, const Vec3& turn, double along);
  double along_edge(const std::vector<Vec3>& points, bool closed, const PolylineSample& s, const std::optional<Circle3>& rim) const;
  // The vertex noise a clean mesh's side normals carry over `region` (its facets' residuals are the
  // tessellation's), and the whole mesh's; none on a noisy mesh, whose residuals are the noise.
  std::optional<CleanNoise> clean_noise(const std::vector<int>& region) const;
  double across_edge(int seed, const PolylineSample& s) const;
  Vec3 curve_turn(const std::vector<Vec3>& points, bool closed, const PolylineSample& s, double reach,
                  const std::optional<Circle3>& rim) const;
  Vec3 edge_turn(const std::vector<Vec3>& points, bool closed, const PolylineSample& s, double along,
                 const std::optional<Circle3>& rim) const;
  void emit_curve_points(int curve, const std::vector<CurveSample>& samples, int hole);
  void emit_loop_points(SideRegionFinder& finder, int loop_index);
  void add_wall_hole(const WallHole& wall);
  void adopt_wall_hole_rims();
  double distinct_sides_rad() const { return 0.5 * options_.features.angle_deg * std::numbers::pi / 180; }
  // bore_detection.cpp
  std::optional<Rim> bore_rim(int curve, const Circle3& circle, const std::vector<CurveSample>& samples);
  std::vector<int> bores(SideRegionFinder& finder, std::vector<Rim>& rims);
  void fit_wall_axis(Rim& rim, const std::vector<int>& wall) const;
  void measure_wall_draft(Rim& rim, const std::vector<int>& wall) const;
  void wall_normals_from_bore(const Rim& rim, std::vector<CurveSample>& samples);

  static constexpr std::size_t min_region_faces = 6;
  // Up to this turn × reach (rad) edge_turn takes a rim's turn out of a side's facets.
  static constexpr double max_turn_reach = 0.5;
  const TriangleMesh& mesh_;
  const FeatureModelOptions& options_;
  EdgeAdjacency adjacency_;
  FaceGeometry faces_;
  FeatureModel model_;
  double noise_radius_ = 0, noise_along_ = 0;  // the neighbourhood the vertex noise asks for, mm
  int half_window_ = 0;
  std::vector<int> wall_holes_;  // ids of the holes found from their walls' borders
  // A rim point of a hole seen from its wall lies this close to the entry circle (or a tenth of the
  // radius): the crease's rounding and the noise move it by about half a bin.
  static constexpr double kWallRimReachMm = 0.3;
};

}  // namespace cmm::geometry::detail
