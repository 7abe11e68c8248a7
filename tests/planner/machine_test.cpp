// machine.json: the built-in default parses and round-trips; every bad description is refused with
// the file and the field named, so an operator can fix it without reading code.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "geometry/file_error.hpp"
#include "planner/machine.hpp"

namespace cmm::planner {
namespace {

using nlohmann::json;

std::string refusal(const json& j) {
  try {
    machine_from_json(j, "machine.json");
  } catch (const geometry::FileError& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(Machine, DefaultIsConfigMachineJsonAndRoundTrips) {
  const MachineDescription m = default_machine();
  EXPECT_EQ(m.active_tip, "T1");
  EXPECT_EQ(m.tip().ball_radius_mm, 1.0);
  EXPECT_EQ(m.tips.size(), 2u);
  EXPECT_EQ(m.travel_box.max, Vec3(700, 900, 450));
  const MachineDescription again = machine_from_json(to_json(m));
  EXPECT_EQ(to_json(again), to_json(m));
  std::ifstream in(CMMD_SOURCE_DIR "/config/machine.json");
  EXPECT_EQ(to_json(machine_from_json(json::parse(in))), to_json(m));
}

TEST(Machine, BadFieldsAreNamed) {
  const json good = to_json(default_machine());
  auto with = [&](const std::string& pointer, const json& value) {
    json j = good;
    j[json::json_pointer(pointer)] = value;
    return refusal(j);
  };
  EXPECT_EQ(refusal(good), "(accepted)");
  EXPECT_EQ(with("/max_speed_mm_s", -5), "machine.json: max_speed_mm_s: must be positive, got -5");
  EXPECT_NE(with("/travel_box/min", json::array({0, 0})).find("travel_box.min: expected [x, y, z]"), std::string::npos);
  EXPECT_NE(with("/travel_box/min", json::array({800, 0, 0})).find("travel_box: min must be below max"), std::string::npos);
  EXPECT_NE(with("/clearance_z", 1000).find("clearance_z: lies outside the travel box"), std::string::npos);
  EXPECT_NE(with("/probe_speed_mm_s", 500).find("probe_speed_mm_s: exceeds max_speed_mm_s"), std::string::npos);
  EXPECT_NE(with("/active_tip", "T9").find("active_tip: \"T9\" is not among the tips"), std::string::npos);
  EXPECT_NE(with("/tips/1/id", "T1").find("tips[1].id: duplicates tip \"T1\""), std::string::npos);
  EXPECT_NE(with("/tips/0/shaft_radius_mm", 2).find("tips[0].shaft_radius_mm: is wider than the ball"),
            std::string::npos);
  EXPECT_NE(with("/tips/0/direction", json::array({0, 0, 0})).find("tips[0].direction: is zero"), std::string::npos);
  EXPECT_NE(with("/tips/0/shaft_length_mm", 0.5).find("tips[0].shaft_length_mm: does not reach past the ball"),
            std::string::npos);
  EXPECT_NE(with("/tips/0", json::array({1, 2})).find("tips[0]: expected an object"), std::string::npos);
  EXPECT_NE(with("/travel_box/mx", 1).find("travel_box.mx: unknown field"), std::string::npos);
  EXPECT_NE(with("/reference_sphere/radius", 1).find("reference_sphere.radius: unknown field"), std::string::npos);
  EXPECT_NE(with("/max_speed", 5).find("max_speed: unknown field"), std::string::npos);
  EXPECT_NE(with("/tips/0/ball_radius", 5).find("tips[0].ball_radius: unknown field"), std::string::npos);
  json missing = good;
  missing.erase("clearance_z");
  EXPECT_EQ(refusal(missing), "machine.json: clearance_z: missing");
  EXPECT_NE(refusal(json::array()).find("expected an object"), std::string::npos);
}

TEST(Machine, UnreadableFilesAreNamed) {
  const std::filesystem::path file = std::filesystem::temp_directory_path() / "cmmd_machine_test.json";
  std::ofstream(file) << "{\"travel_box\": ";
  try {
    read_machine(file);
    ADD_FAILURE() << "a truncated file was accepted";
  } catch (const geometry::FileError& e) {
    EXPECT_NE(std::string(e.what()).find(file.string() + ": not valid JSON"), std::string::npos) << e.what();
  }
  std::filesystem::remove(file);
  EXPECT_THROW(read_machine(file), geometry::FileError);
}

}  // namespace
}  // namespace cmm::planner
