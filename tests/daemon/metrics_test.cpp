// What cmmd counts from its notifications and answered requests, and the text /metrics serves.
#include "daemon/metrics.hpp"

#include <gtest/gtest.h>

namespace cmm::daemon {
namespace {

using namespace std::chrono_literals;

bool has_line(const std::string& text, const std::string& line) {
  return text.find("\n" + line + "\n") != std::string::npos || text.rfind(line + "\n", 0) == 0;
}

// Done jobs by their verdict: the four values always listed, anything else "other" (a record cannot
// grow the label set), a job without a nominal (verdict null) not at all.
TEST(Metrics, CountsDoneJobsByVerdict) {
  Metrics m({});
  const auto done = [&](int job, nlohmann::json verdict) {
    m.observe("job.state", {{"job", job}, {"state", "done"}, {"verdict", std::move(verdict)}});
  };
  done(1, {{"verdict", "incomplete"}, {"coverage", "…"}});
  done(2, {{"verdict", "incomplete"}});
  done(3, {{"verdict", "pass"}});
  done(4, nullptr);
  done(5, {{"verdict", "brilliant"}});
  const std::string text = m.text({});
  EXPECT_TRUE(has_line(text, "cmmd_job_verdicts_total{verdict=\"incomplete\"} 2")) << text;
  EXPECT_TRUE(has_line(text, "cmmd_job_verdicts_total{verdict=\"pass\"} 1")) << text;
  EXPECT_TRUE(has_line(text, "cmmd_job_verdicts_total{verdict=\"fail\"} 0")) << text;
  EXPECT_TRUE(has_line(text, "cmmd_job_verdicts_total{verdict=\"undecided\"} 0")) << text;
  EXPECT_TRUE(has_line(text, "cmmd_job_verdicts_total{verdict=\"other\"} 1")) << text;
}

TEST(Metrics, CountsAJobsTouchesStatesAndDurations) {
  Metrics m({"job.submit", "job.get"});
  const Metrics::Clock::time_point t0{};
  m.observe("job.state", {{"job", 1}, {"state", "queued"}}, t0);
  m.observe("job.state", {{"job", 1}, {"state", "planning"}}, t0 + 1s);
  m.observe("job.touch", {{"job", 1}, {"touch", 0}}, t0 + 1300ms);
  m.observe("job.touch", {{"job", 1}, {"touch", 1}}, t0 + 3300ms);
  m.observe("job.state", {{"job", 1}, {"state", "paused"}}, t0 + 4s);
  m.observe("job.state", {{"job", 1}, {"state", "probing"}}, t0 + 10s);
  m.observe("job.touch", {{"job", 1}, {"touch", 2}}, t0 + 10400ms);  // 0.4 s after the resume, not 7.1 s
  m.observe("job.state", {{"job", 1}, {"state", "done"}}, t0 + 21s);
  m.observe("job.state", {{"job", 2}, {"state", "cancelled"}}, t0 + 22s);  // from the queue
  const std::string text = m.text({.socket_clients = 2, .websocket_clients = 1});

  EXPECT_TRUE(has_line(text, "cmmd_touches_total 3")) << text;
  EXPECT_TRUE(has_line(text, "cmmd_jobs_total{state=\"done\"} 1")) << text;
  EXPECT_TRUE(has_line(text, "cmmd_jobs_total{state=\"cancelled\"} 1")) << text;
  EXPECT_TRUE(has_line(text, "cmmd_jobs_total{state=\"failed\"} 0")) << text;
  // Job 1 ran from its planning to its end, its pause included: 20 s; job 2 never started: 0 s.
  EXPECT_TRUE(has_line(text, "cmmd_job_duration_seconds_bucket{le=\"15\"} 1")) << text;
  EXPECT_TRUE(has_line(text, "cmmd_job_duration_seconds_bucket{le=\"30\"} 2")) << text;
  EXPECT_TRUE(has_line(text, "cmmd_job_duration_seconds_sum 20")) << text;
  EXPECT_TRUE(has_line(text, "cmmd_job_duration_seconds_count 2")) << text;
  // The touches: 0.3 s after the start, then 2 s, then 0.4 s after the resume; buckets are cumulative.
  EXPECT_TRUE(has_line(text, "cmmd_touch_duration_seconds_bucket{le=\"0.25\"} 0")) << text;
  EXPECT_TRUE(has_line(text, "cmmd_touch_duration_seconds_bucket{le=\"0.5\"} 2")) << text;
  EXPECT_TRUE(has_line(text, "cmmd_touch_duration_seconds_bucket{le=\"2\"} 3")) << text;
  EXPECT_TRUE(has_line(text, "cmmd_touch_duration_seconds_bucket{le=\"+Inf\"} 3")) << text;
  EXPECT_TRUE(has_line(text, "cmmd_connected_clients{transport=\"socket\"} 2")) << text;
  EXPECT_TRUE(has_line(text, "cmmd_connected_clients{transport=\"websocket\"} 1")) << text;
  EXPECT_TRUE(has_line(text, "# TYPE cmmd_job_duration_seconds histogram")) << text;
}

TEST(Metrics, CountsAFaultWhenItAppearsAndTheLink) {
  Metrics m({});
  const nlohmann::json up = {{"lifecycle", "active"}, {"link", "up"}, {"fault", nullptr}};
  const nlohmann::json hit = {{"lifecycle", "active"}, {"link", "up"}, {"fault", {{"kind", "UnexpectedContact"}}}};
  const nlohmann::json down = {{"lifecycle", "active"}, {"link", "down"}, {"fault", {{"kind", "CommLost"}}}};
  for (const auto& state : {up, hit, hit, up, hit, down}) m.observe("machine.state", state);
  const std::string text = m.text({});
  EXPECT_TRUE(has_line(text, "cmmd_machine_faults_total{kind=\"UnexpectedContact\"} 2")) << text;
  EXPECT_TRUE(has_line(text, "cmmd_machine_faults_total{kind=\"CommLost\"} 1")) << text;
  EXPECT_TRUE(has_line(text, "cmmd_machine_link_up 0")) << text;
}

TEST(Metrics, RequestsOfNoSuchMethodShareOneLabel) {
  Metrics m({"job.get"});
  m.count_request("job.get", false);
  m.count_request("job.get", true);
  for (int i = 0; i < 100; ++i) m.count_request("made.up." + std::to_string(i), true);
  m.count_request("", true);  // an invalid request
  m.count_request("quote\"d", true);
  const std::string text = m.text({});
  EXPECT_TRUE(has_line(text, "cmmd_rpc_requests_total{method=\"job.get\"} 2")) << text;
  EXPECT_TRUE(has_line(text, "cmmd_rpc_errors_total{method=\"job.get\"} 1")) << text;
  EXPECT_TRUE(has_line(text, "cmmd_rpc_requests_total{method=\"other\"} 102")) << text;
  EXPECT_EQ(text.find("made.up"), std::string::npos);
}

TEST(Metrics, TheBrokersLinkAndUnsentMessagesOnlyWithMqtt) {
  Metrics m({"server.info"});
  EXPECT_EQ(m.text({}).find("cmmd_mqtt"), std::string::npos);
  const std::string text = m.text({}, MqttGauges{.link_up = false, .unsent = 3});
  EXPECT_NE(text.find("# TYPE cmmd_mqtt_link_up gauge\ncmmd_mqtt_link_up 0\n"), std::string::npos) << text;
  EXPECT_NE(text.find("cmmd_mqtt_unsent_messages 3\n"), std::string::npos) << text;
}

}  // namespace
}  // namespace cmm::daemon
