// A job's registration as the runner made it (registration.json in its folder): T_M_S, how it was
// found, and the tip and radius the plan is made for. Kept for the job's life: the plan is made
// again on every resume, and the same registration, tip and radius keep its touch ids, and with
// them the journal, valid even when the tip is qualified again meanwhile.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

namespace cmm::daemon {

// A plate corner the machine measured (registration by measure_plate).
struct MeasuredCorner {
  int id = 0;
  Eigen::Vector3d machine = Eigen::Vector3d::Zero();  // M
  std::array<double, 3> face_rms_mm{};  // top, side to the next corner, side to the previous one
  double conditioning = 0;
};

// A tip the plan may use, at the radius the plan is made for.
struct PlannedTip {
  std::string id;
  double radius_mm = 0;
};

struct JobRegistration {
  enum class Method { given, measured };
  Method method = Method::given;
  Eigen::Isometry3d T_M_S = Eigen::Isometry3d::Identity();
  double radius_mm = 0;  // the ball radius the plan is made for
  std::string tip;       // and its tip: the job's primary, which measured the plate
  // Every tip the plan may use, the primary first (chosen when the job registered: the tips qualified
  // then), so every resume plans the same touches.
  std::vector<PlannedTip> tips;
  std::string time_utc;
  nlohmann::json fit;    // planner::to_json(RegistrationResult): the plan's and the result's "registration"
  int corner_touches = 0;                      // measured only
  std::vector<MeasuredCorner> measured_corners;  // measured only
};

const char* to_string(JobRegistration::Method method);  // "given", "measured"

nlohmann::json to_json(const JobRegistration& registration);
// Throws std::invalid_argument or nlohmann::json::exception for a file that is not one.
JobRegistration job_registration_from_json(const nlohmann::json& j);

}  // namespace cmm::daemon
