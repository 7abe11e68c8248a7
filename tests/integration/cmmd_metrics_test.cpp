// /metrics of the real cmmd after a job and some requests: Prometheus's own parser
// (python3-prometheus-client) reads it, and its counters match what the test did.
#include <gtest/gtest.h>

#include <fstream>

#include <nlohmann/json.hpp>

#include "cmmd_instance.hpp"
#include "tests/daemon/fresh_folder.hpp"
#include "tests/tools/run_command.hpp"
#include "web_client.hpp"

namespace cmm {
namespace {

using nlohmann::json;
using testing::CmmdInstance;

// The samples of a scrape, as metrics_parse.py prints them.
json scrape(const CmmdInstance& cmmd, const std::filesystem::path& file) {
  const testing::HttpReply reply = testing::http_request(cmmd.http_port(), "GET", "/metrics");
  EXPECT_EQ(reply.status, 200) << reply.body;
  EXPECT_NE(reply.header("content-type").find("version=0.0.4"), std::string::npos) << reply.header("content-type");
  std::ofstream(file) << reply.body;
  const auto r = cmm::test::run_command(std::string(CMMD_SYSTEM_PYTHON) + " " CMMD_SOURCE_DIR
                                        "/tests/integration/metrics_parse.py " + file.string() + " 2>&1");
  if (r.exit_code != 0) throw std::runtime_error("metrics_parse.py: " + r.output + "\n" + reply.body);
  return json::parse(r.output);
}

TEST(CmmdMetrics, PrometheusReadsThemAndTheyCountWhatTheTestDid) {
  const auto dir = daemon::fresh_folder("metrics");
  CmmdInstance cmmd(dir / "cmmd", testing::sample_sim_block());
  cmmd.start();
  daemon::RpcClient client = cmmd.client();
  testing::WebSocketClient ws(cmmd.http_port());
  ws.call("server.info");

  const json request = {{"spacing_mm", 8}, {"registration", testing::sample_measure_plate(dir / "scan")}};
  const int job = testing::submit_job(client, testing::sample_scan(dir / "scan"), request);
  const json record = testing::wait_for_job(client, job, {"done", "failed"}, 300);
  ASSERT_EQ(record.at("state"), "done") << record.dump();
  const int touches = client.call("job.result", {{"job", job}}).at("touches").get<int>();
  ASSERT_GT(touches, 10);
  EXPECT_THROW(client.call("job.get", {{"job", 999}}), daemon::RpcError);
  EXPECT_THROW(client.call("no.such.method", json::object()), daemon::RpcError);

  const json parsed = scrape(cmmd, dir / "metrics.txt");
  const json& s = parsed.at("samples");
  EXPECT_EQ(parsed.at("families").at("cmmd_job_duration_seconds"), "histogram");
  EXPECT_EQ(parsed.at("families").at("cmmd_touches"), "counter");  // the parser drops _total from a counter's name
  EXPECT_EQ(s.at("cmmd_touches_total"), touches);
  EXPECT_EQ(s.at("cmmd_jobs_total{state=\"done\"}"), 1);
  EXPECT_EQ(s.at("cmmd_jobs_total{state=\"failed\"}"), 0);
  EXPECT_EQ(s.at("cmmd_job_duration_seconds_count"), 1);
  EXPECT_GT(s.at("cmmd_job_duration_seconds_sum").get<double>(), 0);
  EXPECT_EQ(s.at("cmmd_touch_duration_seconds_count"), touches);
  EXPECT_EQ(s.at("cmmd_machine_link_up"), 1);
  EXPECT_EQ(s.at("cmmd_rpc_requests_total{method=\"job.submit\"}"), 1);
  EXPECT_EQ(s.at("cmmd_rpc_errors_total{method=\"job.get\"}"), 1);
  EXPECT_EQ(s.at("cmmd_rpc_errors_total{method=\"other\"}"), 1);
  EXPECT_EQ(s.at("cmmd_rpc_requests_total{method=\"server.info\"}"), 1);  // the WebSocket's
  EXPECT_EQ(s.at("cmmd_connected_clients{transport=\"websocket\"}"), 1);
  EXPECT_GE(s.at("cmmd_connected_clients{transport=\"socket\"}").get<int>(), 1);
  EXPECT_EQ(cmmd.terminate(), 0);
}

}  // namespace
}  // namespace cmm
