// Issue 34, parts 4 and 5, end to end: the real cmmd driving cmm-sim over Modbus TCP. A model in the
// wrong unit is refused at job.submit and in plan.preview naming the factor, a tiny part passes with
// the override; registration mistakes the request already shows are refused at submit before any
// touch, blamed on their own corner; the sample corners fit the demo's simulator.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "cmmd_instance.hpp"
#include "daemon/client/model_upload.hpp"
#include "daemon/client/rpc_error.hpp"
#include "geometry/analytic_parts.hpp"
#include "geometry/mesh_io.hpp"
#include "job_watch.hpp"
#include "tests/tools/run_command.hpp"

namespace cmm {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::CmmdInstance;

fs::path scratch(const std::string& name) {
  const auto dir = fs::temp_directory_path() / ("cmmd_units_test_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(dir);
  return dir;
}

// cmm-sim in the demo's set-up (config/samples/demo_sim.json), fast, and cmmd driving it over Modbus.
struct Station {
  explicit Station(const fs::path& dir)
      : sim(CMMD_SOURCE_DIR "/config/samples/demo_sim.json", 50),
        cmmd(dir / "cmmd", testing::modbus_block(sim.port),
             {{"machine_description", CMMD_SOURCE_DIR "/config/machine.json"}}) {
    cmmd.start();
  }
  testing::SimulatorProcess sim;
  CmmdInstance cmmd;
};

// The case-3 block in its own frame (S of the sample scan), its coordinates times `times`.
fs::path block_model(const fs::path& folder, const std::string& name, double times) {
  fs::create_directories(folder);
  geometry::TriangleMesh mesh = geometry::make_analytic_part("case3_block", 2).mesh;
  mesh.vertices *= times;
  const fs::path file = folder / name;
  geometry::write_mesh(file, mesh);
  return file;
}

daemon::RpcError error_of(daemon::RpcClient& client, const std::string& method, const json& params) {
  try {
    client.call(method, params, 300);
  } catch (const daemon::RpcError& e) {
    return e;
  }
  ADD_FAILURE() << method << " was not refused";
  return daemon::RpcError(0, "");
}

// A refusal before anything moves: no job queued, the machine where it was, so no touch made.
void expect_nothing_queued_or_moved(daemon::RpcClient& client, const json& position_before) {
  EXPECT_TRUE(client.call("job.list").at("jobs").empty());
  EXPECT_EQ(client.call("machine.status").at("position"), position_before);
}

TEST(CmmdUnits, AModelInAnotherUnitIsRefusedAtSubmitAndInPreviewNamingTheFactor) {
  const auto dir = scratch("factor");
  Station station(dir);
  daemon::RpcClient client = station.cmmd.client();
  const json registration = testing::sample_measure_plate(dir / "scan");
  const json position_before = client.call("machine.status").at("position");
  struct Case {
    double factor;
    const char* name;
    const char* says;
  };
  for (const Case& c : {Case{25.4, "inch.stl", "the model is 25.4× smaller than the plate it stands on: a model in inches? use --scale 25.4"},
                        Case{10, "cm.stl", "the model is 10× smaller than the plate it stands on: a model in centimetres? use --scale 10"},
                        Case{1000, "m.stl", "the model is 1000× smaller than the plate it stands on: a model in metres? use --scale 1000"}}) {
    const std::string model = daemon::upload_model(client, block_model(dir / "models", c.name, 1 / c.factor));
    for (const char* method : {"job.submit", "plan.preview"}) {
      const daemon::RpcError e = error_of(client, method, {{"model", model}, {"registration", registration}});
      EXPECT_EQ(e.code(), daemon::rpc_code::model_error) << method << ": " << e.what();
      EXPECT_NE(std::string(e.what()).find(c.says), std::string::npos) << method << ": " << e.what();
      EXPECT_EQ(e.data().value("kind", ""), "units") << e.data();
      EXPECT_DOUBLE_EQ(e.data().value("factor", 0.0), c.factor) << e.data();
    }
  }
  // Without a registration the preview still finds the inch model by its size, and says what it did
  // not check.
  const std::string inch = daemon::upload_model(client, block_model(dir / "models", "inch.stl", 1 / 25.4));
  const daemon::RpcError unregistered = error_of(client, "plan.preview", {{"model", inch}});
  EXPECT_NE(std::string(unregistered.what()).find("25.4× smaller"), std::string::npos) << unregistered.what();
  // cmmctl preview says it on the terminal.
  const std::string ctl = CMMD_BINARY_DIR "/daemon/cmmctl --endpoint unix:" + (dir / "cmmd" / "run" / "cmmd.sock").string();
  const auto r = cmm::test::run_command(ctl + " preview " + (dir / "models" / "inch.stl").string());
  EXPECT_NE(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("use --scale 25.4"), std::string::npos) << r.output;
  expect_nothing_queued_or_moved(client, position_before);
}

TEST(CmmdUnits, ATinyPartPassesWithTheOverride) {
  const auto dir = scratch("override");
  Station station(dir);
  daemon::RpcClient client = station.cmmd.client();
  const json registration = testing::sample_measure_plate(dir / "scan");
  const std::string tiny = daemon::upload_model(client, block_model(dir / "models", "tiny.stl", 1 / 25.4));
  EXPECT_EQ(error_of(client, "job.submit", {{"model", tiny}, {"registration", registration}}).data().value("kind", ""), "units");
  for (const json& word : {json{{"units_checked", true}}, json{{"scale", 1}}}) {
    json params = word;
    params.update({{"model", tiny}, {"registration", registration}});
    const json record = client.call("job.submit", params, 300);
    // Accepted is what this checks; the tiny job may finish before the cancel reaches it.
    try {
      client.call("job.cancel", {{"job", record.at("id")}});
    } catch (const daemon::RpcError& e) {
      EXPECT_EQ(e.code(), daemon::rpc_code::invalid_state) << e.what();
    }
    testing::wait_for_job(client, record.at("id").get<int>(), {"cancelled", "done"}, 120);
  }
}

TEST(CmmdUnits, RegistrationMistakesAreRefusedAtSubmitBeforeATouchNamingTheCorner) {
  const auto dir = scratch("registration");
  Station station(dir);
  daemon::RpcClient client = station.cmmd.client();
  const std::string model = daemon::upload_model(client, testing::sample_scan(dir / "scan"));
  const json registration = testing::sample_measure_plate(dir / "scan");
  const json position_before = client.call("machine.status").at("position");

  // Scan corners 2 and 3 given in each other's place.
  json swapped = registration;
  json& scan = swapped["measure_plate"]["scan_corners"];
  std::swap(scan[1]["scan"], scan[2]["scan"]);
  const daemon::RpcError s = error_of(client, "job.submit", {{"model", model}, {"registration", swapped}});
  EXPECT_EQ(s.code(), daemon::rpc_code::registration_error) << s.what();
  EXPECT_NE(std::string(s.what()).find("scan_corners (S): "), std::string::npos) << s.what();
  EXPECT_EQ(s.data().value("kind", ""), "nominal_length") << s.data();

  // Rough corner 2 taught 30 mm off: blamed on corner 2, not on the corner whose touch would miss first.
  json rough = registration;
  rough["measure_plate"]["rough_machine"][1]["machine"][0] = rough["measure_plate"]["rough_machine"][1]["machine"][0].get<double>() + 30;
  const daemon::RpcError r = error_of(client, "job.submit", {{"model", model}, {"registration", rough}});
  EXPECT_EQ(r.code(), daemon::rpc_code::registration_error) << r.what();
  EXPECT_NE(std::string(r.what()).find("rough_machine (M"), std::string::npos) << r.what();
  EXPECT_NE(std::string(r.what()).find("corner 2 is in every one: it is probably the one that is off"), std::string::npos)
      << r.what();
  EXPECT_EQ(r.data().value("corners", json::array()), json::array({2})) << r.data();

  expect_nothing_queued_or_moved(client, position_before);
}

TEST(CmmdUnits, TheSampleCornersFitTheDemosSimulator) {
  // README: config/samples/case3_block.ply with case3_block.corners.json on demo_sim.json.
  const auto dir = scratch("sample");
  Station station(dir);
  daemon::RpcClient client = station.cmmd.client();
  client.call("machine.qualify", json::object(), 300);
  json corners = testing::read_json_file(CMMD_SOURCE_DIR "/config/samples/case3_block.corners.json");
  corners["plate"] = testing::read_json_file(CMMD_SOURCE_DIR "/config/plate.json");
  daemon::RpcClient watch = station.cmmd.client();
  watch.call("server.subscribe", {{"topics", {"job"}}});
  const int id = testing::submit_job(client, CMMD_SOURCE_DIR "/config/samples/case3_block.ply",
                                     {{"spacing_mm", 10}, {"registration", corners}});
  // Registered and touching the part: ten touches made, every one a contact, no fault.
  for (int touches = 0; touches < 10; ++touches) {
    const json touch = testing::await_job(watch, id, "touch " + std::to_string(touches), testing::job_touched(id), 300,
                                          testing::job_ended_or_held);
    EXPECT_TRUE(touch.at("params").at("contact").get<bool>()) << touch;
  }
  client.call("job.cancel", {{"job", id}});
  testing::wait_for_job(client, id, {"cancelled"}, 120);
}

}  // namespace
}  // namespace cmm
