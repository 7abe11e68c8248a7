// job.submit's and plan.preview's params: the raw-scan fields (tolerance_mm, bin_size_mm, adaptive)
// read with the one field checker, each bad one refused with its JSON Pointer.
#include "daemon/job_request.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "daemon/client/rpc_error.hpp"

namespace cmm::daemon {
namespace {

using ::testing::HasSubstr;
using nlohmann::json;

const DaemonConfig& config() {
  static const DaemonConfig c = daemon_config_from_json(json::object(), "job_request_test", "/nonexistent");
  return c;
}

// A preview of an uploaded PCD with `fields` set as given (null too, which a merge patch would drop).
json preview(const json& fields) {
  json params = {{"model", "sha256:" + std::string(64, 'a') + ".pcd"}};
  for (const auto& [key, value] : fields.items()) params[key] = value;
  return params;
}

TEST(JobRequestScan, FieldsAreReadWhenGiven) {
  const JobRequest r = parse_job_request(preview({{"tolerance_mm", 0.02}, {"bin_size_mm", 0.15}, {"adaptive", true}}),
                                         config(), true);
  ASSERT_TRUE(r.tolerance_mm);
  EXPECT_EQ(*r.tolerance_mm, 0.02);
  ASSERT_TRUE(r.bin_size_mm);
  EXPECT_EQ(*r.bin_size_mm, 0.15);
  EXPECT_TRUE(r.adaptive);
}

TEST(JobRequestScan, LeftOutTheyStayUnsetForTheFrontEndsDefaults) {
  const JobRequest r = parse_job_request(preview(json::object()), config(), true);
  EXPECT_FALSE(r.tolerance_mm);
  EXPECT_FALSE(r.bin_size_mm);
  EXPECT_FALSE(r.adaptive);
}

TEST(JobRequestScan, EachBadFieldIsRefusedAtItsPointer) {
  struct Case {
    json patch;
    std::string path, message;
  };
  const std::vector<Case> cases = {
      {{{"tolerance_mm", 0}}, "/tolerance_mm", "must be in [0.001, 10]"},
      {{{"tolerance_mm", 11}}, "/tolerance_mm", "must be in [0.001, 10]"},
      {{{"tolerance_mm", "0.05"}}, "/tolerance_mm", "must be a number"},
      {{{"tolerance_mm", nullptr}}, "/tolerance_mm", "must be a number"},
      {{{"bin_size_mm", -0.1}}, "/bin_size_mm", "must be in [0.001, 10]"},
      {{{"bin_size_mm", json::array()}}, "/bin_size_mm", "must be a number"},
      {{{"adaptive", 1}}, "/adaptive", "must be true or false"},
      {{{"tolerance", 0.05}}, "/tolerance", "unknown"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.patch.dump());
    try {
      parse_job_request(preview(c.patch), config(), true);
      ADD_FAILURE() << "no error";
    } catch (const RpcError& e) {
      EXPECT_EQ(e.code(), rpc_code::invalid_params);
      EXPECT_EQ(e.data().value("path", ""), c.path);
      EXPECT_THAT(e.what(), HasSubstr(c.message));
    }
  }
}

}  // namespace
}  // namespace cmm::daemon
