// The simulator's config block: {} is a working machine, and one pass names every bad key.
#include "sim/sim_config.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace cmm::sim {
namespace {

using ::testing::HasSubstr;
using ::testing::UnorderedElementsAre;

TEST(SimConfig, EmptyBlockIsTheDefaultMachine) {
  SimConfig c = sim_config_from_json(nlohmann::json::object());
  EXPECT_EQ(c.machine.active_tip, "T1");
  EXPECT_EQ(c.plate.corner_count(), 4);
  EXPECT_EQ(c.part.analytic, "case3_block");
  EXPECT_EQ(c.home_position, c.machine.travel_box.max);
  EXPECT_DOUBLE_EQ(c.trigger_sigma_mm, 0.001);
  EXPECT_EQ(c.time_scale, 0);
}

TEST(SimConfig, ReadsPosesAndFaults) {
  SimConfig c = sim_config_from_json(nlohmann::json::parse(R"({
    "plate_pose": {"rotation_deg": [0, 0, 90], "translation": [300, 200, 5]},
    "part": {"analytic": "cube", "edge_length_mm": 4},
    "faults": {"drop_link_after_commands": 7, "estop_at_s": 12.5},
    "true_tips": {"T2": {"ball_radius_mm": 2.49}}})"));
  EXPECT_LT((c.T_M_P * Vec3(1, 0, 0) - Vec3(300, 201, 5)).norm(), 1e-12);
  EXPECT_EQ(c.part.analytic, "cube");
  EXPECT_EQ(c.faults.drop_link_after_commands, 7);
  EXPECT_DOUBLE_EQ(c.faults.estop_at_s, 12.5);
  EXPECT_DOUBLE_EQ(c.true_tips.at("T2").ball_radius_mm, 2.49);
}

TEST(SimConfig, NamesEveryBadKeyByItsPath) {
  try {
    sim_config_from_json(nlohmann::json::parse(R"({
      "part": {"analytic": "teapot", "edge_lenght_mm": 1},
      "trigger_sigma_mm": -1, "time_scale": "fast", "home_position": [0, 0, 9999],
      "faults": {"reply_delay_s": -2, "estop": 3},
      "true_tips": {"T9": {"ball_radius_mm": 1}},
      "machine": {"travel_box": 5},
      "colour": "blue"})"));
    FAIL() << "no FieldError";
  } catch (const description::FieldError& e) {
    // The inline machine's own problems come under /machine, each at its pointer inside it.
    std::vector<std::string> outside_machine;
    for (const std::string& line : e.lines())
      if (line.rfind("/machine/", 0) != 0) outside_machine.push_back(line);
    EXPECT_THAT(outside_machine,
                UnorderedElementsAre(HasSubstr("/part/analytic: must be one of"), HasSubstr("/part/edge_lenght_mm: unknown key"),
                                     HasSubstr("/trigger_sigma_mm: must be in [0, 1]"),
                                     HasSubstr("/time_scale: must be a number"),
                                     HasSubstr("/home_position: must lie inside"),
                                     HasSubstr("/faults/reply_delay_s: must be in"), HasSubstr("/faults/estop: unknown key"),
                                     HasSubstr("/true_tips/T9: no tip with this id"), HasSubstr("/colour: unknown key")));
    EXPECT_THAT(e.lines(), ::testing::Contains(HasSubstr("/machine/travel_box: must be an object")));
    EXPECT_THAT(e.lines(), ::testing::Contains(HasSubstr("/machine/max_speed_mm_s: missing")));
  }
}

TEST(SimConfig, MachineAndPlateFilesResolveAgainstTheBaseDirectory) {
  SimConfig c = sim_config_from_json({{"machine", "config/machine.json"}, {"plate", "config/plate.json"}}, CMMD_SOURCE_DIR);
  EXPECT_EQ(c.machine.tips.size(), 2u);
  EXPECT_THROW(sim_config_from_json({{"machine", "no/such.json"}}, CMMD_SOURCE_DIR), description::FieldError);
}

}  // namespace
}  // namespace cmm::sim
