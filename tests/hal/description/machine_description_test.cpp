// machine.json: the built-in default parses and round-trips; every bad description is refused with
// the file and each bad field named by its JSON Pointer, all at once, so an operator fixes it in one
// edit without reading code.
#include <unistd.h>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "hal/description/json_fields.hpp"
#include "hal/description/machine_description.hpp"

namespace cmm::description {
namespace {

using ::testing::HasSubstr;
using nlohmann::json;

std::string refusal(const json& j) {
  try {
    machine_from_json(j, "machine.json");
  } catch (const FieldError& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(MachineDescription, DefaultIsConfigMachineJsonAndRoundTrips) {
  const MachineDescription m = default_machine();
  EXPECT_EQ(m.active_tip, "T1");
  EXPECT_EQ(m.tip().ball_radius_mm, 1.0);
  EXPECT_EQ(m.tips.size(), 2u);
  EXPECT_EQ(m.travel_box.max, Vec3(700, 900, 450));
  EXPECT_EQ(m.find_tip("T2")->ball_radius_mm, 2.5);
  EXPECT_EQ(m.find_tip("T9"), nullptr);
  const MachineDescription again = machine_from_json(to_json(m));
  EXPECT_EQ(to_json(again), to_json(m));
  std::ifstream in(CMMD_SOURCE_DIR "/config/machine.json");
  EXPECT_EQ(to_json(machine_from_json(json::parse(in))), to_json(m));
}

TEST(MachineDescription, BadFieldsAreNamedByTheirPointer) {
  const json good = to_json(default_machine());
  auto with = [&](const std::string& pointer, const json& value) {
    json j = good;
    j[json::json_pointer(pointer)] = value;
    return refusal(j);
  };
  EXPECT_EQ(refusal(good), "(accepted)");
  EXPECT_EQ(with("/max_speed_mm_s", -5), "machine.json: /max_speed_mm_s: must be positive, not -5");
  EXPECT_THAT(with("/travel_box/min", json::array({0, 0})), HasSubstr("/travel_box/min: must be [x, y, z]"));
  EXPECT_THAT(with("/travel_box/min", json::array({800, 0, 0})), HasSubstr("/travel_box: min must be below max"));
  EXPECT_THAT(with("/clearance_z", 1000), HasSubstr("/clearance_z: lies outside the travel box"));
  EXPECT_THAT(with("/probe_speed_mm_s", 500), HasSubstr("/probe_speed_mm_s: exceeds max_speed_mm_s"));
  EXPECT_THAT(with("/active_tip", "T9"), HasSubstr("/active_tip: \"T9\" is not among the tips"));
  EXPECT_THAT(with("/tips/1/id", "T1"), HasSubstr("/tips/1/id: duplicates tip \"T1\""));
  EXPECT_THAT(with("/tips/0/shaft_radius_mm", 2), HasSubstr("/tips/0/shaft_radius_mm: is wider than the ball"));
  EXPECT_THAT(with("/tips/0/direction", json::array({0, 0, 0})), HasSubstr("/tips/0/direction: must not be zero"));
  EXPECT_THAT(with("/tips/0/shaft_length_mm", 0.5), HasSubstr("/tips/0/shaft_length_mm: does not reach past the ball"));
  EXPECT_THAT(with("/tips/0", json::array({1, 2})), HasSubstr("/tips/0: must be an object"));
  EXPECT_THAT(with("/travel_box/mx", 1), HasSubstr("/travel_box/mx: unknown key (known: max, min)"));
  EXPECT_THAT(with("/reference_sphere/radius", 1), HasSubstr("/reference_sphere/radius: unknown key"));
  EXPECT_THAT(with("/max_speed", 5), HasSubstr("/max_speed: unknown key"));
  EXPECT_THAT(with("/tips/0/ball_radius", 5), HasSubstr("/tips/0/ball_radius: unknown key"));
  json missing = good;
  missing.erase("clearance_z");
  EXPECT_EQ(refusal(missing), "machine.json: /clearance_z: missing");
  EXPECT_THAT(refusal(json::array()), HasSubstr("must be an object"));
}

TEST(MachineDescription, EveryProblemAtOnce) {
  json j = to_json(default_machine());
  j["max_speed_mm_s"] = "fast";
  j["tips"][1]["ball_radius_mm"] = 0;
  j["colour"] = "grey";
  j.erase("active_tip");
  try {
    machine_from_json(j, "machine.json");
    FAIL() << "accepted";
  } catch (const FieldError& e) {
    std::vector<std::string> pointers;
    for (const FieldProblem& p : e.problems()) pointers.push_back(p.pointer);
    // The unknown key first: a misspelling is often why another key is missing.
    EXPECT_THAT(pointers, ::testing::ElementsAre("/colour", "/max_speed_mm_s", "/tips/1/ball_radius_mm", "/active_tip"));
    EXPECT_THAT(e.what(), HasSubstr("machine.json: 4 problems"));
    EXPECT_EQ(e.pointer(), "/colour");
  }
}

TEST(MachineDescription, TheQualificationIsStateNotDescription) {
  MachineDescription m = default_machine();
  m.tips[0].qualification = TipQualification{0.9985, Vec3(0.001, 0, 0), 0.0004, 9, "2026-12-01T10:00:00Z"};
  EXPECT_FALSE(to_json(m)["tips"][0].contains("qualification"));
}

TEST(MachineDescription, UnreadableFilesAreNamed) {
  const std::filesystem::path file = std::filesystem::temp_directory_path() / ("cmmd_machine_test_" + std::to_string(getpid()) + ".json");
  std::ofstream(file) << "{\"travel_box\": ";
  try {
    read_machine(file);
    ADD_FAILURE() << "a truncated file was accepted";
  } catch (const FieldError& e) {
    EXPECT_THAT(e.what(), HasSubstr(file.string() + ": not valid JSON at byte"));
  }
  std::filesystem::remove(file);
  try {
    read_machine(file);
    ADD_FAILURE() << "a missing file was accepted";
  } catch (const FieldError& e) {
    EXPECT_THAT(e.what(), HasSubstr(file.string() + ": cannot open the machine description"));
  }
}

}  // namespace
}  // namespace cmm::description
