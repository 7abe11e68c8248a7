// Base-plate registration: the plate's corners measured in the scan (S) and on the machine (M) give
// T_M_S by a rigid least-squares fit, after every check that can name bad input instead of fitting it.
#pragma once

#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "hal/description/plate.hpp"
#include "planner/rigid_fit.hpp"

namespace cmm::planner {

// Input the registration refuses to fit. what() names what is wrong and which corner(s) and frame.
class RegistrationError : public std::runtime_error {
 public:
  enum class Kind {
    too_few_corners,
    bad_corner_id,     // duplicate, or not a corner of the plate
    not_finite,        // NaN or infinite coordinate
    coincident,        // two corners at one place
    collinear,         // all corners on one line
    nominal_length,    // a side or diagonal disagrees with the plate
    frame_length,      // a length differs between S and M
    mirrored,          // the corner order runs the wrong way round
    rms,               // the fit's RMS is over the tolerance
    fiducial,          // the fiducial is not where the fitted pose puts it
    probing,           // touches that cannot give a corner or fiducial
  };
  RegistrationError(Kind kind, std::vector<int> corners, const std::string& message)
      : std::runtime_error(message), kind_(kind), corners_(std::move(corners)) {}
  Kind kind() const { return kind_; }
  const std::vector<int>& corners() const { return corners_; }  // the corner ids the message names

 private:
  Kind kind_;
  std::vector<int> corners_;
};

const char* to_string(RegistrationError::Kind kind);  // "too_few_corners", "nominal_length", …

struct CornerPair {
  int id = 0;              // the plate's corner id (1-based) when a plate is given; any distinct int otherwise
  Vec3 scan = Vec3::Zero();     // S, mm
  Vec3 machine = Vec3::Zero();  // M, mm
};

struct RegistrationOptions {
  double rms_tolerance_mm = 0.05;       // refuse a fit whose residual RMS is larger
  double length_tolerance_mm = 0.5;     // sides and diagonals: S vs M, and each frame vs the plate
  double fiducial_tolerance_mm = 0.5;   // fiducial off its nominal face / axis, and outside its extent
  double degenerate_tolerance = 1e-3;   // coincident / collinear, relative to the corners' extent
};

// What corners.json holds (docs/registration.md).
struct RegistrationInput {
  std::string source = "<json>";  // file the input came from, for messages
  std::optional<description::Plate> plate;
  double noise_scan_mm = 0.01;     // σ per coordinate of the scan corners
  double noise_machine_mm = 0.01;  // σ per coordinate of the machine corners
  std::vector<CornerPair> corners;
  std::optional<Vec3> fiducial_machine;  // measured fiducial point, M (chamfer: on its face; hole: on its axis)
  std::optional<Vec3> fiducial_scan;     // the same, S
  std::optional<Vec3> scan_up;           // outward normal of the plate's top face in S, if the scan knows it
  RegistrationOptions options;
  std::vector<std::string> notes;  // defaults the reader filled in
};

// Reads corners.json. Errors are description::FieldError and name the file and every bad field
// ("corners.json: /corners/2/machine: must be [x, y, z], not [1, 2]"). A "plate" string is a path
// relative to corners.json's folder.
RegistrationInput read_registration(const std::filesystem::path& file);
RegistrationInput registration_from_json(const nlohmann::json& j, const std::string& source = "<json>",
                                         const std::filesystem::path& base_dir = {});

// The fiducial measured in one frame, compared with where the plate pose fitted to that frame's
// corners puts it.
struct FiducialCheck {
  char frame = 'M';
  Vec3 measured = Vec3::Zero();   // in that frame
  Vec3 predicted = Vec3::Zero();  // the nominal fiducial point through the plate pose
  description::FiducialDeviation deviation;
  double tolerance_mm = 0;
};

struct RegistrationResult {
  Eigen::Isometry3d T_M_S = Eigen::Isometry3d::Identity();
  std::vector<int> ids;            // corner ids, in input order
  RigidFit fit;                    // residuals in M, per corner in `ids` order; RMS
  RigidFitUncertainty predicted;   // from the corner geometry and the stated σ (rigid_fit.hpp)
  std::optional<Eigen::Isometry3d> T_M_P;  // plate frame into M, from the M corners (with a plate)
  std::vector<FiducialCheck> fiducial_checks;
  bool order_verified = false;     // a fiducial confirmed the corner order in M
  std::vector<std::string> notes;  // what was not checked and why, defaults taken
};

// Checks, fits and checks again; throws RegistrationError naming the first problem found. The plate
// is `plate` if given, else the input's, else none (then only S against M is checked).
RegistrationResult fit_registration(const RegistrationInput& input, const description::Plate* plate = nullptr);

// The checks one frame's corners allow alone, before anything moves (job.submit): distinct corner
// ids of the plate, finite, neither coincident nor collinear, every side and diagonal against the
// plate within `length_tolerance_mm`, and the counter-clockwise order seen from the top (in M, whose
// +z is up; in S only with `up`). `what` names the corners in the message ("scan_corners (S)").
// Throws RegistrationError; for lengths it names the one corner every failing length involves when
// there is one (a rough corner 30 mm off is that corner's fault, not its neighbours').
void check_plate_corners(const std::vector<int>& ids, const std::vector<Vec3>& points, char frame,
                         const std::string& what, const description::Plate& plate, double length_tolerance_mm,
                         const std::optional<Vec3>& up = std::nullopt, double degenerate_tolerance = 1e-3);

// The plan JSON's "registration": {"T_M_S" (4×4, row-major nested arrays), "residuals_mm" (per
// corner norm, input order), "rms_mm", "corners", "predicted", "plate_pose", "fiducial", "notes"}.
nlohmann::json to_json(const RegistrationResult& result);

}  // namespace cmm::planner
