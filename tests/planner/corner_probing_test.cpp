// Corner probing against a perfect plate: touches planned from a rough pose, each simulated exactly
// (where the ball centre first comes within r of the true plate along its approach), give back the
// true corners and fiducial to 1e-9 mm; broken touch sets are refused naming the corner and face.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "planner/corner_probing.hpp"
#include "planner/plate_pose.hpp"
#include "planner/registration.hpp"

namespace cmm::planner {
namespace {

using ::testing::HasSubstr;
using nlohmann::json;

json plate_json(bool hole) {
  json j = {{"corners", {{0, 0, 0}, {200, 0, 0}, {200, 150, 0}, {0, 150, 0}}},
            {"thickness_mm", 10},
            {"fiducial", {{"kind", "chamfer"}, {"corner", 1}, {"size_mm", 5}}}};
  if (hole) j["fiducial"] = {{"kind", "hole"}, {"centre", {20, 15}}, {"diameter_mm", 6}};
  return j;
}

Eigen::Isometry3d pose(double turn_rad, double tilt_rad, const Vec3& translation) {
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  p.linear() = (Eigen::AngleAxisd(turn_rad, Vec3::UnitZ()) * Eigen::AngleAxisd(tilt_rad, Vec3(1, 2, 0).normalized()))
                   .toRotationMatrix();
  p.translation() = translation;
  return p;
}

// The true plate: a convex prism over its outline (the chamfer cut off), plus the fiducial hole.
class TruePlate {
 public:
  TruePlate(const description::Plate& plate, const Eigen::Isometry3d& T_M_P) : plate_(plate), T_M_P_(T_M_P) {
    const bool chamfer = plate.fiducial.kind == description::PlateFiducial::Kind::chamfer;
    for (int id = 1; id <= plate.corner_count(); ++id) {
      const Vec3& c = plate.corner(id);
      if (chamfer && plate.fiducial.corner == id) {
        const double s = plate.fiducial.size_mm;
        outline_.push_back(c + s * (plate.corner(plate.previous(id)) - c).normalized());
        outline_.push_back(c + s * (plate.corner(plate.next(id)) - c).normalized());
      } else {
        outline_.push_back(c);
      }
    }
    top_ = plate.top_z();
    bottom_ = top_ - plate.thickness_mm;
  }

  // The ball centre (M) where a ball of radius r moving from `start` along `direction` first
  // touches the plate, and how far it travelled; nullopt when the ball already touches at the start.
  struct Contact {
    Vec3 centre;
    double travel;
  };
  std::optional<Contact> touch(const Touch& t, double r, double limit = 1e3) const {
    const Eigen::Isometry3d T_P_M = T_M_P_.inverse();
    const Vec3 start = T_P_M * t.start, dir = T_P_M.linear() * t.direction;
    if (plate_.fiducial.kind == description::PlateFiducial::Kind::hole && t.target == TouchTarget::fiducial) {
      // Inside the hole's wall: the centre stays R − r from the axis.
      const Eigen::Vector2d p0 = start.head<2>() - plate_.fiducial.centre, v = dir.head<2>();
      const double rho = plate_.fiducial.diameter_mm / 2 - r;
      const double a = v.squaredNorm(), b = p0.dot(v), c = p0.squaredNorm() - rho * rho;
      const double s = (-b + std::sqrt(b * b - a * c)) / a;
      return Contact{T_M_P_ * (start + s * dir), s};
    }
    if (distance(start) <= r) return std::nullopt;
    // A face contact first: the centre enters the face's plane moved out by r, at its foot on the face.
    double entry = -1;
    Vec3 normal = Vec3::Zero();
    for (const auto& [n, d] : planes()) {
      const double denominator = n.dot(dir);
      if (denominator >= 0) continue;
      const double s = (d + r - n.dot(start)) / denominator;
      if (s > entry) {
        entry = s;
        normal = n;
      }
    }
    if (entry >= 0 && distance(start + entry * dir - r * normal) < 1e-12)
      return Contact{T_M_P_ * (start + entry * dir), entry};
    // An edge or vertex: the distance along the line is convex; bisect where it falls to r.
    double low = 0, high = 0;
    for (double step = 0.01; step < limit; step += 0.01)
      if (distance(start + step * dir) <= r) {
        high = step;
        break;
      }
    if (high == 0) return std::nullopt;
    low = high - 0.01;
    for (int i = 0; i < 200; ++i) {
      const double mid = (low + high) / 2;
      (distance(start + mid * dir) <= r ? high : low) = mid;
    }
    return Contact{T_M_P_ * (start + high * dir), high};
  }

 private:
  std::vector<std::pair<Vec3, double>> planes() const {
    std::vector<std::pair<Vec3, double>> p{{Vec3::UnitZ(), top_}, {-Vec3::UnitZ(), -bottom_}};
    for (std::size_t i = 0; i < outline_.size(); ++i) {
      const Vec3 e = outline_[(i + 1) % outline_.size()] - outline_[i];
      const Vec3 n = Vec3(e.y(), -e.x(), 0).normalized();
      p.emplace_back(n, n.dot(outline_[i]));
    }
    return p;
  }

  // Distance from a point (P) to the prism: the outline's and the height's distances combine.
  double distance(const Vec3& p) const {
    double outside = 0, nearest = INFINITY;
    bool inside = true;
    for (std::size_t i = 0; i < outline_.size(); ++i) {
      const Eigen::Vector2d a = outline_[i].head<2>(), b = outline_[(i + 1) % outline_.size()].head<2>();
      const Eigen::Vector2d e = b - a, q = p.head<2>() - a;
      if (e.x() * q.y() - e.y() * q.x() < 0) inside = false;
      const double t = std::clamp(q.dot(e) / e.squaredNorm(), 0.0, 1.0);
      nearest = std::min(nearest, (q - t * e).norm());
    }
    if (!inside) outside = nearest;
    const double vertical = std::max({0.0, p.z() - top_, bottom_ - p.z()});
    return std::hypot(outside, vertical);
  }

  const description::Plate& plate_;
  Eigen::Isometry3d T_M_P_;
  std::vector<Vec3> outline_;
  double top_ = 0, bottom_ = 0;
};

struct Probed {
  std::vector<Touch> touches;
  std::vector<Vec3> centres;
};

Probed probe(const description::Plate& plate, const Eigen::Isometry3d& rough, const TruePlate& truth,
             const CornerProbingOptions& options, bool require_within_travel = true) {
  Probed p;
  p.touches = plan_corner_touches(plate, rough, options);
  for (const Touch& t : p.touches) {
    const auto contact = truth.touch(t, options.ball_radius_mm);
    EXPECT_TRUE(contact.has_value()) << "touch " << t.id << " starts inside the plate";
    if (!contact) continue;
    if (require_within_travel) {
      EXPECT_GE(contact->travel, 0) << "touch " << t.id;
      EXPECT_LE(contact->travel, t.max_travel_mm) << "touch " << t.id;
    }
    p.centres.push_back(contact->centre);
  }
  return p;
}

CornerProbingOptions options() {
  CornerProbingOptions o;
  o.ball_radius_mm = 1;
  return o;
}

const Eigen::Isometry3d kTruth = pose(0.35, 0.004, Vec3(412.5, 233.25, -187.75));
// The operator's rough pose: 0.2° and about 0.6 mm off.
const Eigen::Isometry3d kRough = pose(0.35 + 0.2 * std::numbers::pi / 180, 0.0, Vec3(412.9, 232.85, -187.5));

TEST(CornerProbing, TouchesAreWellFormed) {
  const description::Plate plate = description::plate_from_json(plate_json(false));
  const CornerProbingOptions o = options();
  const std::vector<Touch> touches = plan_corner_touches(plate, kRough, o, 100);
  ASSERT_EQ(touches.size(), 4u * 9 + 3);
  for (std::size_t i = 0; i < touches.size(); ++i) {
    const Touch& t = touches[i];
    EXPECT_EQ(t.id, 100 + static_cast<int>(i));
    EXPECT_NEAR(t.direction.norm(), 1, 1e-12);
    EXPECT_NEAR((t.nominal_centre - (t.surface_point - o.ball_radius_mm * t.direction)).norm(), 0, 1e-12);
    const double search = t.max_travel_mm / 2;
    EXPECT_NEAR((t.start - (t.nominal_centre - search * t.direction)).norm(), 0, 1e-12);
    EXPECT_GE(search, o.search_mm);
    EXPECT_EQ(t.retract_mm, o.retract_mm);
    if (t.target == TouchTarget::plate_face) {
      EXPECT_EQ(t.corner, static_cast<int>(i) / 9 + 1);
      EXPECT_EQ(t.face, static_cast<int>(i) % 9 / 3);
      if (t.face == 0) EXPECT_NEAR((t.direction - kRough.linear() * -Vec3::UnitZ()).norm(), 0, 1e-12);
      else EXPECT_NEAR(t.direction.dot(kRough.linear() * Vec3::UnitZ()), 0, 1e-12);  // horizontal in P
    } else {
      EXPECT_EQ(t.target, TouchTarget::fiducial);
      EXPECT_EQ(t.corner, 1);
    }
  }
  // Side contacts: two at one height, one at another, so the three are not collinear.
  const Eigen::Isometry3d P_M = kRough.inverse();
  EXPECT_NEAR((P_M * touches[3].surface_point).z(), (P_M * touches[4].surface_point).z(), 1e-9);
  EXPECT_GT(std::abs((P_M * touches[3].surface_point).z() - (P_M * touches[5].surface_point).z()), 1);
}

TEST(CornerProbing, RecoversThePerfectPlatesCornersAndChamfer) {
  const description::Plate plate = description::plate_from_json(plate_json(false));
  const TruePlate truth(plate, kTruth);
  const CornerProbingOptions o = options();
  const Probed p = probe(plate, kRough, truth, o);
  ASSERT_EQ(p.centres.size(), p.touches.size());
  const std::vector<CornerFit> corners = fit_corners(plate, p.touches, p.centres, o);
  std::vector<int> ids;
  std::vector<Vec3> measured;
  for (const CornerFit& c : corners) {
    EXPECT_NEAR((c.position - kTruth * plate.corner(c.corner)).norm(), 0, 1e-9) << "corner " << c.corner;
    EXPECT_NEAR((c.faces[0].normal - kTruth.linear() * Vec3::UnitZ()).norm(), 0, 1e-12);
    EXPECT_NEAR(c.conditioning, 1, 1e-9);
    EXPECT_LT(c.face_rms_mm[1], 1e-9);
    EXPECT_NEAR((corner_from_touches(c.corner, p.touches, p.centres, o) - c.position).norm(), 0, 1e-15);
    ids.push_back(c.corner);
    measured.push_back(c.position);
  }
  const Eigen::Isometry3d fitted = fit_plate_pose(plate, ids, measured);
  const FiducialFit f = locate_fiducial(plate, fitted, p.touches, p.centres, o);
  const description::FiducialDeviation d = description::fiducial_deviation(plate, kTruth.inverse() * f.point);
  EXPECT_LT(d.off_mm, 1e-9);
  EXPECT_EQ(d.outside_mm, 0);

  // And the registration from these, with the scan's exact corners, checks the order and fits exactly.
  const Eigen::Isometry3d T_S_P = pose(-1.1, 0.02, Vec3(-40, 75, 310));
  RegistrationInput in;
  for (int id : ids) in.corners.push_back({id, T_S_P * plate.corner(id), measured[static_cast<std::size_t>(id - 1)]});
  in.fiducial_machine = f.point;
  const RegistrationResult r = fit_registration(in, &plate);
  EXPECT_TRUE(r.order_verified);
  EXPECT_NEAR((r.T_M_S.matrix() - (kTruth * T_S_P.inverse()).matrix()).cwiseAbs().maxCoeff(), 0, 1e-9);
}

TEST(CornerProbing, LocatesAHoleFiducial) {
  const description::Plate plate = description::plate_from_json(plate_json(true));
  const TruePlate truth(plate, kTruth);
  const CornerProbingOptions o = options();
  const Probed p = probe(plate, kRough, truth, o);
  ASSERT_EQ(p.touches.size(), 4u * 9 + 4);
  for (const Touch& t : p.touches)
    if (t.target == TouchTarget::fiducial) {
      EXPECT_NEAR(t.max_travel_mm, 2 * (3 - o.ball_radius_mm), 1e-12);  // from the axis, R − r each way
      EXPECT_EQ(t.corner, -1);
    }
  std::vector<int> ids;
  std::vector<Vec3> measured;
  for (const CornerFit& c : fit_corners(plate, p.touches, p.centres, o)) {
    EXPECT_NEAR((c.position - kTruth * plate.corner(c.corner)).norm(), 0, 1e-9);
    ids.push_back(c.corner);
    measured.push_back(c.position);
  }
  const FiducialFit f = locate_fiducial(plate, fit_plate_pose(plate, ids, measured), p.touches, p.centres, o);
  EXPECT_NEAR(f.diameter_mm, 6, 1e-9);
  EXPECT_LT(f.rms_mm, 1e-9);
  const description::FiducialDeviation d = description::fiducial_deviation(plate, kTruth.inverse() * f.point);
  EXPECT_LT(d.off_mm, 1e-9);
  EXPECT_EQ(d.outside_mm, 0);
}

TEST(CornerProbing, CornersLabelledFromTheOppositeCornerAreRefusedAtTheFiducial) {
  // The operator's rough corners start at corner 3: the rough pose is turned by 180°. The corner
  // touches still meet true faces; the chamfer's touches meet a plain corner's sides early.
  const description::Plate plate = description::plate_from_json(plate_json(false));
  const TruePlate truth(plate, kTruth);
  const CornerProbingOptions o = options();
  std::vector<int> ids{1, 2, 3, 4};
  std::vector<Vec3> rough_corners;
  for (int id : ids) rough_corners.push_back(kRough * plate.corner((id + 1) % 4 + 1));
  const Eigen::Isometry3d rough = fit_plate_pose(plate, ids, rough_corners);
  const Probed p = probe(plate, rough, truth, o);
  std::vector<Vec3> measured;
  for (const CornerFit& c : fit_corners(plate, p.touches, p.centres, o)) {
    EXPECT_NEAR((c.position - kTruth * plate.corner((c.corner + 1) % 4 + 1)).norm(), 0, 1e-9);
    measured.push_back(c.position);
  }
  const FiducialFit f = locate_fiducial(plate, fit_plate_pose(plate, ids, measured), p.touches, p.centres, o);
  const Eigen::Isometry3d T_S_P = pose(-1.1, 0.02, Vec3(-40, 75, 310));
  RegistrationInput in;
  for (int id : ids) in.corners.push_back({id, T_S_P * plate.corner(id), measured[static_cast<std::size_t>(id - 1)]});
  in.fiducial_machine = f.point;
  try {
    fit_registration(in, &plate);
    ADD_FAILURE() << "a mislabelled plate was registered";
  } catch (const RegistrationError& e) {
    EXPECT_EQ(e.kind(), RegistrationError::Kind::fiducial);
    EXPECT_THAT(e.what(), HasSubstr("the chamfer at corner 1 is not where corner 1 should be"));
    EXPECT_THAT(e.what(), HasSubstr("the plate looks the same with its corners shifted by 2"));
  }
}

TEST(CornerProbing, RefusesTouchSetsThatCannotGiveACorner) {
  const description::Plate plate = description::plate_from_json(plate_json(false));
  const TruePlate truth(plate, kTruth);
  const CornerProbingOptions o = options();
  Probed p = probe(plate, kRough, truth, o);
  auto message = [&](const std::vector<Touch>& touches, const std::vector<Vec3>& centres, int corner) {
    try {
      fit_corner(corner, touches, centres, o);
    } catch (const RegistrationError& e) {
      EXPECT_EQ(e.kind(), RegistrationError::Kind::probing);
      return std::string(e.what());
    }
    return std::string("(no RegistrationError)");
  };
  // Two touches on corner 2's top.
  std::vector<Touch> fewer = p.touches;
  fewer[9].corner = 7;
  EXPECT_THAT(message(fewer, p.centres, 2), HasSubstr("corner 2, face 0 (top): 2 touches, a plane needs three"));
  // Three collinear centres on corner 3's side toward corner 4.
  std::vector<Vec3> collinear = p.centres;
  collinear[18 + 3 + 2] = (collinear[18 + 3] + collinear[18 + 4]) / 2;
  EXPECT_THAT(message(p.touches, collinear, 3), HasSubstr("corner 3, face 1 (side toward the next corner)"));
  EXPECT_THAT(message(p.touches, collinear, 3), HasSubstr("collinear"));
  // A side face measured as if it were parallel to the other: the corner is undetermined.
  std::vector<Vec3> parallel = p.centres;
  for (int i = 0; i < 3; ++i)  // corner 1's side toward corner 4 taken as its side toward corner 2, moved 30 mm
    parallel[static_cast<std::size_t>(6 + i)] = p.centres[static_cast<std::size_t>(3 + i)] + kTruth.linear() * Vec3(0, 30, 0);
  EXPECT_THAT(message(p.touches, parallel, 1), HasSubstr("corner 1: the three planes nearly share a direction"));
  EXPECT_THAT(message(p.touches, std::vector<Vec3>(p.centres.begin(), p.centres.end() - 1), 1),
              HasSubstr("touches but"));
}

TEST(CornerProbing, RefusesAPlateTooThinOrAHoleTooSmallForTheBall) {
  json thin = plate_json(false);
  thin["thickness_mm"] = 3;
  try {
    plan_corner_touches(description::plate_from_json(thin), kRough, options());
    ADD_FAILURE() << "no error";
  } catch (const RegistrationError& e) {
    EXPECT_THAT(e.what(), HasSubstr("the plate is 3.00 mm thick: too thin for three touches at two heights"));
  }
  json small_hole = plate_json(true);
  small_hole["fiducial"]["diameter_mm"] = 2;
  try {
    plan_corner_touches(description::plate_from_json(small_hole), kRough, options());
    ADD_FAILURE() << "no error";
  } catch (const RegistrationError& e) {
    EXPECT_THAT(e.what(), HasSubstr("the fiducial hole (Ø2.00 mm) is too small for a Ø2.00 mm ball"));
  }
}

}  // namespace
}  // namespace cmm::planner
