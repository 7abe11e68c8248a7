// ConfigBlock: one pass reports every bad key by its JSON Pointer, unknown keys included.
#include "hal/config_block.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace cmm::hal {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

TEST(ConfigBlock, ReadsValuesAndDefaults) {
  ConfigBlock b(nlohmann::json::parse(R"({"port": 502, "host": "127.0.0.1", "rtu": false, "timeout_s": 0.5,
                                          "home": [1, 2, 3], "link": {"retries": 3}})"));
  EXPECT_EQ(b.integer("port", 0, 0, 65535), 502);
  EXPECT_EQ(b.text("host", ""), "127.0.0.1");
  EXPECT_FALSE(b.flag("rtu", true));
  EXPECT_DOUBLE_EQ(b.number("timeout_s", 1, 0, 60), 0.5);
  EXPECT_EQ(b.vec3("home", Vec3::Zero()), Vec3(1, 2, 3));
  ConfigBlock link = b.object("link");
  EXPECT_EQ(link.integer("retries", 0, 0, 10), 3);
  EXPECT_EQ(link.integer("backoff_ms", 250, 0, 10000), 250);  // absent: the default
  link.finish();
  b.finish();
  EXPECT_NO_THROW(b.throw_if_problems("test"));
}

TEST(ConfigBlock, ReportsEveryProblemWithItsPath) {
  ConfigBlock b(nlohmann::json::parse(R"({"port": 70000, "host": 5, "rtu": "no", "timeout_s": -1,
                                          "home": [1, 2], "mode": "fast", "typo_key": 1,
                                          "link": {"retries": 1.5, "extra": true}})"));
  b.integer("port", 0, 0, 65535);
  b.text("host", "");
  b.flag("rtu", false);
  b.number("timeout_s", 1, 0, 60);
  b.vec3("home", Vec3::Zero());
  b.text("mode", "tcp", {"tcp", "rtu"});
  ConfigBlock link = b.object("link");
  link.integer("retries", 0, 0, 10);
  link.finish();
  b.finish();
  try {
    b.throw_if_problems("cmmd.json /machine");
    FAIL() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.problems(),
                ElementsAre(HasSubstr("/port: must be in [0, 65535], not 70000"), HasSubstr("/host: must be a string"),
                            HasSubstr("/rtu: must be true or false"), HasSubstr("/timeout_s: must be in [0, 60]"),
                            HasSubstr("/home: must be [x, y, z]"), HasSubstr("/mode: must be one of rtu, tcp"),
                            HasSubstr("/link/retries: must be an integer"), HasSubstr("/link/extra: unknown key"),
                            HasSubstr("/typo_key: unknown key")));
    EXPECT_THAT(e.what(), HasSubstr("cmmd.json /machine: 9 problems"));
  }
}

TEST(ConfigBlock, RefusesANonObjectBlock) {
  ConfigBlock b(nlohmann::json::parse("[1, 2]"), "/machine");
  EXPECT_THROW(b.throw_if_problems("x"), ConfigError);
}

}  // namespace
}  // namespace cmm::hal
