// The field checker: typed reads with fallbacks, every problem with its JSON Pointer in one pass
// (unknown keys included), nested inputs under their member, and files that are not JSON.
#include <unistd.h>

#include "hal/description/json_fields.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

namespace cmm::description {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using nlohmann::json;

std::vector<std::string> lines(const FieldError& e) {
  std::vector<std::string> out;
  for (const FieldProblem& p : e.problems()) out.push_back(p.pointer + ": " + p.message);
  return out;
}

TEST(JsonFields, ReadsValuesAndDefaults) {
  JsonFields b(json::parse(R"({"port": 502, "host": "127.0.0.1", "rtu": false, "timeout_s": 0.5,
                               "home": [1, 2, 3], "corner": [4, 5], "link": {"retries": 3}})"));
  EXPECT_EQ(b.integer("port", 0, 0, 65535), 502);
  EXPECT_EQ(b.text("host", ""), "127.0.0.1");
  EXPECT_FALSE(b.flag("rtu", true));
  EXPECT_DOUBLE_EQ(b.number("timeout_s", 1, 0, 60), 0.5);
  EXPECT_EQ(b.vec3("home", Vec3::Zero()), Vec3(1, 2, 3));
  EXPECT_EQ(b.vec3("corner", Vec3::Zero(), true), Vec3(4, 5, 0));
  JsonFields link = b.object("link");
  EXPECT_EQ(link.integer("retries", 0, 0, 10), 3);
  EXPECT_EQ(link.integer("backoff_ms", 250, 0, 10000), 250);  // absent: the default
  EXPECT_EQ(link.pointer(), "/link");
  link.finish();
  b.finish();
  EXPECT_TRUE(b.ok());
  EXPECT_NO_THROW(b.throw_if_problems("test"));
}

TEST(JsonFields, ReportsEveryProblemWithItsPointer) {
  JsonFields b(json::parse(R"({"port": 70000, "host": 5, "rtu": "no", "timeout_s": -1, "gap": 0,
                               "home": [1, 2], "mode": "fast", "typo_key": 1, "items": [{"a": 1}, 7],
                               "link": {"retries": 1.5, "extra": true}, "a/b": {"x": "y"}})"));
  b.integer("port", 0, 0, 65535);
  b.text("host", "");
  b.flag("rtu", false);
  b.number("timeout_s", 1, 0, 60);
  b.positive("gap", 1);
  b.vec3("home", Vec3::Zero());
  b.text("mode", "tcp", {"tcp", "rtu"});
  b.objects("items");
  JsonFields link = b.object("link");
  link.integer("retries", 0, 0, 10);
  link.finish();
  b.object("a/b").number("x", 0, 0, 1);
  b.require("missing_key", "what it holds");
  b.finish();
  try {
    b.throw_if_problems("cmmd.json");
    FAIL() << "no FieldError";
  } catch (const FieldError& e) {
    // Unknown keys first (a misspelling is often why a key is missing), the rest as read.
    EXPECT_THAT(lines(e),
                ElementsAre(HasSubstr("/link/extra: unknown key (known: retries)"), HasSubstr("/typo_key: unknown key"),
                            HasSubstr("/port: must be an integer in [0, 65535], not 70000"),
                            HasSubstr("/host: must be a string, not 5"), HasSubstr("/rtu: must be true or false"),
                            HasSubstr("/timeout_s: must be in [0, 60], not -1"), HasSubstr("/gap: must be positive, not 0"),
                            HasSubstr("/home: must be [x, y, z], not [1,2]"),
                            HasSubstr("/mode: must be one of rtu, tcp, not \"fast\""),
                            HasSubstr("/items/1: must be an object, not 7"), HasSubstr("/link/retries: must be an integer"),
                            HasSubstr("/a~1b/x: must be a number"), HasSubstr("/missing_key: missing (what it holds)")));
    EXPECT_THAT(e.what(), HasSubstr("cmmd.json: 13 problems"));
    EXPECT_EQ(e.pointer(), "/link/extra");
  }
}

TEST(JsonFields, IntegersAreComparedBeforeNarrowing) {
  for (const json& id : {json(4294967297LL), json(18446744073709551615ULL), json(-2147483649LL), json(1.5)}) {
    JsonFields b(json{{"id", id}});
    EXPECT_EQ(b.integer("id", -7, 1, 100), -7) << id;
    EXPECT_FALSE(b.ok()) << id;
  }
  JsonFields b(json{{"id", 100}});
  EXPECT_EQ(b.integer("id", -7, 1, 100), 100);
}

TEST(JsonFields, NestedInputsLandUnderTheirMember) {
  JsonFields b(json{{"plate", {{"thickness_mm", -1}}}}, "/registration");
  b.problems_of(FieldError("plate", {{"/thickness_mm", "must be positive, not -1"}}), "plate");
  b.finish();  // "plate" counts as read
  try {
    b.throw_if_problems("job request");
    FAIL();
  } catch (const FieldError& e) {
    EXPECT_THAT(lines(e), ElementsAre("/registration/plate/thickness_mm: must be positive, not -1"));
    EXPECT_EQ(std::string(e.what()), "job request: /registration/plate/thickness_mm: must be positive, not -1");
  }
}

TEST(JsonFields, ANonObjectInputIsOneProblem) {
  JsonFields b(json::parse("[1, 2]"), "/machine");
  EXPECT_FALSE(b.expect_object());
  EXPECT_THROW(b.throw_if_problems("x"), FieldError);
}

// An object given as something else is one problem, not one more for each key it should hold.
TEST(JsonFields, AMemberThatIsNotAnObjectIsOneProblem) {
  JsonFields b(json{{"travel_box", 5}});
  JsonFields box = b.object("travel_box");
  EXPECT_FALSE(box.require("min"));
  EXPECT_FALSE(box.require("max"));
  JsonFields missing = b.object("reference_sphere");
  EXPECT_FALSE(missing.require("radius_mm"));  // a missing object's keys are missing, though
  try {
    b.throw_if_problems("machine.json");
    FAIL();
  } catch (const FieldError& e) {
    EXPECT_THAT(lines(e), ElementsAre("/travel_box: must be an object, not 5", "/reference_sphere/radius_mm: missing"));
  }
}

TEST(JsonFields, FilesThatAreNotJsonNameTheByte) {
  const auto file = std::filesystem::temp_directory_path() / ("cmmd_json_fields_test_" + std::to_string(getpid()) + ".json");
  std::ofstream(file) << "{\"a\": 1,\n \"b\": }";
  try {
    read_json_file(file, "the test input");
    FAIL();
  } catch (const FieldError& e) {
    EXPECT_THAT(e.what(), HasSubstr(file.string() + ": not valid JSON at byte"));
  }
  std::ofstream(file) << "{\"a\": 1e400}";
  EXPECT_THROW(read_json_file(file, "the test input"), FieldError);
  std::filesystem::remove(file);
  try {
    read_json_file(file, "the test input");
    FAIL();
  } catch (const FieldError& e) {
    EXPECT_THAT(e.what(), HasSubstr("cannot open the test input"));
  }
}

}  // namespace
}  // namespace cmm::description
