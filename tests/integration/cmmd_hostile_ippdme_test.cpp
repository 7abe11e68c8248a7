// cmmd against a controller that lies: the real daemon drives cmm-sim's I++ DME server through a
// proxy that falsifies PtMeas reports (50 mm along the search, 0.3 mm across it, ER −1000, ER 1.3 for
// a 1 mm ball) or swallows one. Each is a typed fault that holds the job, none is journalled, and
// after the resume the next touch is made on the same link.
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>

#include <nlohmann/json.hpp>

#include "cmmd_instance.hpp"
#include "ippdme_proxy.hpp"
#include "job_watch.hpp"

namespace cmm {
namespace {

using nlohmann::json;
using testing::IppDmeProxy;

std::vector<hal::Vec3> journalled_centres(const std::filesystem::path& job_folder) {
  std::vector<hal::Vec3> centres;
  std::ifstream in(job_folder / "touches.jsonl");
  for (std::string line; std::getline(in, line);) {
    const json j = json::parse(line);
    if (!j.contains("centre")) continue;  // a tip change
    const json& c = j.at("centre");
    centres.emplace_back(c.at(0).get<double>(), c.at(1).get<double>(), c.at(2).get<double>());
  }
  return centres;
}

struct Lie {
  const char* name;
  IppDmeProxy::Falsify falsify;
  const char* said;  // what the hold's reason must say
};

TEST(CmmdHostileIppDme, EveryFalseTouchReportIsAProtocolFaultNothingIsJournalledAndTheLinkStays) {
  const auto dir = std::filesystem::temp_directory_path() / ("cmmd_hostile_" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  const auto scan = testing::sample_scan(dir / "scan");
  testing::SimulatorProcess sim(dir / "scan" / "sim.json", 100, 0, {"--ippdme", "0"});
  IppDmeProxy proxy(sim.ippdme_port);
  testing::CmmdInstance cmmd(dir / "cmmd", testing::ippdme_block(proxy.port()),
                             {{"machine_description", CMMD_SOURCE_DIR "/config/machine.json"}});
  cmmd.start();
  daemon::RpcClient client = cmmd.client();
  daemon::RpcClient watch = cmmd.client();
  watch.call("server.subscribe", {{"topics", {"job"}}});
  client.call("machine.qualify", json::object(), 300);
  const int id = testing::submit_job(client, scan, testing::spaced_job_request(dir / "scan"));
  testing::await_job(watch, id, "the first touch", testing::job_touched(id), 600, testing::job_ended_or_held);

  const Lie lies[] = {
      {"50 mm along the search", testing::shifted_along(-50), "past the search's end"},
      {"0.3 mm across the search", testing::shifted_sideways(0.3), "off the commanded search line"},
      {"ER -1000", testing::with_radius(-1000), "ER"},
      {"ER 1.3 for a 1 mm ball", testing::with_radius(1.3), "ER"},
  };
  for (const Lie& lie : lies) {
    SCOPED_TRACE(lie.name);
    proxy.arm(lie.falsify);
    const std::optional<hal::Vec3> claimed = proxy.wait_falsified(300);
    ASSERT_TRUE(claimed) << "no PtMeas came to falsify";
    testing::await_job(watch, id, "the hold", testing::job_state_is(id, "paused"), 120, testing::job_ended);
    const json held = client.call("job.get", {{"job", id}});
    ASSERT_FALSE(held["fault"].is_null()) << held.dump();
    EXPECT_EQ(held["fault"]["kind"], "Protocol") << held.dump();
    EXPECT_NE(held.dump().find(lie.said), std::string::npos) << held.dump();
    for (const hal::Vec3& c : journalled_centres(cmmd.job_folder(id)))
      EXPECT_GT((c - *claimed).norm(), 0.05) << "the falsified touch was journalled";
    EXPECT_EQ(proxy.connections(), 1) << "the driver reconnected";

    client.call("job.resume", {{"job", id}});
    testing::await_job(watch, id, "the next touch", testing::job_touched(id), 120, testing::job_ended_or_held);
    EXPECT_EQ(proxy.connections(), 1) << "the next touch needed a new link";
  }

  // A controller that takes a PtMeas and never answers: the job holds on a Timeout sized by the
  // search (a few seconds), not by a fixed ten minutes.
  proxy.arm_silence();
  const auto silent_from = std::chrono::steady_clock::now();
  testing::await_job(watch, id, "the hold on silence", testing::job_state_is(id, "paused"), 120, testing::job_ended);
  const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - silent_from).count();
  const json held = client.call("job.get", {{"job", id}});
  ASSERT_FALSE(held["fault"].is_null()) << held.dump();
  EXPECT_EQ(held["fault"]["kind"], "Timeout") << held.dump();
  EXPECT_LT(waited, 60) << held.dump();

  client.call("job.resume", {{"job", id}});
  testing::wait_for_job(client, id, {"done"}, 900);
  EXPECT_EQ(cmmd.terminate(), 0);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace cmm
