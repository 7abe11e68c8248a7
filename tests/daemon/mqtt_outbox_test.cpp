// The MQTT outbox keeps job states and results on disk until the broker acknowledges them: across
// a restart, in order, and without losing one to a file it cannot read; RecentJobStates keeps what
// every connect publishes again.
#include "daemon/mqtt_outbox.hpp"

#include <gtest/gtest.h>

#include <fstream>

#include "tests/daemon/fresh_folder.hpp"

namespace cmm::daemon {
namespace {

MqttMessage message(const std::string& topic, const std::string& payload) {
  MqttMessage m;
  m.topic = topic;
  m.payload = payload;
  m.qos = 1;
  m.retain = true;
  return m;
}

std::size_t files_in(const std::filesystem::path& folder) {
  std::size_t n = 0;
  for ([[maybe_unused]] const auto& f : std::filesystem::directory_iterator(folder)) ++n;
  return n;
}

TEST(MqttOutbox, KeepsMessagesInOrderAcrossARestartUntilEachIsAcknowledged) {
  const auto dir = fresh_folder("outbox") / "mqtt-outbox";
  std::uint64_t first = 0, second = 0, third = 0;
  {
    MqttOutbox outbox(dir);
    first = outbox.add(message("cmmd/a/jobs/1/state", R"({"state":"probing"})"));
    second = outbox.add(message("cmmd/a/jobs/1/state", R"({"state":"done"})"));
    third = outbox.add(message("cmmd/a/jobs/1/result", R"({"state":"done"})"));
    outbox.remove(second);
    outbox.remove(second);  // a duplicate ack
    EXPECT_EQ(outbox.size(), 2u);
    EXPECT_EQ(files_in(dir), 2u);
  }
  MqttOutbox again(dir);  // cmmd restarted with the broker still away
  const std::vector<OutboxEntry> pending = again.pending();
  ASSERT_EQ(pending.size(), 2u);
  EXPECT_EQ(pending[0].seq, first);
  EXPECT_EQ(pending[0].message.topic, "cmmd/a/jobs/1/state");
  EXPECT_EQ(pending[0].message.payload, R"({"state":"probing"})");
  EXPECT_EQ(pending[0].message.qos, 1);
  EXPECT_TRUE(pending[0].message.retain);
  EXPECT_EQ(pending[1].seq, third);
  // Numbers go on after the highest kept, so the order holds across restarts.
  EXPECT_GT(again.add(message("cmmd/a/jobs/2/state", "{}")), third);
  for (const OutboxEntry& e : again.pending()) again.remove(e.seq);
  EXPECT_EQ(again.size(), 0u);
  EXPECT_EQ(files_in(dir), 0u);
}

TEST(MqttOutbox, AnUnreadableFileIsSetAsideNotDeletedAndTheRestIsKept) {
  const auto dir = fresh_folder("outbox-bad") / "mqtt-outbox";
  {
    MqttOutbox outbox(dir);
    outbox.add(message("cmmd/a/jobs/1/state", "{}"));
  }
  std::ofstream(dir / "00000000000000000007.json") << R"({"topic": "cmmd/a/jobs/1/st)";  // torn by a crash
  MqttOutbox again(dir);
  EXPECT_EQ(again.size(), 1u);
  EXPECT_TRUE(std::filesystem::exists(dir / "00000000000000000007.bad"));
}

TEST(MqttOutbox, AFolderItCannotWriteStillKeepsTheMessageInMemory) {
  const auto dir = fresh_folder("outbox-readonly") / "mqtt-outbox";
  MqttOutbox outbox(dir);
  std::filesystem::remove_all(dir);  // the disk's folder gone (or full): the write fails
  std::ofstream(dir.string()) << "a file where the folder was";
  const std::uint64_t seq = outbox.add(message("cmmd/a/jobs/1/result", "{}"));
  ASSERT_EQ(outbox.size(), 1u);
  EXPECT_EQ(outbox.pending().front().seq, seq);
}

std::vector<int> ids(const RecentJobStates& recent) {
  std::vector<int> out;
  for (const RecentJobStates::Entry& e : recent.entries()) out.push_back(e.id);
  return out;
}

TEST(RecentJobStates, KeepsEveryUnendedJobAndOnlyTheNewestEndedOnes) {
  RecentJobStates recent(2);
  recent.set({.id = 1, .ended = false, .payload = "interrupted"});
  for (int id = 2; id <= 5; ++id) recent.set({.id = id, .ended = true, .payload = "done"});
  recent.set({.id = 6, .ended = false, .payload = "probing"});
  EXPECT_EQ(ids(recent), (std::vector<int>{1, 4, 5, 6}));
  // Job 1 ends: now it is the oldest ended one, and goes.
  recent.set({.id = 1, .ended = true, .payload = "cancelled"});
  EXPECT_EQ(ids(recent), (std::vector<int>{4, 5, 6}));
  recent.set({.id = 6, .ended = true, .payload = "done"});
  EXPECT_EQ(ids(recent), (std::vector<int>{5, 6}));
  EXPECT_EQ(recent.entries().back().payload, "done");
}

TEST(RecentJobStates, AStateReadBackNeverReplacesOneANotificationGave) {
  RecentJobStates recent(2);
  recent.set({.id = 7, .ended = true, .payload = "cancelled"});  // notified between job.list and the recall
  EXPECT_FALSE(recent.add_if_unknown({.id = 7, .ended = false, .payload = "interrupted"}));
  EXPECT_TRUE(recent.add_if_unknown({.id = 8, .ended = false, .payload = "interrupted"}));
  EXPECT_TRUE(recent.add_if_unknown({.id = 6, .ended = true, .payload = "done"}));
  EXPECT_FALSE(recent.add_if_unknown({.id = 5, .ended = true, .payload = "done"})) << "older than the two kept";
  const std::vector<RecentJobStates::Entry> entries = recent.entries();
  ASSERT_EQ(entries.size(), 3u);
  EXPECT_EQ(entries[1].payload, "cancelled");
  EXPECT_EQ(entries[2].payload, "interrupted");
}

}  // namespace
}  // namespace cmm::daemon
