// job.view against the real cmmd: a job on the in-process simulator, viewed while unknown, then once
// done: the stored reference mesh, T_M_S, every planned point and hole, every touch made, the result.
#include <gtest/gtest.h>

#include <fstream>
#include <set>

#include <nlohmann/json.hpp>

#include "cmmd_instance.hpp"
#include "daemon/client/base64.hpp"
#include "daemon/client/rpc_error.hpp"
#include "tests/daemon/fresh_folder.hpp"

namespace cmm {
namespace {

using nlohmann::json;
using testing::CmmdInstance;

std::string file_bytes(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

TEST(CmmdView, ADoneJobShowsItsMeshPointsEveryTouchAndItsResult) {
  const auto dir = daemon::fresh_folder("view");
  CmmdInstance cmmd(dir / "cmmd", testing::sample_sim_block());
  cmmd.start();
  daemon::RpcClient client = cmmd.client();
  try {
    client.call("job.view", {{"job", 7}});
    ADD_FAILURE() << "job.view of no job answered";
  } catch (const daemon::RpcError& e) {
    EXPECT_EQ(e.code(), daemon::rpc_code::not_found) << e.what();
  }

  const int id = testing::submit_quick_job(client, dir / "scan");
  testing::wait_for_job(client, id, {"done"}, 300);
  const json view = client.call("job.view", {{"job", id}}, 60);
  const std::filesystem::path folder = cmmd.job_folder(id);

  EXPECT_EQ(view.at("job"), id);
  const std::string ply = daemon::decode_base64(view.at("reference_ply").get<std::string>());
  EXPECT_EQ(ply.rfind("ply\n", 0), 0u);
  EXPECT_EQ(ply, file_bytes(folder / "reference.ply"));
  EXPECT_EQ(view.at("T_M_S"), testing::read_json_file(folder / "registration.json").at("T_M_S"));

  const json result = client.call("job.result", {{"job", id}});
  ASSERT_EQ(view.at("edge_points").size(), result.at("edge_points").size());
  ASSERT_EQ(view.at("holes").size(), result.at("holes").size());
  std::set<int> planned;
  for (const json& p : view["edge_points"]) {
    EXPECT_EQ(p.at("position_S").size(), 3u);
    if (p.at("probeable").get<bool>()) EXPECT_FALSE(p.at("touches").empty()) << p.dump();
    else EXPECT_TRUE(p.at("reason").is_string()) << p.dump();
    for (const json& t : p["touches"]) planned.insert(t.get<int>());
  }
  for (const json& h : view["holes"]) {
    EXPECT_GT(h.at("radius").get<double>(), 0);
    for (const json& t : h.at("touches")) planned.insert(t.get<int>());
  }
  // Done: every planned touch is in the journal, and nothing else is.
  const std::vector<int> journal = testing::journal_touch_ids(folder);
  EXPECT_EQ(view.at("touches_done").get<std::vector<int>>(), journal);
  EXPECT_EQ(std::set<int>(journal.begin(), journal.end()), planned);
  EXPECT_EQ(static_cast<int>(journal.size()), result.at("touches").get<int>());

  const json& r = view.at("result");
  ASSERT_EQ(r.at("edge_points").size(), result["edge_points"].size());
  int measured = 0;
  for (std::size_t i = 0; i < result["edge_points"].size(); ++i) {
    const json& mine = r["edge_points"][i];
    EXPECT_EQ(mine.at("status"), result["edge_points"][i]["status"]);
    EXPECT_EQ(mine.at("deviation_mm"), result["edge_points"][i]["deviation_mm"]);
    if (mine["status"] == "measured") {
      ++measured;
      EXPECT_EQ(mine.at("measured_S").at("position").size(), 3u);
    }
  }
  EXPECT_GT(measured, 20);
  EXPECT_EQ(r.at("summary"), result.at("summary"));
  EXPECT_EQ(cmmd.terminate(), 0);
}

}  // namespace
}  // namespace cmm
