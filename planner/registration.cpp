// corners.json in, T_M_S out. Every check that can say which corner is wrong runs before the fit,
// because a least-squares fit spreads one bad corner over all residuals and hides it.
#include "planner/registration.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <numbers>
#include <optional>
#include <set>

#include "geometry/file_error.hpp"
#include "hal/description/eigen_json.hpp"
#include "hal/description/json_fields.hpp"
#include "planner/number_text.hpp"
#include "planner/plate_pose.hpp"

namespace cmm::planner {
namespace {

using description::JsonFields;
using nlohmann::json;
using Kind = RegistrationError::Kind;


std::string corner_name(int id) { return "corner " + std::to_string(id); }

std::string id_list(const std::vector<int>& ids) {
  std::string s;
  for (std::size_t i = 0; i < ids.size(); ++i) s += (i ? ", " : "") + std::to_string(ids[i]);
  return s;
}

// --- checks --------------------------------------------------------------------------------

struct Frame {
  char name;         // 'S' or 'M'
  const char* long_name;  // "scan (S)"
  std::vector<Vec3> points;
};

void check_finite(const std::vector<int>& ids, const Frame& frame) {
  static const char* axis[] = {"x", "y", "z"};
  for (std::size_t i = 0; i < ids.size(); ++i)
    for (int a = 0; a < 3; ++a) {
      const double v = frame.points[i](a);
      if (std::isfinite(v)) continue;
      throw RegistrationError(Kind::not_finite, {ids[i]},
                              corner_name(ids[i]) + ": " + frame.long_name + " " + axis[a] + " is " +
                                  (std::isnan(v) ? "NaN" : "infinite") + "; measure that corner again");
    }
}

double extent_of(const std::vector<Vec3>& points) {
  double extent = 0;
  for (std::size_t a = 0; a < points.size(); ++a)
    for (std::size_t b = a + 1; b < points.size(); ++b) extent = std::max(extent, (points[a] - points[b]).norm());
  return extent;
}

void check_degenerate(const std::vector<int>& ids, const Frame& frame, double relative) {
  const double extent = extent_of(frame.points);
  const double limit = relative * extent;
  const std::string frame_name(1, frame.name);
  for (std::size_t a = 0; a < ids.size(); ++a)
    for (std::size_t b = a + 1; b < ids.size(); ++b) {
      const double d = (frame.points[a] - frame.points[b]).norm();
      if (d <= limit)
        throw RegistrationError(Kind::coincident, {ids[a], ids[b]},
                                "corners " + std::to_string(ids[a]) + " and " + std::to_string(ids[b]) +
                                    " coincide in " + frame_name + " (" + fixed(d, 3) + " mm apart, the corners span " +
                                    fixed(extent) + " mm): the same corner given twice?");
    }
  // Collinear: the largest distance from the principal line through the centroid.
  Vec3 centroid = Vec3::Zero();
  for (const Vec3& p : frame.points) centroid += p;
  centroid /= static_cast<double>(frame.points.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const Vec3& p : frame.points) scatter += (p - centroid) * (p - centroid).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(scatter);
  const Vec3 axis = eigen.eigenvectors().col(2);
  double farthest = 0;
  for (const Vec3& p : frame.points) farthest = std::max(farthest, ((p - centroid) - (p - centroid).dot(axis) * axis).norm());
  if (farthest <= limit)
    throw RegistrationError(Kind::collinear, ids,
                            "corners " + id_list(ids) + " are collinear in " + frame_name + ": the farthest is " +
                                fixed(farthest, 3) + " mm off their common line (needs more than " + fixed(limit, 3) +
                                " mm, " + fixed(relative, 4) + " of their " + fixed(extent) +
                                " mm extent); the rotation about that line is undetermined");
}

// "side corner 2–corner 3" or "diagonal corner 1–corner 3"; without a plate, "distance …".
std::string length_name(const description::Plate* plate, int a, int b) {
  const char* what = !plate ? "distance " : plate->adjacent(a, b) ? "side " : "diagonal ";
  return what + corner_name(std::min(a, b)) + "–" + corner_name(std::max(a, b));
}

// One corner that every failing length involves is most likely the one that is off.
std::optional<int> common_corner(const std::vector<std::pair<int, int>>& failing) {
  if (failing.size() < 2) return std::nullopt;
  for (int candidate : {failing[0].first, failing[0].second}) {
    if (std::all_of(failing.begin(), failing.end(),
                    [&](const auto& p) { return p.first == candidate || p.second == candidate; }))
      return candidate;
  }
  return std::nullopt;
}

std::string common_corner_hint(const std::vector<std::pair<int, int>>& failing) {
  const std::optional<int> common = common_corner(failing);
  return common ? " (" + corner_name(*common) + " is in every one: it is probably the one that is off)" : "";
}

void check_nominal_lengths(const std::vector<int>& ids, const Frame& frame, const description::Plate& plate, double tolerance) {
  std::vector<std::pair<int, int>> failing;
  std::string message;
  std::set<int> named;
  for (std::size_t a = 0; a < ids.size(); ++a)
    for (std::size_t b = a + 1; b < ids.size(); ++b) {
      const double measured = (frame.points[a] - frame.points[b]).norm();
      const double nominal = (plate.corner(ids[a]) - plate.corner(ids[b])).norm();
      if (std::abs(measured - nominal) <= tolerance) continue;
      failing.emplace_back(ids[a], ids[b]);
      named.insert(ids[a]);
      named.insert(ids[b]);
      message += (message.empty() ? "" : "; ") + length_name(&plate, ids[a], ids[b]) + " is " + fixed(measured) +
                 " mm in " + frame.name + ", the plate says " + fixed(nominal) + " mm";
    }
  if (failing.empty()) return;
  // The corner to blame, when one is in every failing length; else every corner named.
  const std::optional<int> common = common_corner(failing);
  throw RegistrationError(Kind::nominal_length, common ? std::vector<int>{*common} : std::vector<int>(named.begin(), named.end()),
                          message + " (tolerance " + fixed(tolerance) + " mm)" + common_corner_hint(failing));
}

void check_frame_lengths(const std::vector<int>& ids, const Frame& s, const Frame& m, const description::Plate* plate,
                         double tolerance) {
  std::vector<std::pair<int, int>> failing;
  std::string message;
  std::set<int> named;
  for (std::size_t a = 0; a < ids.size(); ++a)
    for (std::size_t b = a + 1; b < ids.size(); ++b) {
      const double in_s = (s.points[a] - s.points[b]).norm(), in_m = (m.points[a] - m.points[b]).norm();
      if (std::abs(in_s - in_m) <= tolerance) continue;
      failing.emplace_back(ids[a], ids[b]);
      named.insert(ids[a]);
      named.insert(ids[b]);
      message += (message.empty() ? "" : "; ") + length_name(plate, ids[a], ids[b]) + " is " + fixed(in_s) +
                 " mm in S but " + fixed(in_m) + " mm in M";
    }
  if (failing.empty()) return;
  throw RegistrationError(Kind::frame_length, {named.begin(), named.end()},
                          message + " (tolerance " + fixed(tolerance) + " mm)" + common_corner_hint(failing) +
                              "; a wrong --scale or unit in the scan changes every length by one factor");
}

// Newell's normal of the corners taken in the plate's (counter-clockwise) id order.
Vec3 order_normal(const std::vector<int>& ids, const std::vector<Vec3>& points) {
  std::vector<std::size_t> order(ids.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return ids[a] < ids[b]; });
  Vec3 n = Vec3::Zero();
  for (std::size_t i = 0; i < order.size(); ++i)
    n += points[order[i]].cross(points[order[(i + 1) % order.size()]]);
  return n;
}

std::string sorted_ids(std::vector<int> ids) {
  std::sort(ids.begin(), ids.end());
  return id_list(ids);
}

std::string fiducial_name(const description::Plate& plate) {
  if (plate.fiducial.kind == description::PlateFiducial::Kind::chamfer)
    return "the chamfer at corner " + std::to_string(plate.fiducial.corner);
  // Name the hole by its nearest corner: that is the corner it stands for.
  int nearest = 1;
  const Vec3 centre(plate.fiducial.centre.x(), plate.fiducial.centre.y(), plate.top_z());
  for (int id = 2; id <= plate.corner_count(); ++id)
    if ((plate.corner(id) - centre).norm() < (plate.corner(nearest) - centre).norm()) nearest = id;
  return "the hole near corner " + std::to_string(nearest);
}

int fiducial_corner(const description::Plate& plate) {
  if (plate.fiducial.kind == description::PlateFiducial::Kind::chamfer) return plate.fiducial.corner;
  int nearest = 1;
  const Vec3 centre(plate.fiducial.centre.x(), plate.fiducial.centre.y(), plate.top_z());
  for (int id = 2; id <= plate.corner_count(); ++id)
    if ((plate.corner(id) - centre).norm() < (plate.corner(nearest) - centre).norm()) nearest = id;
  return nearest;
}

bool within(const description::FiducialDeviation& d, double tolerance) {
  return d.off_mm <= tolerance && d.outside_mm <= tolerance;
}

FiducialCheck check_fiducial(const description::Plate& plate, const std::vector<int>& ids, const Frame& frame,
                             const Vec3& measured, const RegistrationOptions& options) {
  const Eigen::Isometry3d T_X_P = fit_plate_pose(plate, ids, frame.points);
  FiducialCheck check;
  check.frame = frame.name;
  check.measured = measured;
  check.predicted = T_X_P * description::fiducial_geometry(plate).point;
  check.deviation = description::fiducial_deviation(plate, T_X_P.inverse() * measured);
  check.tolerance_mm = options.fiducial_tolerance_mm;
  if (within(check.deviation, options.fiducial_tolerance_mm)) return check;

  const int n = plate.corner_count();
  const int home = fiducial_corner(plate);
  std::string message = "fiducial in " + std::string(1, frame.name) + ": " + fiducial_name(plate) +
                        " is not where " + corner_name(home) + " should be: the measured point is " +
                        fixed(check.deviation.off_mm) + " mm off " +
                        (plate.fiducial.kind == description::PlateFiducial::Kind::chamfer ? "the chamfer face's plane"
                                                                             : "the hole's axis") +
                        " and " + fixed(check.deviation.outside_mm) +
                        " mm beyond its extent, where the plate pose fitted to the " + frame.name +
                        " corners puts it (tolerance " + fixed(options.fiducial_tolerance_mm) + " mm)";
  // Try every relabelling of the corners by a cyclic shift: the corner labelled `id` taken as the
  // plate's corner id + k. One that fits the corners and puts the fiducial right is the diagnosis.
  for (int k = 1; k < n; ++k) {
    std::vector<int> shifted;
    for (int id : ids) shifted.push_back((id - 1 + k) % n + 1);
    const RigidFit refit = fit_rigid(
        [&] {
          std::vector<Vec3> nominal;
          for (int id : shifted) nominal.push_back(plate.corner(id));
          return nominal;
        }(),
        frame.points);
    if (refit.rms_mm > options.length_tolerance_mm) continue;
    const description::FiducialDeviation d = description::fiducial_deviation(plate, refit.transform.inverse() * measured);
    if (!within(d, options.fiducial_tolerance_mm)) continue;
    const int labelled = (n - k) % n + 1;  // the label whose shifted id is 1
    throw RegistrationError(Kind::fiducial, {labelled, 1},
                            message + "; the corner order looks shifted by " + std::to_string(k) +
                                ": the fiducial fits if the corner labelled " + std::to_string(labelled) +
                                " is the plate's " + corner_name(1) + "; relabel the " + frame.name + " corners");
  }
  std::string symmetric;
  for (int k : description::symmetry_shifts(plate)) symmetric += (symmetric.empty() ? "" : " or ") + std::to_string(k);
  const std::string hint =
      symmetric.empty() ? ""
                        : "; the plate looks the same with its corners shifted by " + symmetric +
                              ", so if the fiducial was probed where these corners put it, it was probed at a plain "
                              "corner and the corner order is shifted";
  throw RegistrationError(Kind::fiducial, {home},
                          message + "; no cyclic relabelling of the corners explains it" + hint +
                              "; otherwise check the fiducial measurement and the plate description");
}

}  // namespace

const char* to_string(RegistrationError::Kind kind) {
  switch (kind) {
    case Kind::too_few_corners: return "too_few_corners";
    case Kind::bad_corner_id: return "bad_corner_id";
    case Kind::not_finite: return "not_finite";
    case Kind::coincident: return "coincident";
    case Kind::collinear: return "collinear";
    case Kind::nominal_length: return "nominal_length";
    case Kind::frame_length: return "frame_length";
    case Kind::mirrored: return "mirrored";
    case Kind::rms: return "rms";
    case Kind::fiducial: return "fiducial";
    case Kind::probing: return "probing";
  }
  return "?";
}

RegistrationInput registration_from_json(const json& j, const std::string& source,
                                         const std::filesystem::path& base_dir) {
  JsonFields f(j);
  RegistrationInput input;
  input.source = source;
  if (!f.expect_object()) f.throw_if_problems(source);
  f.text("description", "");  // for the reader of the file
  const bool no_plate = !f.has("plate") || j["plate"].is_null() || (j["plate"].is_string() && j["plate"].get<std::string>().empty());
  if (!no_plate)
    input.plate = description::described(f, "plate", description::Plate{}, base_dir, description::plate_from_json,
                                         description::read_plate);
  else
    f.member("plate");

  // noise_mm sets both frames' noise; noise_scan_mm and noise_machine_mm override it per frame.
  if (f.has("noise_mm")) input.noise_scan_mm = input.noise_machine_mm = f.positive("noise_mm", input.noise_scan_mm);
  input.noise_scan_mm = f.positive("noise_scan_mm", input.noise_scan_mm);
  input.noise_machine_mm = f.positive("noise_machine_mm", input.noise_machine_mm);
  if (!f.has("noise_mm") && !(f.has("noise_scan_mm") && f.has("noise_machine_mm")))
    input.notes.push_back("noise_mm not given: the predicted uncertainty assumes σ = " + fixed(input.noise_scan_mm, 3) +
                          " mm (S) and " + fixed(input.noise_machine_mm, 3) + " mm (M) per coordinate");

  if (f.require("corners", "[{\"id\", \"scan\", \"machine\"}, ...]"))
    for (JsonFields& c : f.objects("corners")) {
      if (!c.value().is_object()) continue;
      CornerPair pair;
      if (c.require("id", "an integer corner id")) pair.id = c.integer("id", 0, 1, std::numeric_limits<int>::max());
      if (c.require("scan")) pair.scan = c.vec3("scan", pair.scan);
      if (c.require("machine")) pair.machine = c.vec3("machine", pair.machine);
      c.finish();
      input.corners.push_back(pair);
    }

  if (f.has("fiducial") && !j["fiducial"].is_null()) {
    JsonFields fiducial = f.object("fiducial");
    if (fiducial.has("machine")) input.fiducial_machine = fiducial.vec3("machine", Vec3::Zero());
    if (fiducial.has("scan")) input.fiducial_scan = fiducial.vec3("scan", Vec3::Zero());
    fiducial.finish();
  } else {
    f.member("fiducial");
  }
  if (f.has("scan_up")) {
    const Vec3 up = f.vec3("scan_up", Vec3::UnitZ());
    if (!(up.norm() > 0)) f.problem("scan_up", "must not be zero");
    else input.scan_up = up.normalized();
  }
  RegistrationOptions& o = input.options;
  o.rms_tolerance_mm = f.positive("rms_tolerance_mm", o.rms_tolerance_mm);
  o.length_tolerance_mm = f.positive("length_tolerance_mm", o.length_tolerance_mm);
  o.fiducial_tolerance_mm = f.positive("fiducial_tolerance_mm", o.fiducial_tolerance_mm);
  f.finish();
  f.throw_if_problems(source);
  return input;
}

RegistrationInput read_registration(const std::filesystem::path& file) {
  return registration_from_json(description::read_json_file(file, "the registration input"), file.string(),
                                file.parent_path());
}

RegistrationResult fit_registration(const RegistrationInput& input, const description::Plate* plate_given) {
  const description::Plate* plate = plate_given ? plate_given : input.plate ? &*input.plate : nullptr;
  const RegistrationOptions& options = input.options;
  const auto& corners = input.corners;
  if (corners.size() < 3)
    throw RegistrationError(Kind::too_few_corners, {},
                            "registration needs at least three corners measured in both S and M, got " +
                                std::to_string(corners.size()));
  std::vector<int> ids;
  Frame s{'S', "scan (S)", {}}, m{'M', "machine (M)", {}};
  for (const CornerPair& c : corners) {
    if (std::find(ids.begin(), ids.end(), c.id) != ids.end())
      throw RegistrationError(Kind::bad_corner_id, {c.id}, corner_name(c.id) + " is listed twice");
    if (plate && (c.id < 1 || c.id > plate->corner_count()))
      throw RegistrationError(Kind::bad_corner_id, {c.id},
                              corner_name(c.id) + " is not a corner of the plate (ids 1–" +
                                  std::to_string(plate->corner_count()) + ")");
    ids.push_back(c.id);
    s.points.push_back(c.scan);
    m.points.push_back(c.machine);
  }
  check_finite(ids, s);
  check_finite(ids, m);
  if (input.fiducial_machine && !input.fiducial_machine->allFinite())
    throw RegistrationError(Kind::not_finite, {}, "the fiducial's machine (M) position is not finite");
  if (input.fiducial_scan && !input.fiducial_scan->allFinite())
    throw RegistrationError(Kind::not_finite, {}, "the fiducial's scan (S) position is not finite");
  check_degenerate(ids, s, options.degenerate_tolerance);
  check_degenerate(ids, m, options.degenerate_tolerance);
  if (plate) {
    // M first: the machine's corners are the accurate ones, so a disagreement there is the plainer message.
    check_nominal_lengths(ids, m, *plate, options.length_tolerance_mm);
    check_nominal_lengths(ids, s, *plate, options.length_tolerance_mm);
  }
  check_frame_lengths(ids, s, m, plate, options.length_tolerance_mm);

  if (plate) {
    // The probe comes down along −z onto the plate's top, so +z of M is the top's side; a rotation
    // cannot turn counter-clockwise into clockwise, so a clockwise order is a mirrored one.
    if (!(order_normal(ids, m.points).z() > 0))
      throw RegistrationError(Kind::mirrored, ids,
                              "corners " + sorted_ids(ids) +
                                  " go clockwise seen from above (+z) in M, but the plate lists its corners "
                                  "counter-clockwise seen from its top: the corner order is mirrored");
    if (input.scan_up && !(order_normal(ids, s.points).dot(*input.scan_up) > 0))
      throw RegistrationError(Kind::mirrored, ids,
                              "corners " + sorted_ids(ids) +
                                  " go clockwise seen from scan_up in S, but the plate lists its corners "
                                  "counter-clockwise seen from its top: the corner order (or the scan) is mirrored");
  }

  RegistrationResult result;
  result.ids = ids;
  result.fit = fit_rigid(s.points, m.points);
  result.T_M_S = result.fit.transform;
  result.predicted = predict_rigid_fit_uncertainty(s.points, result.T_M_S, input.noise_scan_mm, input.noise_machine_mm);
  result.notes = input.notes;

  if (input.scan_up && !((result.T_M_S.linear() * *input.scan_up).z() > 0))
    throw RegistrationError(Kind::mirrored, ids,
                            "T_M_S turns the scan's up direction (scan_up) downward in M: the corner order is "
                            "mirrored between S and M, or the scan is mirrored");

  if (result.fit.rms_mm > options.rms_tolerance_mm) {
    const auto worst = std::max_element(result.fit.residual_norms.begin(), result.fit.residual_norms.end()) -
                       result.fit.residual_norms.begin();
    throw RegistrationError(Kind::rms, {ids[static_cast<std::size_t>(worst)]},
                            "the fit's RMS " + fixed(result.fit.rms_mm, 3) + " mm is over the tolerance " +
                                fixed(options.rms_tolerance_mm, 3) + " mm (expected about " +
                                fixed(result.predicted.expected_rms_mm, 3) + " mm from the stated noise); the largest "
                                "residual is " + corner_name(ids[static_cast<std::size_t>(worst)]) + "'s, " +
                                fixed(result.fit.residual_norms[static_cast<std::size_t>(worst)], 3) + " mm");
  }

  if (plate) {
    result.T_M_P = fit_plate_pose(*plate, ids, m.points);
    if (input.fiducial_machine) {
      result.fiducial_checks.push_back(check_fiducial(*plate, ids, m, *input.fiducial_machine, options));
      result.order_verified = true;
    } else {
      result.notes.push_back("the corner order in M is not verified: no fiducial measured in M (" +
                             fiducial_name(*plate) + ")");
    }
    if (input.fiducial_scan)
      result.fiducial_checks.push_back(check_fiducial(*plate, ids, s, *input.fiducial_scan, options));
    else if (!input.scan_up)
      result.notes.push_back("the corner order in S is checked only against M's: no fiducial and no scan_up in S");
  } else {
    result.notes.push_back("no plate description: the corners are checked only against each other, not against the "
                           "plate's size, handedness or fiducial");
  }
  return result;
}

void check_plate_corners(const std::vector<int>& ids, const std::vector<Vec3>& points, char frame,
                         const std::string& what, const description::Plate& plate, double length_tolerance_mm,
                         const std::optional<Vec3>& up, double degenerate_tolerance) {
  try {
    std::set<int> seen;
    for (int id : ids)
      if (id < 1 || id > plate.corner_count() || !seen.insert(id).second)
        throw RegistrationError(Kind::bad_corner_id, {id},
                                corner_name(id) + " is listed twice or is not a corner of the plate (ids 1–" +
                                    std::to_string(plate.corner_count()) + ")");
    if (ids.size() < 3)
      throw RegistrationError(Kind::too_few_corners, {}, "at least three corners are needed, got " + std::to_string(ids.size()));
    const Frame f{frame, frame == 'M' ? "machine (M)" : "scan (S)", points};
    check_finite(ids, f);
    check_degenerate(ids, f, degenerate_tolerance);
    try {
      check_nominal_lengths(ids, f, plate, length_tolerance_mm);
    } catch (const RegistrationError& e) {
      // Lengths that are the plate's under another labelling: the corners were given in each
      // other's places, and which ones is the diagnosis.
      std::vector<int> relabelled = ids;
      std::sort(relabelled.begin(), relabelled.end());
      do {
        if (relabelled == ids) continue;
        bool fits = true;
        for (std::size_t a = 0; a < ids.size() && fits; ++a)
          for (std::size_t b = a + 1; b < ids.size() && fits; ++b)
            fits = std::abs((points[a] - points[b]).norm() - (plate.corner(relabelled[a]) - plate.corner(relabelled[b])).norm()) <=
                   length_tolerance_mm;
        if (!fits) continue;
        std::string moves;
        std::vector<int> named;
        for (std::size_t i = 0; i < ids.size(); ++i)
          if (ids[i] != relabelled[i]) {
            moves += (moves.empty() ? "" : ", ") + std::string("the one given as ") + corner_name(ids[i]) + " is " +
                     corner_name(relabelled[i]);
            named.push_back(ids[i]);
          }
        throw RegistrationError(e.kind(), named,
                                std::string(e.what()) + "; the lengths are the plate's with the corners relabelled (" + moves +
                                    "): corners swapped?");
      } while (std::next_permutation(relabelled.begin(), relabelled.end()));
      throw;
    }
    // In M the probe comes down along −z, so +z is the top's side; in S only a known up tells.
    const std::optional<Vec3> top = frame == 'M' ? std::optional<Vec3>(Vec3::UnitZ()) : up;
    if (top && !(order_normal(ids, points).dot(*top) > 0))
      throw RegistrationError(Kind::mirrored, ids,
                              "corners " + sorted_ids(ids) + " go clockwise seen from the plate's top in " +
                                  std::string(1, frame) + ", but the plate lists its corners counter-clockwise: "
                                  "the corner order is mirrored (two corners swapped?)");
  } catch (const RegistrationError& e) {
    throw RegistrationError(e.kind(), e.corners(), what + ": " + e.what());
  }
}

json to_json(const RegistrationResult& r) {
  json residuals = json::array(), corners = json::array();
  for (std::size_t i = 0; i < r.ids.size(); ++i) {
    residuals.push_back(r.fit.residual_norms[i]);
    corners.push_back({{"id", r.ids[i]}, {"residual_mm", description::vec3_json(r.fit.residuals[i])},
                       {"norm_mm", r.fit.residual_norms[i]}});
  }
  const RigidFitUncertainty& p = r.predicted;
  json covariance = json::array();
  for (int row = 0; row < 6; ++row) {
    json line = json::array();
    for (int col = 0; col < 6; ++col) line.push_back(p.covariance(row, col));
    covariance.push_back(line);
  }
  json fiducial = json::array();
  for (const FiducialCheck& f : r.fiducial_checks)
    fiducial.push_back({{"frame", std::string(1, f.frame)},
                        {"measured", description::vec3_json(f.measured)},
                        {"predicted", description::vec3_json(f.predicted)},
                        {"off_mm", f.deviation.off_mm},
                        {"outside_mm", f.deviation.outside_mm},
                        {"tolerance_mm", f.tolerance_mm}});
  return {
      {"T_M_S", description::transform_json(r.T_M_S)},
      {"residuals_mm", residuals},
      {"rms_mm", r.fit.rms_mm},
      {"corners", corners},
      {"predicted",
       {{"sigma_scan_mm", p.sigma_from_mm},
        {"sigma_machine_mm", p.sigma_to_mm},
        {"sigma_eff_mm", p.sigma_eff_mm},
        {"rotation_rms_rad", p.rotation_rms_rad},
        {"rotation_rms_deg", p.rotation_rms_rad * 180 / std::numbers::pi},
        {"rotation_std_rad", description::vec3_json(p.rotation_std_rad)},
        {"translation_rms_at_centroid_mm", p.translation_rms_at_centroid_mm},
        {"translation_rms_at_origin_mm", p.translation_rms_at_origin_mm},
        {"expected_rms_mm", p.expected_rms_mm},
        {"centroid_S", description::vec3_json(p.centroid_from)},
        {"centroid_M", description::vec3_json(r.T_M_S * p.centroid_from)},
        {"covariance", covariance},
        {"covariance_parameters",
         "[wx, wy, wz] rad: rotation vector in M axes, R = exp([w]x) R_fit; [cx, cy, cz] mm: error of "
         "T_M_S * centroid_S in M"}}},
      {"plate_pose", r.T_M_P ? json{{"T_M_P", description::transform_json(*r.T_M_P)}} : json(nullptr)},
      {"fiducial", fiducial},
      {"order_verified", r.order_verified},
      {"notes", r.notes},
  };
}

}  // namespace cmm::planner
