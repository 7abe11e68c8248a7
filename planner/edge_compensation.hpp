// Compensation of edge touches: from the ball centres a touch-trigger probe reports to the measured
// edge point, its uncertainty, its deviation from the reference point, and back to the scan frame.
#pragma once

#include <array>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "geometry/mesh.hpp"

namespace cmm::planner {

using geometry::Vec3;

// Every refusal of compensation names its feature ("edge point 12", "hole 3") and says why, so a
// job records the failure against that feature and carries on with the others.
class CompensationError : public std::runtime_error {
 public:
  enum class Reason {
    bad_input,        // missing, non-finite or non-unit inputs, too few touches
    no_intersection,  // the two touch circles do not meet: the touches cannot be of one edge
    degenerate,       // the inputs fix no unique answer (parallel approaches, collinear touches)
    beyond_delta,     // the point came out farther from its reference than the δ its touches assumed
  };
  // what() reads "edge point 12: trigger centres 2.31 mm apart, more than 2r = 2 mm: ..."; a
  // negative id leaves the number out.
  CompensationError(std::string_view feature, int id, Reason reason, const std::string& message);
  int id() const { return id_; }
  Reason reason() const { return reason_; }

 private:
  int id_;
  Reason reason_;
};

// Which frame a result's coordinates are in (DESIGN.md: S scan, M machine). Touches come in M.
enum class PointFrame { machine, scan };

enum class MeasurementMethod {
  two_touch_edge,     // two touches in the cross-section plane, both lines through the reference point
  face_intersection,  // touches on the two faces, planes intersected
  bore_wall,          // a surface point on a bore's wall (measured_cloud's input from a bore)
};

const char* to_string(MeasurementMethod method);

// A point on the part the probe measured. Millimetres throughout.
struct MeasuredPoint {
  int id = -1;  // plan edge point id (hole id for bore_wall points)
  MeasurementMethod method = MeasurementMethod::two_touch_edge;
  PointFrame frame = PointFrame::machine;
  Vec3 position = Vec3::Zero();
  Vec3 tangent = Vec3::UnitX();  // unit edge direction (the cross-section plane's normal); bore: the hole axis
  // Of `position`, from the trigger noise alone (mm²). Edge points lie in the cross-section plane, so
  // the covariance has (almost) no extent along `tangent`.
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  double sigma_mm = 0;     // 1-σ along the worst direction: √(largest eigenvalue of `covariance`)
  // How much a trigger error is amplified sideways: two touches 1/sin β (β half the angle between
  // the approaches); faces 1/sin θ (θ the angle between the face normals); 1 for a wall point.
  double sensitivity = 1;
  double out_of_plane_mm = 0;  // two touches: largest distance of a trigger centre from the cross-section plane
  bool clamped = false;        // two touches: the circles missed by less than the noise; tangency taken
  std::vector<std::string> notes;  // assumptions the result rests on, for the job report
};

// ---- 1. Two touches on a convex edge -------------------------------------------------------------

struct TwoTouchInput {
  int id = -1;                        // plan edge point id, named in errors
  std::array<Vec3, 2> centre{Vec3::Zero(), Vec3::Zero()};    // trigger centres (ball centre at the trigger), M
  std::array<Vec3, 2> approach{Vec3::Zero(), Vec3::Zero()};  // unit approach directions, into the material
  Vec3 reference_point = Vec3::Zero();  // A: the reference edge point; the cross-section plane passes through it
  Vec3 tangent = Vec3::Zero();          // t: unit edge tangent, the cross-section plane's normal
  Vec3 window_axis = Vec3::Zero();      // unit, into the material: decides the side when the approaches cannot
  double ball_radius_mm = 0;
  double trigger_sigma_mm = 0.001;    // 1-σ of each trigger centre, per axis (isotropic)
};

// Projects both centres into the cross-section plane (exact for a straight edge along t) and
// intersects the two radius-r circles around them; of the two intersections the one ahead of both
// balls ((X − Ci)·di > 0) is the edge, the window axis decides when both or neither are.
// Circles that miss by at most 4√2σ (the noise of their distance) are taken as tangent (`clamped`);
// a larger miss, coincident centres or parallel approaches throw CompensationError.
MeasuredPoint measure_edge_two_touch(const TwoTouchInput& input);

// ---- 2. Touches on the two faces of an edge -------------------------------------------------------

struct FaceTouches {
  std::vector<Vec3> centres;  // trigger centres on this face, M (at least one)
  Vec3 nominal_normal = Vec3::Zero();  // unit outward normal from the plan (n_up or n_down rotated to M)
};

// A face as measured: the plane n·x = offset_mm of the part's surface (the centres' plane moved by −r n).
struct FacePlane {
  Vec3 normal = Vec3::UnitZ();  // unit, outward
  double offset_mm = 0;
  bool normal_fitted = false;   // false: the nominal normal was taken as exact
  double normal_change_rad = 0; // angle between the fitted and the nominal normal
  double rms_mm = 0;            // of the centres about their plane (0 with fewer than four touches)
};

// Plane through the touches: fitted when there are at least three whose spread across their best
// line is at least 100σ (so noise tilts the normal by at most 10 mrad); with two at least 200σ apart,
// only the tilt along their line is fitted (the normal nearest the nominal one square to it: two
// touches across an edge measure the tilt that moves the edge, which a scan's side normals get wrong
// by degrees); otherwise the nominal normal is taken as exact and only the offset is measured (the
// mean over the touches). `face` names the face in errors and notes ("up", "down").
FacePlane fit_face_plane(const FaceTouches& touches, double ball_radius_mm, double trigger_sigma_mm, int id,
                         std::string_view face, std::vector<std::string>* notes = nullptr);

// The point of the line where the two planes meet that is nearest to `reference` (the edge point
// of measure_edge_from_faces without its uncertainty). Throws CompensationError naming `id` when
// the planes are (nearly) parallel.
Vec3 face_edge_point(const FacePlane& up, const FacePlane& down, const Vec3& reference, int id);

struct FaceEdgeInput {
  int id = -1;                      // plan edge point id, named in errors
  FaceTouches up, down;             // the faces of n_up and n_down
  Vec3 reference_point = Vec3::Zero();  // A: the measured point is the edge line's point nearest to A
  Vec3 tangent = Vec3::Zero();          // nominal edge tangent; only the output tangent's sign is taken from it
  double ball_radius_mm = 0;
  double trigger_sigma_mm = 0.001;  // 1-σ of each trigger centre, per axis (isotropic)
};

// The edge is the line where the two face planes meet; the measured point is its point nearest to
// A, i.e. in the plane through A perpendicular to the line. Works for concave and convex edges.
// Uncertainty: first-order propagation of σ on every centre (numerical Jacobian through the whole
// computation). A face with fewer than three touches contributes only its offset's noise: its
// normal is taken as given, so the normal's own error (the plan's n_up/n_down uncertainty) is not
// in the figure; `notes` says so. Throws CompensationError for (nearly) parallel faces.
MeasuredPoint measure_edge_from_faces(const FaceEdgeInput& input);

// ---- 4. Back to the scan frame, deviation from the reference -------------------------------------

// Maps a result in M into S: positions by T_M_S⁻¹, vectors and covariances by its rotation.
// Throws CompensationError when the point is already in S (mapping twice is always a bug).
MeasuredPoint to_scan_frame(const MeasuredPoint& point, const Eigen::Isometry3d& T_M_S);

struct EdgeDeviation {
  // |v| with v = (X − A) minus its component along the tangent, signed POSITIVE when the measured
  // edge lies OUTSIDE the reference (v·b > 0 with b = normalize(n_up + n_down), the outward
  // bisector: material would have to be added to the reference to reach the measured edge), negative
  // inside; a purely sideways v (v·b = 0) counts as positive.
  double signed_mm = 0;
  Vec3 vector = Vec3::Zero();  // v, in the frame of the inputs
  double outward_mm = 0;       // v·b
  double sideways_mm = 0;      // |v − (v·b) b|: the part of v along the cross-section, across the bisector
};

// All inputs in one frame; n_up, n_down outward unit normals of the two sides, tangent the edge's.
// Throws CompensationError (no id) when n_up + n_down vanishes: a flat "edge" has no outside.
EdgeDeviation signed_deviation(const Vec3& measured, const Vec3& reference, const Vec3& n_up, const Vec3& n_down,
                               const Vec3& tangent);

}  // namespace cmm::planner
