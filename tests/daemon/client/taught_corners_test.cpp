// with_taught_corner: cmmctl teach's edit of a measure_plate file — the corner set or added, in
// scan_corners' order, everything else kept, a malformed file refused with what is wrong.
#include "daemon/client/taught_corners.hpp"

#include <gtest/gtest.h>

namespace cmm::daemon {
namespace {

using nlohmann::json;

TEST(TaughtCorner, ANewFileGetsTheCornerAlone) {
  const TaughtCorner t = with_taught_corner(nullptr, 3, {1.5, 2, -3});
  EXPECT_EQ(t.file, json::parse(R"({"rough_machine": [{"id": 3, "machine": [1.5, 2.0, -3.0]}]})"));
  EXPECT_TRUE(t.replaced.is_null());
  EXPECT_EQ(t.summary, "rough_machine has corners 3");
}

TEST(TaughtCorner, FollowsScanCornersOrderAndKeepsTheRest) {
  const json file = json::parse(R"({"scan_corners": [{"id": 4, "scan": [0, 0, 0]}, {"id": 1, "scan": [1, 0, 0]},
                                                      {"id": 2, "scan": [2, 0, 0]}],
                                    "rough_machine": [{"id": 9, "machine": [9, 9, 9]}, {"id": 2, "machine": [2, 2, 2]}],
                                    "plate": "../plate.json"})");
  TaughtCorner t = with_taught_corner(file, 1, {10, 20, 30});
  EXPECT_EQ(t.file["rough_machine"], json::parse(R"([{"id": 1, "machine": [10.0, 20.0, 30.0]}, {"id": 2, "machine": [2, 2, 2]},
                                                     {"id": 9, "machine": [9, 9, 9]}])"));
  EXPECT_EQ(t.file["scan_corners"], file["scan_corners"]);
  EXPECT_EQ(t.file["plate"], "../plate.json");
  EXPECT_EQ(t.summary, "rough_machine has corners 1, 2, 9; still to teach: 4");

  t = with_taught_corner(t.file, 2, {5, 6, 7});
  EXPECT_EQ(t.replaced, json::parse("[2, 2, 2]"));
  EXPECT_EQ(t.file["rough_machine"][1], json::parse(R"({"id": 2, "machine": [5.0, 6.0, 7.0]})"));
  t = with_taught_corner(t.file, 4, {0, 0, 0});
  EXPECT_EQ(t.file["rough_machine"][0]["id"], 4);
  EXPECT_EQ(t.summary, "rough_machine has corners 4, 1, 2, 9; every scan corner is taught");
}

TEST(TaughtCorner, AMalformedFileIsRefusedSayingWhatIsWrong) {
  const auto message = [](const json& file) {
    try {
      with_taught_corner(file, 1, {0, 0, 0});
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(message(json::array()).find("must be a JSON object"), std::string::npos);
  EXPECT_NE(message({{"rough_machine", 3}}).find("rough_machine must be a list"), std::string::npos);
  EXPECT_NE(message({{"rough_machine", {{{"id", "A"}}}}}).find("rough_machine[0] must be an object with an integer \"id\""),
            std::string::npos);
  EXPECT_NE(message({{"scan_corners", {1, 2}}}).find("scan_corners[0]"), std::string::npos);
}

}  // namespace
}  // namespace cmm::daemon
