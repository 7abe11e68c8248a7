// What cmmctl reads off a broker anyone may publish on: statuses for `cmmctl fleet` and job topics
// as notifications, shown as far as they make sense and otherwise left out, never a stop.
#include "daemon/client/fleet_listing.hpp"

#include <gtest/gtest.h>

#include "daemon/client/station_link.hpp"

namespace cmm::daemon {
namespace {

using nlohmann::json;

TEST(FleetListing, AStatusBecomesOneLineWithTheStationFromTheTopic) {
  const auto status = fleet_entry("cmmd/alpha/status", "cmmd",
                                  R"({"station":"mallory","online":true,"machine":{"link":"up","lifecycle":"enabled",)"
                                  R"("fault":{"kind":"estop"}},"job":{"id":3,"state":"probing"}})");
  ASSERT_TRUE(status);
  EXPECT_EQ((*status)["station"], "alpha");
  EXPECT_EQ(fleet_line(*status), "alpha            online   machine up (enabled) fault estop  job 3 probing");
  EXPECT_EQ(fleet_line(*fleet_entry("cmmd/beta/status", "cmmd", R"({"online":false})")), "beta             OFFLINE");
}

TEST(FleetListing, OtherTopicsAndPayloadsThatAreNoObjectAreLeftOutAndWrongTypesReadAsText) {
  EXPECT_FALSE(fleet_entry("cmmd/alpha/status", "cmmd", "not json"));
  EXPECT_FALSE(fleet_entry("cmmd/alpha/status", "cmmd", "[1,2]"));
  EXPECT_FALSE(fleet_entry("cmmd/a/b/status", "cmmd", "{}"));
  EXPECT_FALSE(fleet_entry("other/alpha/status", "cmmd", "{}"));
  EXPECT_FALSE(fleet_entry("cmmd//status", "cmmd", "{}"));
  const auto odd = fleet_entry("cmmd/alpha/status", "cmmd", R"({"online":"yes","machine":{"link":7},"job":{"id":"x"}})");
  ASSERT_TRUE(odd);
  EXPECT_EQ(fleet_line(*odd), "alpha            OFFLINE  machine 7 (?)  job x ?");
}

TEST(StationLink, JobTopicsBecomeTheNotificationsASocketClientGets) {
  const auto state = job_notification("cmmd/alpha/jobs/3/state", R"({"job":3,"state":"done"})");
  ASSERT_TRUE(state);
  EXPECT_EQ(json::parse(*state), (json{{"jsonrpc", "2.0"}, {"method", "job.state"}, {"params", {{"job", 3}, {"state", "done"}}}}));
  EXPECT_TRUE(job_notification("cmmd/alpha/jobs/3/progress", R"({"job":3,"done":1})"));
  EXPECT_FALSE(job_notification("cmmd/alpha/jobs/3/result", R"({"job":3})"));
  EXPECT_FALSE(job_notification("cmmd/alpha/jobs/3/state", "garbage"));
  EXPECT_FALSE(job_notification("cmmd/alpha/jobs/3/state", R"({"job":"3"})"));
}

}  // namespace
}  // namespace cmm::daemon
