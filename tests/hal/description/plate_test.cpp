// The plate description: config/plate.json reads back as the 200 × 150 × 10 mm plate with its chamfer,
// its geometry answers are exact, and every broken description is refused naming the field by its
// JSON Pointer.
#include <unistd.h>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <numbers>
#include <string>

#include "hal/description/json_fields.hpp"
#include "hal/description/plate.hpp"

namespace cmm::description {
namespace {

using ::testing::AllOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::Not;
using nlohmann::json;

json rectangle(double x = 200, double y = 150) {
  return {{"corners", {{0, 0, 0}, {x, 0, 0}, {x, y, 0}, {0, y, 0}}},
          {"thickness_mm", 10},
          {"fiducial", {{"kind", "chamfer"}, {"corner", 1}, {"size_mm", 5}}}};
}

std::string error_of(const json& j) {
  try {
    plate_from_json(j, "plate.json");
  } catch (const FieldError& e) {
    return e.what();
  }
  return "(no FieldError)";
}

TEST(Plate, ConfigExampleIsTheChamferedRectangle) {
  const Plate plate = read_plate(std::filesystem::path(CMMD_SOURCE_DIR) / "config" / "plate.json");
  ASSERT_EQ(plate.corner_count(), 4);
  EXPECT_EQ(plate.corner(1), Vec3(0, 0, 0));
  EXPECT_EQ(plate.corner(3), Vec3(200, 150, 0));
  EXPECT_EQ(plate.thickness_mm, 10);
  EXPECT_EQ(plate.fiducial.kind, PlateFiducial::Kind::chamfer);
  EXPECT_EQ(plate.fiducial.corner, 1);
  EXPECT_EQ(plate.fiducial.size_mm, 5);
  EXPECT_EQ(plate.next(4), 1);
  EXPECT_EQ(plate.previous(1), 4);
  EXPECT_TRUE(plate.adjacent(4, 1));
  EXPECT_FALSE(plate.adjacent(1, 3));
}

TEST(Plate, RoundTripsThroughJson) {
  const Plate plate = plate_from_json(rectangle());
  const Plate again = plate_from_json(to_json(plate));
  EXPECT_EQ(again.corners, plate.corners);
  EXPECT_EQ(again.thickness_mm, plate.thickness_mm);
  EXPECT_EQ(again.fiducial.corner, plate.fiducial.corner);
  json hole = rectangle();
  hole["fiducial"] = {{"kind", "hole"}, {"centre", {20, 15}}, {"diameter_mm", 6}};
  const Plate with_hole = plate_from_json(to_json(plate_from_json(hole)));
  EXPECT_EQ(with_hole.fiducial.kind, PlateFiducial::Kind::hole);
  EXPECT_EQ(with_hole.fiducial.centre, Eigen::Vector2d(20, 15));
  EXPECT_EQ(with_hole.fiducial.depth_mm, 10);  // through
}

TEST(Plate, TwoDimensionalCornersSitAtZeroHeight) {
  json j = rectangle();
  j["corners"] = {{0, 0}, {200, 0}, {200, 150}, {0, 150}};
  EXPECT_EQ(plate_from_json(j).corner(2), Vec3(200, 0, 0));
}

TEST(Plate, SideNormalsPointOut) {
  const Plate plate = plate_from_json(rectangle());
  EXPECT_NEAR((side_normal(plate, 1) - Vec3(0, -1, 0)).norm(), 0, 1e-15);
  EXPECT_NEAR((side_normal(plate, 2) - Vec3(1, 0, 0)).norm(), 0, 1e-15);
  EXPECT_NEAR((side_normal(plate, 3) - Vec3(0, 1, 0)).norm(), 0, 1e-15);
  EXPECT_NEAR((side_normal(plate, 4) - Vec3(-1, 0, 0)).norm(), 0, 1e-15);
}

TEST(Plate, ChamferGeometryAndDeviation) {
  const Plate plate = plate_from_json(rectangle());
  const FiducialGeometry g = fiducial_geometry(plate);
  EXPECT_NEAR((g.point - Vec3(2.5, 2.5, -5)).norm(), 0, 1e-12);
  EXPECT_NEAR((g.normal - Vec3(-1, -1, 0).normalized()).norm(), 0, 1e-12);
  EXPECT_NEAR(g.half_width_mm, 5 / std::numbers::sqrt2, 1e-12);
  EXPECT_EQ(g.bottom_z, -10);
  // Any point of the chamfer face is on it; off the face's plane or past its edges is not.
  const FiducialDeviation on = fiducial_deviation(plate, Vec3(4, 1, -9));
  EXPECT_NEAR(on.off_mm, 0, 1e-12);
  EXPECT_EQ(on.outside_mm, 0);
  const FiducialDeviation off = fiducial_deviation(plate, g.point + 0.3 * g.normal);
  EXPECT_NEAR(off.off_mm, 0.3, 1e-12);
  const FiducialDeviation beyond = fiducial_deviation(plate, Vec3(7, -2, -5));  // on the plane, past corner 2's side
  EXPECT_NEAR(beyond.off_mm, 0, 1e-12);
  EXPECT_NEAR(beyond.outside_mm, (Vec3(7, -2, 0) - Vec3(2.5, 2.5, 0)).norm() - g.half_width_mm, 1e-12);
  EXPECT_NEAR(fiducial_deviation(plate, Vec3(2.5, 2.5, 1)).outside_mm, 1, 1e-12);  // above the top
}

TEST(Plate, HoleGeometryAndDeviation) {
  json j = rectangle();
  j["fiducial"] = {{"kind", "hole"}, {"centre", {20, 15}}, {"diameter_mm", 6}};
  const Plate plate = plate_from_json(j);
  const FiducialGeometry g = fiducial_geometry(plate);
  EXPECT_EQ(g.point, Vec3(20, 15, -5));
  EXPECT_EQ(g.half_width_mm, 3);
  EXPECT_NEAR(fiducial_deviation(plate, Vec3(20, 15, -2)).off_mm, 0, 1e-12);
  EXPECT_NEAR(fiducial_deviation(plate, Vec3(20.3, 15.4, -2)).off_mm, 0.5, 1e-12);
  EXPECT_NEAR(fiducial_deviation(plate, Vec3(20, 15, -12)).outside_mm, 2, 1e-12);
}

TEST(Plate, SymmetryShifts) {
  EXPECT_THAT(symmetry_shifts(plate_from_json(rectangle())), ElementsAre(2));
  EXPECT_THAT(symmetry_shifts(plate_from_json(rectangle(150, 150))), ElementsAre(1, 2, 3));
  json trapezoid = rectangle();
  trapezoid["corners"] = {{0, 0, 0}, {200, 0, 0}, {180, 150, 0}, {20, 150, 0}};
  EXPECT_TRUE(symmetry_shifts(plate_from_json(trapezoid)).empty());
}

TEST(Plate, RefusesBrokenDescriptionsNamingTheField) {
  json j = rectangle();
  j["corners"] = {{0, 0, 0}, {0, 150, 0}, {200, 150, 0}, {200, 0, 0}};
  EXPECT_THAT(error_of(j), HasSubstr("counter-clockwise"));

  j = rectangle();
  j["corners"] = {{0, 0, 0}, {200, 0, 0}, {100, 20, 0}, {0, 150, 0}};  // not convex
  EXPECT_THAT(error_of(j), HasSubstr("corner 3 turns clockwise"));

  j = rectangle();
  j["corners"][2] = {200, 150, 1};
  EXPECT_THAT(error_of(j), HasSubstr("plate.json: /corners/2: every corner lies on the top face"));

  j = rectangle();
  j["corners"] = {{0, 0, 0}, {200, 0, 0}};
  EXPECT_THAT(error_of(j), HasSubstr("/corners: must hold at least three corners"));

  j = rectangle();
  j["corners"][1] = {200, "x", 0};
  EXPECT_THAT(error_of(j), HasSubstr("/corners/1/1: must be a finite number"));

  j = rectangle();
  j.erase("thickness_mm");
  EXPECT_THAT(error_of(j), HasSubstr("/thickness_mm: missing"));

  j = rectangle();
  j["thickness_mm"] = -1;
  EXPECT_THAT(error_of(j), HasSubstr("/thickness_mm: must be positive"));

  j = rectangle();
  j["thicknes_mm"] = 10;
  EXPECT_THAT(error_of(j), HasSubstr("/thicknes_mm: unknown key"));

  j = rectangle();
  j.erase("fiducial");
  EXPECT_THAT(error_of(j), HasSubstr("/fiducial: missing"));

  j = rectangle();
  j["fiducial"]["kind"] = "notch";
  EXPECT_THAT(error_of(j), HasSubstr("/fiducial/kind: must be one of chamfer, hole, not \"notch\""));

  j = rectangle();
  j["fiducial"]["corner"] = 5;
  EXPECT_THAT(error_of(j), HasSubstr("/fiducial/corner: 5 is not a corner id"));

  j = rectangle();
  j["fiducial"]["size_mm"] = 80;
  EXPECT_THAT(error_of(j), HasSubstr("/fiducial/size_mm: 80.00 mm is more than half the shortest side"));

  j = rectangle();
  j["fiducial"] = {{"kind", "hole"}, {"centre", {2, 15}}, {"diameter_mm", 6}};
  EXPECT_THAT(error_of(j), HasSubstr("/fiducial/centre: the hole does not fit inside the plate"));

  j = rectangle();
  j["fiducial"] = {{"kind", "hole"}, {"centre", {100, 75}}, {"diameter_mm", 6}};  // the rectangle's centre
  EXPECT_THAT(error_of(j), HasSubstr("cannot tell those corners apart"));
  j = rectangle(150, 150);  // a square's three symmetries say it once
  j["fiducial"] = {{"kind", "hole"}, {"centre", {75, 75}}, {"diameter_mm", 6}};
  EXPECT_THAT(error_of(j), AllOf(HasSubstr("cannot tell those corners apart"), Not(HasSubstr("problems"))));

  j = rectangle();
  j["fiducial"] = {{"kind", "hole"}, {"centre", {20, 15}}, {"diameter_mm", 6}, {"depth_mm", 12}};
  EXPECT_THAT(error_of(j), HasSubstr("/fiducial/depth_mm: 12.00 mm is deeper than the plate"));
}

TEST(Plate, ReadErrorsNameTheFile) {
  const auto dir = std::filesystem::temp_directory_path() / ("cmmd_plate_test_" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  const auto broken = dir / "broken.json";
  std::ofstream(broken) << "{\"corners\": [";
  try {
    read_plate(broken);
    ADD_FAILURE() << "no error";
  } catch (const FieldError& e) {
    EXPECT_THAT(e.what(), HasSubstr("broken.json: not valid JSON at byte"));
  }
  try {
    read_plate(dir / "missing.json");
    ADD_FAILURE() << "no error";
  } catch (const FieldError& e) {
    EXPECT_THAT(e.what(), HasSubstr("missing.json: cannot open"));
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace cmm::description
