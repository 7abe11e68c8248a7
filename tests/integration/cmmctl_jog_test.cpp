// Jog and teach through the real binaries: cmmctl home, a step jog down, teach it as a plate corner
// into a measure_plate file, a jog refused at a face of the travel box, and machine.jog over JSON-RPC.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <fstream>

#include <nlohmann/json.hpp>

#include "cmmd_instance.hpp"
#include "daemon/client/rpc_error.hpp"
#include "tests/daemon/fresh_folder.hpp"
#include "tests/tools/run_command.hpp"

namespace cmm {
namespace {

using nlohmann::json;

const std::string kCmmctl = CMMD_BINARY_DIR "/daemon/cmmctl";

TEST(CmmctlJog, HomeJogDownAndTeachTheCornerIntoTheMeasurePlateFile) {
  const auto dir = daemon::fresh_folder("cmmctl-jog");
  testing::CmmdInstance cmmd(dir / "cmmd", testing::sample_sim_block());  // homes to the box's top corner
  cmmd.start();
  const std::string ctl = kCmmctl + " --endpoint unix:" + (dir / "cmmd" / "run" / "cmmd.sock").string();

  auto r = cmm::test::run_command(ctl + " home");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = cmm::test::run_command(ctl + " jog 0 0 -1 --distance 5");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("position (700.0000, 900.0000, 445.0000)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("travelled 5.000 mm"), std::string::npos) << r.output;

  // A file as cmm-scan --plate-corners writes it, corner 2 already taught: corner 1 goes before it.
  const std::filesystem::path file = dir / "plate_corners.json";
  json scan = json::array();
  for (int id = 1; id <= 4; ++id) scan.push_back({{"id", id}, {"scan", {id, 0, 0}}});
  std::ofstream(file) << json{{"scan_corners", scan}, {"rough_machine", {{{"id", 2}, {"machine", {1, 2, 3}}}}}, {"note", "kept"}}.dump();
  r = cmm::test::run_command(ctl + " teach 1 --file " + file.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("corner 1 rough machine position (700.0000, 900.0000, 445.0000)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("still to teach: 3, 4"), std::string::npos) << r.output;
  json taught = testing::read_json_file(file);
  EXPECT_EQ(taught["rough_machine"], json::parse(R"([{"id": 1, "machine": [700.0, 900.0, 445.0]}, {"id": 2, "machine": [1, 2, 3]}])"))
      << taught.dump();
  EXPECT_EQ(taught["scan_corners"], scan);
  EXPECT_EQ(taught["note"], "kept");

  // The default step is DX DY DZ's own length; teaching a corner again replaces its position.
  r = cmm::test::run_command(ctl + " jog -3 0 -4");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("position (697.0000, 900.0000, 441.0000)"), std::string::npos) << r.output;
  r = cmm::test::run_command(ctl + " teach 1 --file " + file.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("(was (700.0000, 900.0000, 445.0000))"), std::string::npos) << r.output;
  const auto near = [](const json& p, double x, double y, double z) {
    return p.is_array() && std::abs(p[0].get<double>() - x) + std::abs(p[1].get<double>() - y) + std::abs(p[2].get<double>() - z) < 1e-9;
  };
  taught = testing::read_json_file(file);
  EXPECT_TRUE(near(taught["rough_machine"][0]["machine"], 697, 900, 441)) << taught.dump();
  // A new file is made.
  r = cmm::test::run_command(ctl + " teach 3 --file " + (dir / "new.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(testing::read_json_file(dir / "new.json")["rough_machine"][0]["id"], 3);

  // At the +y face (900 less T1's ball radius is the jog's limit): refused, naming the face.
  r = cmm::test::run_command(ctl + " jog 0 1 0");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("-32013"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("+y face"), std::string::npos) << r.output;
  r = cmm::test::run_command(ctl + " jog-stop");
  EXPECT_EQ(r.exit_code, 0) << r.output;

  // machine.status shows how the last jog ended; a held jog over JSON-RPC returns at once and runs
  // until its lease ends.
  daemon::RpcClient client = cmmd.client();
  json status = client.call("machine.status");
  EXPECT_TRUE(status["jog"].is_null()) << status.dump();
  EXPECT_EQ(status["last_jog"]["reason"], "travelled 5.000 mm") << status.dump();
  const json started = client.call("machine.jog", {{"direction", {-1, 0, 0}}, {"hold_s", 0.2}});
  EXPECT_EQ(started["speed_mm_s"], 5);
  EXPECT_TRUE(near(started["position"], 697, 900, 441)) << started.dump();
  const int id = started["jog"].get<int>();
  for (int i = 0; i < 200; ++i) {  // 10 s at most
    status = client.call("machine.status");
    if (status["jog"].is_null()) break;
    EXPECT_EQ(status["jog"]["id"], id);
    usleep(50000);
  }
  EXPECT_TRUE(status["jog"].is_null()) << status.dump();
  EXPECT_EQ(status["last_jog"]["id"], id);
  EXPECT_EQ(status["last_jog"]["reason"], "released (no machine.jog within hold_s)");
  EXPECT_LT(status["position"][0].get<double>(), 697);
  try {
    client.call("machine.jog", {{"direction", {0, 0, 0}}});
    ADD_FAILURE() << "a zero direction was accepted";
  } catch (const daemon::RpcError& e) {
    EXPECT_EQ(e.code(), daemon::rpc_code::invalid_params);
    EXPECT_EQ(e.data()["path"], "/direction");
  }
  EXPECT_EQ(cmmd.terminate(), 0);
}

}  // namespace
}  // namespace cmm
