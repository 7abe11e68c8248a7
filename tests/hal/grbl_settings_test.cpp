// The Grbl driver's config block: what Grbl does not know (the machine description) comes from it,
// inline or as a file, and one pass names every bad key by its JSON Pointer.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "hal/description/json_fields.hpp"
#include "hal/grbl_cmm.hpp"

namespace cmm::hal {
namespace {

using ::testing::HasSubstr;
using ::testing::UnorderedElementsAre;

TEST(GrblSettings, ReadsTheMachineGrblDoesNotKnow) {
  nlohmann::json machine = description::to_json(description::default_machine());
  machine["travel_box"] = {{"min", {0, 0, -50}}, {"max", {300, 200, 100}}};
  machine["clearance_z"] = 50;
  machine["active_tip"] = "T2";
  GrblSettings s = grbl_settings_from_json(
      {{"driver", "grbl"}, {"device", "/dev/ttyACM0"}, {"reset_on_open", false}, {"machine", machine}});
  EXPECT_EQ(s.device, "/dev/ttyACM0");
  EXPECT_FALSE(s.reset_on_open);
  EXPECT_EQ(s.machine.travel_box.max, Vec3(300, 200, 100));
  ASSERT_EQ(s.machine.tips.size(), 2u);
  EXPECT_EQ(s.machine.active_tip, "T2");
  EXPECT_DOUBLE_EQ(s.machine.reference_sphere.radius_mm, 12.5);
  // A file name resolves against the base folder.
  EXPECT_EQ(grbl_settings_from_json({{"device", "x"}, {"machine", "config/machine.json"}}, CMMD_SOURCE_DIR).machine.tips.size(),
            2u);
}

// Grbl knows no travel box: a block without the machine's description (or naming none) is refused
// rather than run inside the sample machine's box.
TEST(GrblSettings, RequiresTheMachineDescription) {
  for (const nlohmann::json& block : {nlohmann::json{{"device", "/dev/ttyACM0"}},
                                      nlohmann::json{{"device", "/dev/ttyACM0"}, {"machine", ""}}}) {
    try {
      grbl_settings_from_json(block);
      FAIL() << "no FieldError for " << block.dump();
    } catch (const description::FieldError& e) {
      EXPECT_EQ(e.pointer(), "/machine") << block.dump();
      EXPECT_EQ(e.problems().size(), 1u) << block.dump();
    }
  }
}

TEST(GrblSettings, NamesEveryBadKey) {
  nlohmann::json machine = description::to_json(description::default_machine());
  machine["tips"][0]["ball_radius_mm"] = -1;
  machine["active_tip"] = "T7";
  try {
    grbl_settings_from_json({{"baud", 12}, {"reset_on_open", "yes"}, {"machine", machine}, {"travel_box", 1}});
    FAIL() << "no FieldError";
  } catch (const description::FieldError& e) {
    EXPECT_THAT(e.lines(), UnorderedElementsAre(HasSubstr("/device: the serial device is required"),
                                                HasSubstr("/baud: must be an integer in"),
                                                HasSubstr("/reset_on_open: must be true or false"),
                                                HasSubstr("/machine/tips/0/ball_radius_mm: must be positive"),
                                                HasSubstr("/machine/active_tip: \"T7\" is not among the tips"),
                                                HasSubstr("/travel_box: unknown key")));
  }
}

}  // namespace
}  // namespace cmm::hal
