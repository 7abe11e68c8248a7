// Two-touch intersection with its analytic first-order uncertainty, face planes intersected with a
// numerical one, and the frame change and signed deviation that turn results into a report.
#include "planner/edge_compensation.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>

namespace cmm::planner {

namespace {

using Reason = CompensationError::Reason;

std::string compose(std::string_view feature, int id, const std::string& message) {
  std::ostringstream out;
  out << feature;
  if (id >= 0) out << ' ' << id;
  out << ": " << message;
  return out.str();
}

std::string mm(double value) {
  std::ostringstream out;
  out.precision(6);
  out << value << " mm";
  return out.str();
}

bool finite(const Vec3& v) { return v.allFinite(); }

// Unit vector of `v`, or a bad_input error naming `what`: callers pass directions that should be
// unit already, so only zero or non-finite ones are refused, not slightly unnormalised ones.
Vec3 unit_or_throw(const Vec3& v, int id, const char* what) {
  const double norm = v.norm();
  if (!std::isfinite(norm) || norm < 1e-9) {
    throw CompensationError("edge point", id, Reason::bad_input, std::string(what) + " is zero or not finite");
  }
  return v / norm;
}

double largest_eigenvalue(const Eigen::Matrix3d& covariance) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(covariance, Eigen::EigenvaluesOnly);
  return std::max(0.0, eigen.eigenvalues()(2));
}

// ---- face planes -----------------------------------------------------------------------------------

struct Scatter {
  Vec3 mean = Vec3::Zero();
  Eigen::Vector3d eigenvalues = Eigen::Vector3d::Zero();  // ascending, of the scatter matrix Σ (p − mean)(p − mean)ᵀ
  Eigen::Matrix3d eigenvectors = Eigen::Matrix3d::Identity();
};

Scatter scatter_of(const std::vector<Vec3>& points) {
  Scatter s;
  for (const Vec3& p : points) s.mean += p;
  s.mean /= static_cast<double>(points.size());
  Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
  for (const Vec3& p : points) m += (p - s.mean) * (p - s.mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(m);
  s.eigenvalues = eigen.eigenvalues();
  s.eigenvectors = eigen.eigenvectors();
  return s;
}

// The plane once the decision fit/nominal is made; the Jacobian re-runs this with the decision fixed
// so that a perturbation never flips it.
FacePlane plane_from(const std::vector<Vec3>& centres, const Vec3& nominal, double radius, bool fit) {
  FacePlane plane;
  if (fit) {
    const Scatter s = scatter_of(centres);
    Vec3 normal = s.eigenvectors.col(0);
    if (centres.size() == 2) {
      // Two touches across the edge fix the face's tilt across it, the one that moves the edge: the
      // normal nearest the nominal one that is square to the line through them. The nominal normal
      // keeps its tilt along the edge, which only slides the point along the edge.
      const Vec3 across = (centres[1] - centres[0]).normalized();
      normal = (nominal - nominal.dot(across) * across).normalized();
    }
    if (normal.dot(nominal) < 0) normal = -normal;
    plane.normal = normal;
    plane.normal_fitted = true;
    plane.normal_change_rad = std::atan2(normal.cross(nominal).norm(), normal.dot(nominal));
    plane.rms_mm = centres.size() > 3 ? std::sqrt(std::max(0.0, s.eigenvalues(0)) / centres.size()) : 0.0;
    // The centres' plane lies r outside the surface: the ball touches at C − r·n.
    plane.offset_mm = normal.dot(s.mean) - radius;
  } else {
    double sum = 0;
    for (const Vec3& c : centres) sum += nominal.dot(c);
    plane.normal = nominal;
    plane.offset_mm = sum / static_cast<double>(centres.size()) - radius;
  }
  return plane;
}

bool should_fit(const std::vector<Vec3>& centres, double sigma) {
  if (centres.size() < 2) return false;
  const Scatter s = scatter_of(centres);
  // RMS spread across the centres' best line (for two, along their line: only the tilt across the
  // edge is fitted); noise tilts a fitted normal by about σ / spread.
  const double spread = std::sqrt(std::max(0.0, s.eigenvalues(centres.size() == 2 ? 2 : 1)) / centres.size());
  return spread >= std::max(100 * sigma, 1e-6);
}

struct EdgeLine {
  Vec3 point = Vec3::Zero();
  Vec3 direction = Vec3::Zero();  // unit, n_up × n_down
  double sin_angle = 0;           // of the angle between the two face normals
};

EdgeLine intersect(const FacePlane& up, const FacePlane& down, const Vec3& reference) {
  EdgeLine line;
  const Vec3 cross = up.normal.cross(down.normal);
  line.sin_angle = cross.norm();
  if (line.sin_angle < 1e-6) return line;
  line.direction = cross / line.sin_angle;
  Eigen::Matrix3d m;
  m.row(0) = up.normal.transpose();
  m.row(1) = down.normal.transpose();
  m.row(2) = line.direction.transpose();
  const Vec3 rhs(up.offset_mm, down.offset_mm, line.direction.dot(reference));
  line.point = m.partialPivLu().solve(rhs);
  return line;
}

}  // namespace

CompensationError::CompensationError(std::string_view feature, int id, Reason reason, const std::string& message)
    : std::runtime_error(compose(feature, id, message)), id_(id), reason_(reason) {}

const char* to_string(MeasurementMethod method) {
  switch (method) {
    case MeasurementMethod::two_touch_edge: return "two_touch_edge";
    case MeasurementMethod::face_intersection: return "face_intersection";
    case MeasurementMethod::bore_wall: return "bore_wall";
  }
  return "unknown";
}

// ---- 1. two touches --------------------------------------------------------------------------------

MeasuredPoint measure_edge_two_touch(const TwoTouchInput& in) {
  const auto refuse = [&](Reason reason, const std::string& message) {
    return CompensationError("edge point", in.id, reason, message);
  };
  for (int i = 0; i < 2; ++i) {
    if (!finite(in.centre[i])) throw refuse(Reason::bad_input, "trigger centre " + std::to_string(i + 1) + " is not finite");
  }
  if (!finite(in.reference_point)) throw refuse(Reason::bad_input, "reference point is not finite");
  if (!(in.ball_radius_mm > 0) || !std::isfinite(in.ball_radius_mm)) {
    throw refuse(Reason::bad_input, "ball radius " + mm(in.ball_radius_mm) + " is not positive");
  }
  if (!(in.trigger_sigma_mm >= 0) || !std::isfinite(in.trigger_sigma_mm)) {
    throw refuse(Reason::bad_input, "trigger noise " + mm(in.trigger_sigma_mm) + " is not a standard deviation");
  }
  const double r = in.ball_radius_mm, sigma = in.trigger_sigma_mm;
  const Vec3 t = unit_or_throw(in.tangent, in.id, "the tangent");
  const Vec3 axis = unit_or_throw(in.window_axis, in.id, "the window axis");
  const Vec3& a = in.reference_point;

  // In-plane frame: e1 along the window axis (into the material), e2 = t × e1.
  const Vec3 axis_in_plane = axis - axis.dot(t) * t;
  if (axis_in_plane.norm() < 1e-6) throw refuse(Reason::bad_input, "the window axis lies along the tangent");
  const Vec3 e1 = axis_in_plane.normalized();
  const Vec3 e2 = t.cross(e1);
  const auto in_plane = [&](const Vec3& v) { return Eigen::Vector2d(v.dot(e1), v.dot(e2)); };

  MeasuredPoint result;
  result.id = in.id;
  result.method = MeasurementMethod::two_touch_edge;
  result.tangent = t;

  // Projection along t keeps each centre's distance to a straight edge along t: exact, not an
  // approximation, and it removes the trigger noise along the edge.
  std::array<Eigen::Vector2d, 2> p, d;
  for (int i = 0; i < 2; ++i) {
    p[i] = in_plane(in.centre[i] - a);
    result.out_of_plane_mm = std::max(result.out_of_plane_mm, std::abs((in.centre[i] - a).dot(t)));
    const Vec3 approach = unit_or_throw(in.approach[i], in.id, i == 0 ? "approach 1" : "approach 2");
    d[i] = in_plane(approach);
    if (d[i].norm() < 1e-6) {
      throw refuse(Reason::bad_input, "approach " + std::to_string(i + 1) + " lies along the tangent");
    }
    d[i].normalize();
  }
  const double beta = 0.5 * std::acos(std::clamp(d[0].dot(d[1]), -1.0, 1.0));
  if (std::sin(beta) < 1e-9) throw refuse(Reason::degenerate, "the two approaches are parallel: no cross-section fix");
  result.sensitivity = 1 / std::sin(beta);

  const double distance = (p[1] - p[0]).norm();
  if (distance < 1e-12 * std::max(1.0, r)) {
    throw refuse(Reason::degenerate, "the two trigger centres coincide in the cross-section plane");
  }
  // The distance between the centres has noise √2σ; a miss within four of those is noise.
  const double tolerance = 4 * std::sqrt(2.0) * sigma;
  if (distance > 2 * r + tolerance) {
    throw refuse(Reason::no_intersection,
                 "trigger centres " + mm(distance) + " apart in the cross-section plane, more than 2r = " + mm(2 * r) +
                     " (+ noise " + mm(tolerance) + "): the two touches cannot have met one edge");
  }
  result.clamped = distance > 2 * r;
  const double h = std::sqrt(std::max(0.0, r * r - distance * distance / 4));
  const Eigen::Vector2d u = (p[1] - p[0]) / distance;
  const Eigen::Vector2d w(-u.y(), u.x());
  const Eigen::Vector2d mid = (p[0] + p[1]) / 2;
  const std::array<Eigen::Vector2d, 2> candidate{mid + h * w, mid - h * w};

  // The edge lies ahead of both balls; the mirror solution behind the line of centres usually does
  // not (it does too once 2β > 90°), and then the one further along the axis (e1) is the edge.
  std::array<bool, 2> ahead{};
  for (int k = 0; k < 2; ++k) {
    ahead[k] = (candidate[k] - p[0]).dot(d[0]) > 0 && (candidate[k] - p[1]).dot(d[1]) > 0;
  }
  int chosen = candidate[0].x() >= candidate[1].x() ? 0 : 1;
  if (ahead[0] != ahead[1]) chosen = ahead[0] ? 0 : 1;
  const Eigen::Vector2d x = candidate[chosen];
  result.position = a + x.x() * e1 + x.y() * e2;

  // First order: X stays on both circles, (X − p_i)·(dX − dp_i) = 0, so N dX = (n_1·dp_1, n_2·dp_2)
  // with n_i the unit contact normals; only each centre's noise along its n_i moves X, and
  // Cov X = σ² N⁻¹ N⁻ᵀ. Sideways the rows of N differ by ≈ 2 sin β: hence the 1/sin β.
  Eigen::Matrix2d cov2;
  Eigen::Matrix2d n;
  n.row(0) = (x - p[0]).normalized().transpose();
  n.row(1) = (x - p[1]).normalized().transpose();
  if (!result.clamped && std::abs(n.determinant()) > 1e-12) {
    const Eigen::Matrix2d inverse = n.inverse();
    cov2 = sigma * sigma * inverse * inverse.transpose();
  } else {
    // At tangency the intersection moves like √(r·ε) with the miss ε: along the line of centres
    // X is their midpoint (σ²/2); across it, the spread a miss as large as the tolerance allows.
    cov2 = sigma * sigma / 2 * u * u.transpose() + r * tolerance * w * w.transpose();
    result.clamped = true;
    result.notes.push_back("the touch circles (centres " + mm(distance) + " apart, 2r = " + mm(2 * r) +
                           ") only graze: tangency taken, uncertainty across the line of centres √(r·" +
                           mm(tolerance) + ")");
  }
  Eigen::Matrix<double, 3, 2> basis;
  basis.col(0) = e1;
  basis.col(1) = e2;
  result.covariance = basis * cov2 * basis.transpose();
  // Largest eigenvalue of the symmetric 2 × 2 in closed form (this runs inside Monte-Carlo loops).
  const double half_trace = (cov2(0, 0) + cov2(1, 1)) / 2;
  const double radius = std::hypot((cov2(0, 0) - cov2(1, 1)) / 2, cov2(0, 1));
  result.sigma_mm = std::sqrt(std::max(0.0, half_trace + radius));
  return result;
}

// ---- 2. faces ------------------------------------------------------------------------------------

FacePlane fit_face_plane(const FaceTouches& touches, double ball_radius_mm, double trigger_sigma_mm, int id,
                         std::string_view face, std::vector<std::string>* notes) {
  const std::string name = "face " + std::string(face);
  if (touches.centres.empty()) {
    throw CompensationError("edge point", id, Reason::bad_input, name + " has no touches");
  }
  for (std::size_t i = 0; i < touches.centres.size(); ++i) {
    if (!finite(touches.centres[i])) {
      throw CompensationError("edge point", id, Reason::bad_input,
                              name + ": trigger centre " + std::to_string(i + 1) + " is not finite");
    }
  }
  const Vec3 nominal = unit_or_throw(touches.nominal_normal, id, "a nominal face normal");
  const bool fit = should_fit(touches.centres, trigger_sigma_mm);
  const FacePlane plane = plane_from(touches.centres, nominal, ball_radius_mm, fit);
  if (notes) {
    if (!fit) {
      notes->push_back(name + ": " + std::to_string(touches.centres.size()) +
                       (touches.centres.size() >= 3 ? " touches too close to a line" : touches.centres.size() == 2 ? " touches too close together" : " touch") +
                       ", its nominal normal taken as exact; its error is not in the uncertainty");
    } else if (plane.normal_change_rad > 10 * std::numbers::pi / 180) {
      std::ostringstream out;
      out.precision(3);
      out << name << ": fitted normal " << plane.normal_change_rad * 180 / std::numbers::pi
          << "° off the nominal one: did a touch land on another face?";
      notes->push_back(out.str());
    }
  }
  return plane;
}

Vec3 face_edge_point(const FacePlane& up, const FacePlane& down, const Vec3& reference, int id) {
  const EdgeLine line = intersect(up, down, reference);
  if (line.sin_angle < 1e-6) {
    throw CompensationError("edge point", id, Reason::degenerate, "the two measured faces are parallel: they meet in no edge");
  }
  return line.point;
}

MeasuredPoint measure_edge_from_faces(const FaceEdgeInput& in) {
  if (!(in.ball_radius_mm > 0) || !std::isfinite(in.ball_radius_mm)) {
    throw CompensationError("edge point", in.id, Reason::bad_input, "ball radius " + mm(in.ball_radius_mm) + " is not positive");
  }
  if (!(in.trigger_sigma_mm >= 0) || !std::isfinite(in.trigger_sigma_mm)) {
    throw CompensationError("edge point", in.id, Reason::bad_input,
                            "trigger noise " + mm(in.trigger_sigma_mm) + " is not a standard deviation");
  }
  if (!finite(in.reference_point)) {
    throw CompensationError("edge point", in.id, Reason::bad_input, "reference point is not finite");
  }
  MeasuredPoint result;
  result.id = in.id;
  result.method = MeasurementMethod::face_intersection;
  const FacePlane up = fit_face_plane(in.up, in.ball_radius_mm, in.trigger_sigma_mm, in.id, "up", &result.notes);
  const FacePlane down = fit_face_plane(in.down, in.ball_radius_mm, in.trigger_sigma_mm, in.id, "down", &result.notes);
  const EdgeLine line = intersect(up, down, in.reference_point);
  if (line.sin_angle < 1e-6) {
    throw CompensationError("edge point", in.id, Reason::degenerate, "the two measured faces are parallel: they meet in no edge");
  }
  result.position = line.point;
  result.tangent = line.direction;
  if (in.tangent.allFinite() && in.tangent.dot(result.tangent) < 0) result.tangent = -result.tangent;
  result.sensitivity = 1 / line.sin_angle;

  // First-order propagation through the whole chain (fit, offset, intersection) by central
  // differences: each centre coordinate is an independent input of variance σ².
  const Vec3 up_normal = up.normal, down_normal = down.normal;  // nominal ones where not fitted
  const bool fit_up = up.normal_fitted, fit_down = down.normal_fitted;
  std::vector<Vec3> up_centres = in.up.centres, down_centres = in.down.centres;
  const auto evaluate = [&]() {
    const FacePlane a = plane_from(up_centres, up_normal, in.ball_radius_mm, fit_up);
    const FacePlane b = plane_from(down_centres, down_normal, in.ball_radius_mm, fit_down);
    return intersect(a, b, in.reference_point).point;
  };
  const double step = 1e-5 * std::max(1.0, in.ball_radius_mm);
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (std::vector<Vec3>* centres : {&up_centres, &down_centres}) {
    for (Vec3& c : *centres) {
      for (int k = 0; k < 3; ++k) {
        const double original = c(k);
        c(k) = original + step;
        const Vec3 plus = evaluate();
        c(k) = original - step;
        const Vec3 minus = evaluate();
        c(k) = original;
        const Vec3 column = (plus - minus) / (2 * step);
        covariance += column * column.transpose();
      }
    }
  }
  result.covariance = in.trigger_sigma_mm * in.trigger_sigma_mm * covariance;
  result.sigma_mm = std::sqrt(largest_eigenvalue(result.covariance));
  return result;
}

// ---- 4. frames and deviations --------------------------------------------------------------------

MeasuredPoint to_scan_frame(const MeasuredPoint& point, const Eigen::Isometry3d& T_M_S) {
  if (point.frame == PointFrame::scan) {
    throw CompensationError(point.method == MeasurementMethod::bore_wall ? "hole" : "edge point", point.id,
                            Reason::bad_input, "already in the scan frame: mapped twice?");
  }
  const Eigen::Matrix3d rotation_S_M = T_M_S.linear().transpose();
  MeasuredPoint mapped = point;
  mapped.frame = PointFrame::scan;
  mapped.position = T_M_S.inverse() * point.position;
  mapped.tangent = rotation_S_M * point.tangent;
  mapped.covariance = rotation_S_M * point.covariance * rotation_S_M.transpose();
  return mapped;
}

EdgeDeviation signed_deviation(const Vec3& measured, const Vec3& reference, const Vec3& n_up, const Vec3& n_down,
                               const Vec3& tangent) {
  const Vec3 sum = n_up + n_down;
  if (!sum.allFinite() || sum.norm() < 1e-9 || !tangent.allFinite() || tangent.norm() < 1e-9) {
    throw CompensationError("signed deviation", -1, Reason::bad_input,
                            "n_up + n_down or the tangent vanishes: the edge has no outside");
  }
  const Vec3 bisector = sum.normalized();
  const Vec3 t = tangent.normalized();
  EdgeDeviation deviation;
  const Vec3 difference = measured - reference;
  deviation.vector = difference - difference.dot(t) * t;
  deviation.outward_mm = deviation.vector.dot(bisector);
  deviation.sideways_mm = (deviation.vector - deviation.outward_mm * bisector).norm();
  const double magnitude = deviation.vector.norm();
  deviation.signed_mm = deviation.outward_mm < 0 ? -magnitude : magnitude;
  return deviation;
}

}  // namespace cmm::planner
