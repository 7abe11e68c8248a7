// job.submit's and plan.preview's params: the raw-scan fields (tolerance_mm, bin_size_mm, adaptive), the
// tips (tip, allow_unqualified_tip), what to inspect (inspect) and the model references read with the
// one field checker, each bad one refused with its JSON Pointer.
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

// The preview with `patch` is refused as invalid params at `path`, saying `message`.
void expect_refused(const json& patch, const std::string& path, const std::string& message) {
  SCOPED_TRACE(patch.dump());
  try {
    parse_job_request(preview(patch), config(), true);
    ADD_FAILURE() << "no error";
  } catch (const RpcError& e) {
    EXPECT_EQ(e.code(), rpc_code::invalid_params);
    EXPECT_EQ(e.data().value("path", ""), path);
    EXPECT_THAT(e.what(), HasSubstr(message));
  }
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
  for (const Case& c : cases) expect_refused(c.patch, c.path, c.message);
}

// A bad nominal reference was refused at "/model", the job's other model, or not before the lookup.
TEST(JobRequestModels, ABadReferenceIsRefusedAtItsOwnField) {
  const std::string good = "sha256:" + std::string(64, 'b') + ".stl";
  struct Case {
    json patch;
    std::string path, message;
  };
  const std::vector<Case> cases = {
      {{{"nominal", {{"model", "sha256:0123"}}}}, "/nominal/model", "sha256 must be 64 hex digits"},
      {{{"nominal", {{"model", good + ".exe"}}}}, "/nominal/model", "after the digest only"},
      {{{"nominal", {{"model", "file:../cad/part.stl"}}}}, "/nominal/model", "\"..\" is not allowed"},
      {{{"nominal", {{"model", "part.stl"}}}}, "/nominal/model", "is not a model reference"},
      {{{"nominal", {{"model", 7}}}}, "/nominal/model", "must be a string"},
      {{{"model", "file:/srv/part.stl"}, {"nominal", {{"model", good}}}}, "/model", "need a relative name"},
  };
  for (const Case& c : cases) expect_refused(c.patch, c.path, c.message);
  EXPECT_EQ(parse_job_request(preview({{"nominal", {{"model", good}}}}), config(), true).nominal->model, good);
}

TEST(JobRequestTips, AutoAndNoUnqualifiedTipUnlessSaid) {
  const JobRequest plain = parse_job_request(preview(json::object()), config(), true);
  EXPECT_EQ(plain.tip, "auto");
  EXPECT_FALSE(plain.allow_unqualified_tip);
  const JobRequest named = parse_job_request(preview({{"tip", "T2"}, {"allow_unqualified_tip", true}}), config(), true);
  EXPECT_EQ(named.tip, "T2");
  EXPECT_TRUE(named.allow_unqualified_tip);
  for (const json& patch : {json{{"tip", "T9"}}, json{{"tip", 2}}, json{{"allow_unqualified_tip", "yes"}}})
    expect_refused(patch, "/" + patch.begin().key(), "");
}

TEST(JobRequestInspect, LeftOutEveryFeatureIsAskedFor) {
  EXPECT_TRUE(parse_job_request(preview(json::object()), config(), true).inspect.everything());
}

TEST(JobRequestInspect, ChosenFeaturesAndExclusionsAreRead) {
  const JobRequest r = parse_job_request(
      preview({{"inspect", {{"edge_points", {1, 2}},
                            {"holes", "all"},
                            {"exclude", {{"not_probeable", true}, {"holes", {3}}, {"reason", "a dowel pin sits in it"}}}}}}),
      config(), true);
  EXPECT_EQ(r.inspect.edge_points, (std::set<int>{1, 2}));
  EXPECT_FALSE(r.inspect.holes.has_value());
  EXPECT_TRUE(r.inspect.exclude_not_probeable);
  EXPECT_EQ(r.inspect.excluded_holes, std::set<int>{3});
  EXPECT_EQ(r.inspect.exclude_reason, "a dowel pin sits in it");
}

TEST(JobRequestInspect, EachBadFieldIsRefusedAtItsPointer) {
  struct Case {
    json inspect;
    std::string path, message;
  };
  const std::vector<Case> cases = {
      {"all", "/inspect", "must be an object"},
      {{{"edge_points", "most"}}, "/inspect/edge_points", "must be one of"},
      {{{"edge_points", 3}}, "/inspect/edge_points", "must be \"all\", \"none\" or an array of feature ids"},
      {{{"holes", {0, -1}}}, "/inspect/holes/1", "must be"},
      {{{"curves", "all"}}, "/inspect/curves", "must be an array of feature ids"},
      {{{"holes", {2, 2}}}, "/inspect/holes/1", "names feature 2 twice"},
      {{{"exclude", {{"edge_points", {4}}}}}, "/inspect/exclude/reason", "must say why"},
      {{{"exclude", {{"reason", "clamped"}}}}, "/inspect/exclude/reason", "names no feature"},
      {{{"exclude", {{"not_probeable", "yes"}}}}, "/inspect/exclude/not_probeable", "must be true or false"},
      {{{"exclude", {{"unreachable", true}}}}, "/inspect/exclude/unreachable", "unknown"},
      {{{"edges", "all"}}, "/inspect/edges", "unknown"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.inspect.dump());
    try {
      parse_job_request(preview({{"inspect", c.inspect}}), config(), true);
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
