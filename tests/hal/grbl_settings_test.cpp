// The Grbl driver's config block: what Grbl does not know comes from here, and one pass names every
// bad key by its JSON Pointer, tips by their index.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "hal/config_block.hpp"
#include "hal/grbl_cmm.hpp"

namespace cmm::hal {
namespace {

using ::testing::HasSubstr;
using ::testing::UnorderedElementsAre;

TEST(GrblSettings, ReadsTheMachineGrblDoesNotKnow) {
  GrblSettings s = grbl_settings_from_json(nlohmann::json::parse(R"({
    "driver": "grbl", "device": "/dev/ttyACM0", "reset_on_open": false,
    "travel_box": {"min": [0, 0, -50], "max": [300, 200, 100]},
    "tips": [{"id": "T1", "ball_radius_mm": 1.5, "offset": [0, 0, -0.25]}, {"id": "T2"}],
    "active_tip": "T2", "reference_sphere": {"centre": [250, 150, 20], "radius_mm": 12.5}})"));
  EXPECT_EQ(s.device, "/dev/ttyACM0");
  EXPECT_FALSE(s.reset_on_open);
  EXPECT_EQ(s.travel_box.max, Vec3(300, 200, 100));
  ASSERT_EQ(s.tips.size(), 2u);
  EXPECT_DOUBLE_EQ(s.tips[0].ball_radius_mm, 1.5);
  EXPECT_EQ(s.tips[0].offset, Vec3(0, 0, -0.25));
  EXPECT_EQ(s.active_tip, "T2");
  EXPECT_DOUBLE_EQ(s.reference_sphere.radius_mm, 12.5);
}

TEST(GrblSettings, NamesEveryBadKey) {
  try {
    grbl_settings_from_json(nlohmann::json::parse(R"({
      "baud": 12, "travel_box": {"min": [0, 0, 0], "max": [10, 10, -1], "extra": 1},
      "tips": [{"id": "T1", "ball_radius_mm": -1}, {"ball_radius_mm": 1}], "active_tip": "T7",
      "reset_on_open": "yes"})"));
    FAIL() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.problems(), UnorderedElementsAre(
                                  HasSubstr("/device: the serial device is required"), HasSubstr("/baud: must be in"),
                                  HasSubstr("/travel_box/extra: unknown key"), HasSubstr("/travel_box: max must exceed min"),
                                  HasSubstr("/tips/0/ball_radius_mm: must be in"), HasSubstr("/tips/1/id: a tip needs an id"),
                                  HasSubstr("/active_tip: no tip \"T7\""), HasSubstr("/reset_on_open: must be true or false")));
  }
}

}  // namespace
}  // namespace cmm::hal
