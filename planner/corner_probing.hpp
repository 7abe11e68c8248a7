// Measuring the base plate on the machine: the touches that find each corner as the meeting point of
// its three faces and locate the fiducial, and the corners and fiducial computed from their results.
#pragma once

#include <array>
#include <span>
#include <vector>

#include <Eigen/Geometry>

#include "planner/plane_fit.hpp"
#include "hal/description/plate.hpp"
#include "planner/touch.hpp"

namespace cmm::planner {

struct CornerProbingOptions {
  double ball_radius_mm = 1;        // the active tip's qualified radius
  double search_mm = 3;             // a touch starts this far before its nominal contact and searches 2× as far
  double retract_mm = 2;            // back along −direction after each contact
  double edge_margin_mm = 2;        // planned contacts stay this far inside their face: room for the rough pose's error
  double spread_mm = 10;            // spacing of the three touches on a face near its corner
  double min_conditioning = 0.5;    // |n_top · (n_1 × n_2)| a corner needs; 1 for a square corner
  double min_spread_ratio = 0.05;   // a face's three contacts must span an area, not a line (plane_fit.hpp)
};

// Touches in M for every corner, then the fiducial, numbered from `first_id`, from the plate's
// approximate pose T_M_P (e.g. fit_plate_pose on the operator's rough corner positions).
//
// Corner k (target plate_face, corner = k), three touches per face:
//   face 0, top: three contacts inside the top near the corner, approach −z of P;
//   face 1, the side from corner k to corner k+1, and face 2, the side from corner k−1 to corner k:
//   three contacts each, two above and one below mid-thickness, spread along the side away from the
//   corner, approach horizontal into the material. Three contacts at one height would lie on a line
//   and leave the side's tilt, and with it the corner, undetermined.
// A chamfer (target fiducial, corner = its corner, face = 0…2): three contacts on the chamfer face in
// the same pattern, approach along its inward normal. A hole (target fiducial, corner = −1,
// face = 0…3): four contacts on the wall at mid-depth toward +x, +y, −x, −y of P, each starting on
// the axis (the search is the wall's distance from the axis less the ball radius: starting further
// back would start inside the opposite wall).
// With a chamfer, every corner's side and top contacts keep clear of the chamfer's size (so that
// a mislabelled rough pose still measures true corners), and the chamfer's touches search from
// beyond where a plain corner's apex would be (so that at a plain corner they meet its sides early
// instead of starting inside the material). Every contact is on a face of a convex plate, so a
// ball moving along the face's normal meets the face at that point.
// Throws RegistrationError (kind probing) when the plate is too thin, the chamfer too narrow or the
// hole too small for the ball and the margins.
std::vector<Touch> plan_corner_touches(const description::Plate& plate, const Eigen::Isometry3d& T_M_P,
                                       const CornerProbingOptions& options, int first_id = 0);

// One corner from its nine touches. Each face's ball centres lie on the face's plane moved out by
// the ball radius, exactly, whatever the approach angle; so the plane is fitted to the centres and
// moved back in by r (along the approach), rather than each centre moved by r along its approach,
// which is exact only when the approach is square to the face.
struct CornerFit {
  int corner = 0;
  Vec3 position = Vec3::Zero();  // M
  std::array<Plane, 3> faces;    // top, side to next, side to previous: surface planes, outward normals, M
  std::array<double, 3> face_rms_mm{};  // RMS of the ball centres about their fitted plane
  double conditioning = 0;       // |n_top · (n_1 × n_2)|
};

// `touches` and `ball_centres` are parallel (the touch results' centres, M); touches of other
// corners and targets are ignored. Throws RegistrationError (kind probing) naming the corner and
// face when a face has fewer than three touches, its touches are collinear, or the three faces are
// too close to sharing a direction (below options.min_conditioning).
CornerFit fit_corner(int corner, std::span<const Touch> touches, std::span<const Vec3> ball_centres,
                     const CornerProbingOptions& options);
Vec3 corner_from_touches(int corner, std::span<const Touch> touches, std::span<const Vec3> ball_centres,
                         const CornerProbingOptions& options);
// Every corner of the plate, in id order.
std::vector<CornerFit> fit_corners(const description::Plate& plate, std::span<const Touch> touches,
                                   std::span<const Vec3> ball_centres, const CornerProbingOptions& options);

// The fiducial from its touches: a chamfer gives a point on its face (the centres' centroid moved in
// by r along the fitted face normal); a hole a point on its axis (the centre of the circle through
// the ball centres, in the plane square to the plate's axis taken from T_M_P, best the pose fitted to
// the measured corners) and its diameter. That point is what corners.json's "fiducial.machine" holds.
struct FiducialFit {
  Vec3 point = Vec3::Zero();  // M
  double diameter_mm = 0;     // hole only
  double rms_mm = 0;          // centres about the fitted plane (chamfer) or circle (hole)
};
FiducialFit locate_fiducial(const description::Plate& plate, const Eigen::Isometry3d& T_M_P, std::span<const Touch> touches,
                            std::span<const Vec3> ball_centres, const CornerProbingOptions& options);

}  // namespace cmm::planner
