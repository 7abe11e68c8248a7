// A fleet on a real mosquitto (the documented ACL, users with passwords) with two real cmmd stations
// on the simulator: cmmctl fleet, jobs sent through the broker, token roles, a broker killed in the
// middle of a job, the last will of a killed station, and what an observer can and cannot read; and
// what the broker holds after cmmd or the broker itself was killed.
#include <gtest/gtest.h>

#include <chrono>
#include <csignal>
#include <stdexcept>
#include <thread>

#include <nlohmann/json.hpp>

#include "broker_process.hpp"
#include "cmmd_instance.hpp"
#include "daemon/client/rpc_client.hpp"
#include "mqtt_listener.hpp"
#include "tests/daemon/fresh_folder.hpp"
#include "tests/tools/run_command.hpp"

namespace cmm {
namespace {

using nlohmann::json;

const std::string kCmmctl = CMMD_BINARY_DIR "/daemon/cmmctl";
const std::string kOperatorToken = "fleet-operator-token-0123";
const std::string kObserverToken = "fleet-observer-token-0123";
const std::map<std::string, std::string> kUsers = {
    {"alpha", "alpha-pw"}, {"beta", "beta-pw"}, {"ops", "ops-pw"}, {"viewer", "viewer-pw"}};

json station_config(const std::string& station, int broker_port) {
  return {{"station", station},
          {"server", {{"tokens", {{{"token", kOperatorToken}, {"role", "operator"}},
                                  {{"token", kObserverToken}, {"role", "observer"}}}}}},
          {"http", {{"enabled", false}}},
          {"mqtt", {{"enabled", true}, {"broker", "127.0.0.1"}, {"port", broker_port}, {"username", station},
                    {"password", kUsers.at(station)}, {"progress_interval_s", 0.2}}}};
}

daemon::RpcClient station_client(int broker_port, const std::string& station, const std::string& user,
                                 const std::string& token) {
  daemon::StationAddress address;
  address.broker.host = "127.0.0.1";
  address.broker.port = broker_port;
  address.broker.username = user;
  address.broker.password = kUsers.at(user);
  address.station = station;
  address.token = token;
  return daemon::RpcClient::connect_station(address);
}

json payload(const daemon::MqttMessage& m) { return json::parse(m.payload); }

bool is_topic(const daemon::MqttMessage& m, const std::string& topic) { return m.topic == topic; }

bool is_state(const daemon::MqttMessage& m, const std::string& topic, const std::string& state) {
  return m.topic == topic && payload(m).value("state", "") == state;
}

// The broker has acknowledged every state and result: the station's outbox copies are gone. Only
// the disk shows it, so the folder is looked at until then.
void wait_until_acknowledged(const testing::CmmdInstance& cmmd, double timeout_s) {
  const auto outbox = cmmd.folder() / "state" / "mqtt-outbox";
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (!std::filesystem::is_empty(outbox)) {
    if (std::chrono::steady_clock::now() > deadline)
      throw std::runtime_error("the broker did not acknowledge everything in " + outbox.string() + " within " +
                               std::to_string(timeout_s) + " s");
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

class Fleet : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = daemon::fresh_folder("fleet");
    broker_ = std::make_unique<testing::BrokerProcess>(dir_ / "broker", kUsers);
    broker_->start();
  }

  std::unique_ptr<testing::CmmdInstance> station(const std::string& name, json machine) {
    auto cmmd = std::make_unique<testing::CmmdInstance>(dir_ / name, std::move(machine),
                                                         station_config(name, broker_->port()));
    cmmd->start();
    return cmmd;
  }

  std::string ctl(const std::string& user) const {
    return kCmmctl + " --broker 127.0.0.1:" + std::to_string(broker_->port()) + " --broker-user " + user +
           " --broker-password " + kUsers.at(user);
  }

  std::filesystem::path dir_;
  std::unique_ptr<testing::BrokerProcess> broker_;
};

TEST_F(Fleet, ListsBothStationsRunsAJobSentThroughTheBrokerAndHoldsObserversToTheirRole) {
  auto alpha = station("alpha", testing::timed_sim_block(50));
  auto beta = station("beta", testing::sample_sim_block());
  testing::MqttListener viewer(broker_->port(), "viewer", "viewer-pw", {"cmmd/+/status", "cmmd/+/jobs/#"});
  for (const std::string name : {"alpha", "beta"})
    viewer.wait_for(name + " online", [&](const auto& m) {
      return is_topic(m, "cmmd/" + name + "/status") && payload(m).value("online", false) &&
             payload(m)["machine"].is_object();
    }, 10);

  auto r = cmm::test::run_command(ctl("viewer") + " fleet");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("alpha            online   machine up (enabled)  idle"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("beta             online   machine up (enabled)  idle"), std::string::npos) << r.output;

  // An observer's token over the broker reads but cannot submit.
  daemon::RpcClient observer = station_client(broker_->port(), "alpha", "viewer", kObserverToken);
  EXPECT_EQ(observer.call("machine.status").at("driver"), "sim");
  try {
    observer.call("job.submit", {{"model", "sha256:00"}});
    ADD_FAILURE() << "an observer submitted a job through the broker";
  } catch (const daemon::RpcError& e) {
    EXPECT_EQ(e.code(), daemon::rpc_code::unauthorized) << e.what();
  }
  // No token at all: not even the status.
  daemon::RpcClient nobody = station_client(broker_->port(), "alpha", "viewer", "");
  EXPECT_THROW(nobody.call("machine.status"), daemon::RpcError);

  daemon::RpcClient ops = station_client(broker_->port(), "alpha", "ops", kOperatorToken);
  const int id = testing::submit_quick_job(ops, dir_ / "scan");
  const std::string jobs = "cmmd/alpha/jobs/" + std::to_string(id) + "/";
  const daemon::MqttMessage result =
      viewer.wait_for("result of job " + std::to_string(id), [&](const auto& m) { return is_topic(m, jobs + "result"); }, 120);
  const json summary = payload(result);
  EXPECT_EQ(summary.at("state"), "done") << summary.dump();
  EXPECT_EQ(summary.at("job"), id);
  EXPECT_EQ(summary.at("station"), "alpha");
  EXPECT_TRUE(summary.contains("verdict")) << summary.dump();
  EXPECT_TRUE(result.retain || result.qos == 1);
  viewer.wait_for("progress of job " + std::to_string(id), [&](const auto& m) { return is_topic(m, jobs + "progress"); }, 1);
  for (const std::string state : {"planning", "registering", "probing", "done"})
    viewer.wait_for(state + " of job " + std::to_string(id), [&](const auto& m) {
      return is_topic(m, jobs + "state") && payload(m).at("state") == state;
    }, 1);

  // It ran on alpha, not on beta, and cmmctl --station sees it there.
  EXPECT_EQ(alpha->client().call("job.get", {{"job", id}}).at("state"), "done");
  EXPECT_TRUE(beta->client().call("job.list").at("jobs").empty());
  r = cmm::test::run_command(ctl("ops") + " --station alpha --token " + kOperatorToken + " jobs");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("job " + std::to_string(id) + "  done"), std::string::npos) << r.output;
  r = cmm::test::run_command(ctl("ops") + " --station beta --token " + kOperatorToken + " jobs");
  EXPECT_NE(r.output.find("no jobs"), std::string::npos) << r.output;
}

TEST_F(Fleet, ABrokerKilledMidJobChangesNothingAndWhatItMissedIsPublishedOnItsReturn) {
  auto alpha = station("alpha", testing::timed_sim_block(20));
  daemon::RpcClient local = alpha->client();
  local.call("server.subscribe", {{"topics", {"job"}}});
  const int id = testing::submit_quick_job(local, dir_ / "scan");
  testing::wait_for_notification(local, "probing", [&](const json& n) {
    return n["method"] == "job.state" && n["params"]["state"] == "probing";
  }, 120);
  broker_->kill9();
  // The job goes on to its end without the broker; the states it passes meanwhile are noted.
  std::vector<std::string> missed;
  for (;;) {
    const json n = testing::wait_for_notification(local, "the job's end", [&](const json& n) {
      return n["method"] == "job.state" && n["params"]["job"] == id;
    }, 300);
    missed.push_back(n["params"]["state"].get<std::string>());
    if (missed.back() == "done" || missed.back() == "failed" || missed.back() == "cancelled") break;
  }
  EXPECT_EQ(missed.back(), "done");
  EXPECT_EQ(local.call("job.get", {{"job", id}}).at("state"), "done");
  const auto outbox = alpha->folder() / "state" / "mqtt-outbox";
  EXPECT_FALSE(std::filesystem::is_empty(outbox)) << "the missed states are kept on disk";

  broker_->start();
  testing::MqttListener viewer(broker_->port(), "viewer", "viewer-pw", {"cmmd/alpha/jobs/#"});
  const std::string jobs = "cmmd/alpha/jobs/" + std::to_string(id) + "/";
  viewer.wait_for("the result", [&](const auto& m) { return is_topic(m, jobs + "result"); }, 60);
  for (const std::string& state : missed)
    viewer.wait_for("missed state " + state, [&](const auto& m) {
      return is_topic(m, jobs + "state") && payload(m).at("state") == state;
    }, 10);
  // Acknowledged, so forgotten.
  for (int i = 0; i < 500 && !std::filesystem::is_empty(outbox); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_TRUE(std::filesystem::is_empty(outbox));
}

TEST_F(Fleet, AKilledOrStoppedStationIsMarkedOfflineByItsLastWill) {
  auto alpha = station("alpha", testing::sample_sim_block());
  auto beta = station("beta", testing::sample_sim_block());
  testing::MqttListener viewer(broker_->port(), "viewer", "viewer-pw", {"cmmd/+/status"});
  auto online = [](const auto& m) { return payload(m).value("online", false); };
  viewer.wait_for("beta online", [&](const auto& m) { return is_topic(m, "cmmd/beta/status") && online(m); }, 10);
  beta->kill9();
  viewer.wait_for("beta's last will", [&](const auto& m) { return is_topic(m, "cmmd/beta/status") && !online(m); }, 10);
  EXPECT_EQ(alpha->terminate(), 0);
  viewer.wait_for("alpha offline", [&](const auto& m) { return is_topic(m, "cmmd/alpha/status") && !online(m); }, 10);
  const auto r = cmm::test::run_command(ctl("viewer") + " fleet");
  EXPECT_NE(r.output.find("alpha            OFFLINE"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("beta             OFFLINE"), std::string::npos) << r.output;
}

TEST_F(Fleet, AnObserverUnderTheDocumentedAclReadsNoRequestNorReplyOfAnother) {
  auto alpha = station("alpha", testing::sample_sim_block());
  // Everything the observer may ask for, wildcards and all.
  testing::MqttListener viewer(broker_->port(), "viewer", "viewer-pw",
                               {"#", "cmmd/#", "cmmd/alpha/api/request/#", "cmmd/alpha/api/request/ops",
                                "cmmd/clients/#", "cmmd/clients/ops/#"});
  viewer.wait_for("alpha's status (what it may read)", [&](const auto& m) { return is_topic(m, "cmmd/alpha/status"); }, 10);

  daemon::RpcClient ops = station_client(broker_->port(), "alpha", "ops", kOperatorToken);
  EXPECT_EQ(ops.call("machine.status").at("driver"), "sim");
  EXPECT_TRUE(ops.call("job.list").at("jobs").empty());
  // A message of the observer's own after ops's: once it is here, anything ops's would have been too.
  daemon::RpcClient own = station_client(broker_->port(), "alpha", "viewer", kObserverToken);
  own.call("machine.status");
  viewer.wait_for("its own reply", [&](const auto& m) { return m.topic.starts_with("cmmd/clients/viewer/"); }, 10);
  for (const daemon::MqttMessage& m : viewer.messages()) {
    EXPECT_EQ(m.topic.find("/api/request"), std::string::npos) << "the observer read a request: " << m.topic;
    EXPECT_EQ(m.payload.find(kOperatorToken), std::string::npos) << m.topic;
    EXPECT_FALSE(m.topic.starts_with("cmmd/clients/ops/")) << "the observer read ops's reply: " << m.topic;
  }

  // A request in ops's name with the operator's token (stolen, say, but not ops's broker password),
  // its answer asked for under ops's replies: the ACL lets viewer publish under its own name only, so
  // the station never sees it. Then a request of viewer's own and one of ops's: once ops's reply is
  // in, the station has answered everything before it, in the order it came.
  testing::MqttListener ops_replies(broker_->port(), "ops", "ops-pw", {"cmmd/clients/ops/#"});
  daemon::MqttMessage forged;
  forged.topic = "cmmd/alpha/api/request/ops";
  forged.response_topic = "cmmd/clients/ops/forged/reply";
  forged.payload = R"({"jsonrpc":"2.0","id":1,"method":"job.list"})";
  forged.user_properties.emplace_back("token", kOperatorToken);
  forged.qos = 1;
  ASSERT_TRUE(viewer.client().publish(forged));
  daemon::MqttMessage own_name = forged;
  own_name.topic = "cmmd/alpha/api/request/viewer";
  own_name.response_topic = "cmmd/clients/viewer/own/reply";
  ASSERT_TRUE(viewer.client().publish(own_name));
  viewer.wait_for("the reply under viewer's own name", [](const auto& m) { return m.topic == "cmmd/clients/viewer/own/reply"; }, 10);
  EXPECT_TRUE(ops.call("job.list").at("jobs").empty());
  ops_replies.wait_for("ops's own reply", [](const auto& m) { return m.topic.ends_with("/reply") && m.topic.find("forged") == std::string::npos; }, 10);
  for (const daemon::MqttMessage& m : ops_replies.messages())
    EXPECT_NE(m.topic, "cmmd/clients/ops/forged/reply") << "a request published in another user's name was answered";
}

// A station killed mid-job finds the job interrupted when it starts again, without any job.state
// notification: the broker must still learn it, or every reader goes on seeing it probing.
TEST_F(Fleet, AStationKilledMidJobPublishesTheJobInterruptedOnceItIsBack) {
  auto alpha = station("alpha", testing::timed_sim_block(50));
  daemon::RpcClient local = alpha->client();
  const int id = testing::submit_quick_job(local, dir_ / "scan");
  const std::string state = "cmmd/alpha/jobs/" + std::to_string(id) + "/state";
  testing::MqttListener viewer(broker_->port(), "viewer", "viewer-pw", {state});
  viewer.wait_for("probing", [&](const auto& m) { return is_state(m, state, "probing"); }, 120);
  alpha->kill9();
  alpha->start();
  viewer.wait_for("interrupted", [&](const auto& m) { return is_state(m, state, "interrupted"); }, 10);

  // A reader that comes later gets it as the retained state, and the station's status names the job
  // that holds it.
  testing::MqttListener later(broker_->port(), "viewer", "viewer-pw", {state, "cmmd/alpha/status"});
  const daemon::MqttMessage retained = later.wait_for("the retained state", [&](const auto& m) {
    return is_topic(m, state) && m.retain;
  }, 5);
  EXPECT_EQ(payload(retained).at("state"), "interrupted") << retained.payload;
  const daemon::MqttMessage status = later.wait_for("the retained status", [](const auto& m) {
    return is_topic(m, "cmmd/alpha/status") && m.retain;
  }, 5);
  EXPECT_EQ(payload(status).at("job"), (json{{"id", id}, {"state", "interrupted"}})) << status.payload;
}

// A broker acknowledges before it saves: killed in between, it comes back without the result, and
// the station has already dropped its outbox copy. The station publishes it again on reconnecting.
TEST_F(Fleet, ABrokerBackWithAnEmptyDatabaseGetsTheStatusAndRecentJobsAgainFromTheStation) {
  auto alpha = station("alpha", testing::sample_sim_block());
  daemon::RpcClient local = alpha->client();
  const int id = testing::submit_quick_job(local, dir_ / "scan");
  testing::wait_for_job(local, id, {"done"}, 120);
  wait_until_acknowledged(*alpha, 10);
  broker_->kill9();
  broker_->start();  // the fixture's broker saves nothing: it is back with no retained message at all

  const std::string jobs = "cmmd/alpha/jobs/" + std::to_string(id) + "/";
  testing::MqttListener viewer(broker_->port(), "viewer", "viewer-pw", {jobs + "result"});
  viewer.wait_for("the result published again", [&](const auto& m) { return is_topic(m, jobs + "result"); }, 15);
  testing::MqttListener later(broker_->port(), "viewer", "viewer-pw", {"cmmd/alpha/status", "cmmd/alpha/jobs/#"});
  for (const std::string& topic : {jobs + "result", jobs + "state", std::string("cmmd/alpha/status")}) {
    const daemon::MqttMessage got = later.wait_for("retained " + topic, [&](const auto& m) {
      return is_topic(m, topic) && m.retain;
    }, 5);
    if (topic == "cmmd/alpha/status") {
      EXPECT_TRUE(payload(got).value("online", false)) << got.payload;
    } else {
      EXPECT_EQ(payload(got).at("state"), "done") << topic << ": " << got.payload;
      EXPECT_EQ(payload(got).at("job"), id) << got.payload;
    }
  }
}

// The second wall: with the shipped config, the broker itself keeps an acknowledged result through
// a kill -9, for a station that is not there to publish it again.
TEST(FleetBroker, TheShippedConfigSavesAnAcknowledgedResultBeforeAKill9) {
  const auto dir = daemon::fresh_folder("fleet-persistence");
  testing::BrokerProcess broker(dir / "broker", kUsers, {.shipped_persistence = true});
  broker.start();
  testing::CmmdInstance alpha(dir / "alpha", testing::sample_sim_block(), station_config("alpha", broker.port()));
  alpha.start();
  daemon::RpcClient local = alpha.client();
  const int id = testing::submit_quick_job(local, dir / "scan");
  testing::wait_for_job(local, id, {"done"}, 120);
  wait_until_acknowledged(alpha, 10);
  EXPECT_EQ(alpha.terminate(), 0);  // what comes back after the kill is the broker's own
  broker.kill9();
  broker.start();
  const std::string result = "cmmd/alpha/jobs/" + std::to_string(id) + "/result";
  testing::MqttListener viewer(broker.port(), "viewer", "viewer-pw", {result});
  const daemon::MqttMessage kept =
      viewer.wait_for("the result from the broker's database", [&](const auto& m) { return is_topic(m, result); }, 5);
  EXPECT_TRUE(kept.retain);
  EXPECT_EQ(payload(kept).at("state"), "done") << kept.payload;
}

// The documented set-up: the broker takes TLS only. cmmd and cmmctl verify its certificate against
// the CA they are given; a client without it, or with another CA, gets no link.
TEST(FleetTls, StationsAndCmmctlTalkTlsAndAnotherCaIsRefused) {
  const auto dir = daemon::fresh_folder("fleet-tls");
  testing::BrokerProcess broker(dir / "broker", kUsers, {.tls = true});
  broker.start();
  json config = station_config("alpha", broker.port());
  config["mqtt"]["tls"] = {{"ca_file", broker.tls_ca().string()}};
  testing::CmmdInstance alpha(dir / "alpha", testing::sample_sim_block(), config);
  alpha.start();
  const std::string ctl = kCmmctl + " --broker 127.0.0.1:" + std::to_string(broker.port()) +
                          " --broker-user viewer --broker-password viewer-pw";
  auto r = cmm::test::run_command(ctl + " --broker-ca " + broker.tls_ca().string() + " fleet");
  for (int i = 0; i < 30 && r.output.find("alpha            online") == std::string::npos; ++i)
    r = cmm::test::run_command(ctl + " --broker-ca " + broker.tls_ca().string() + " fleet");  // alpha still connecting
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("alpha            online"), std::string::npos) << r.output;

  r = cmm::test::run_command(ctl + " fleet 2>&1");  // plain MQTT to a TLS port
  EXPECT_NE(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("cannot reach the MQTT broker at 127.0.0.1:" + std::to_string(broker.port())), std::string::npos)
      << r.output;
  testing::make_test_certificates(dir / "other", "client");
  r = cmm::test::run_command(ctl + " --broker-ca " + (dir / "other" / "ca.crt").string() + " fleet 2>&1");
  EXPECT_NE(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("TLS"), std::string::npos) << r.output;
  // A wrong password is said as such, at once.
  r = cmm::test::run_command(kCmmctl + " --broker 127.0.0.1:" + std::to_string(broker.port()) +
                             " --broker-user viewer --broker-password wrong --broker-ca " + broker.tls_ca().string() +
                             " fleet 2>&1");
  EXPECT_NE(r.output.find("refused: "), std::string::npos) << r.output;
}

}  // namespace
}  // namespace cmm
