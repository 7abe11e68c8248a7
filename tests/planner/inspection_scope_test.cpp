// The job verdict's precedence (fail > incomplete > undecided > pass, excluded deciding nothing), the
// features a scope asks for or leaves out, and the "inspect" field's one JSON form with its error paths.
#include "planner/inspection_scope.hpp"

#include <gtest/gtest.h>

#include "planner/inspection.hpp"
#include "planner/inspection_scope_json.hpp"

namespace cmm::planner {
namespace {

VerdictCounts counts(std::initializer_list<Verdict> verdicts) {
  VerdictCounts c;
  for (Verdict v : verdicts) c.add(v);
  return c;
}

TEST(JobVerdict, FailThenIncompleteThenUndecidedThenPass) {
  using enum Verdict;
  EXPECT_EQ(job_verdict(counts({pass, fail, not_measured, undecided}), {}), fail);
  EXPECT_EQ(job_verdict(counts({pass, not_measured, undecided}), {}), incomplete);
  EXPECT_EQ(job_verdict(counts({pass, undecided}), counts({pass})), undecided);
  EXPECT_EQ(job_verdict(counts({pass, excluded, excluded}), counts({excluded})), pass);
  EXPECT_EQ(job_verdict(counts({pass}), counts({not_measured})), incomplete) << "an unmeasured hole counts as much as an edge";
  EXPECT_EQ(job_verdict(counts({excluded}), {}), incomplete) << "nothing measured is no pass";
  EXPECT_EQ(job_verdict({}, {}), incomplete);
}

TEST(JobVerdict, AFeatureIsAsGoodAsItsWorstCharacteristic) {
  using enum Verdict;
  EXPECT_EQ(worse(pass, fail), fail);
  EXPECT_EQ(worse(incomplete, fail), fail);
  EXPECT_EQ(worse(undecided, incomplete), incomplete);
  EXPECT_EQ(worse(not_measured, undecided), not_measured) << "one characteristic unmeasured: the feature is";
  EXPECT_EQ(worse(excluded, pass), pass);
  EXPECT_EQ(worse(excluded, excluded), excluded);
  const VerdictCounts c = counts({pass, fail, undecided, not_measured, incomplete, excluded});
  EXPECT_EQ(c.not_measured, 2);
  EXPECT_EQ(c.inspected(), 5);
  EXPECT_EQ(c.measured(), 3);
  for (Verdict v : {pass, fail, undecided, incomplete, not_measured, excluded})
    EXPECT_STRNE(to_string(v), "") << static_cast<int>(v);
  EXPECT_STREQ(to_string(incomplete), "incomplete");
  EXPECT_STREQ(to_string(excluded), "excluded");
}

TEST(InspectionScope, AskedListedAndNotProbeable) {
  InspectionScope all;
  EXPECT_EQ(edge_exclusion(all, 3, 1, false), "") << "by default an unprobeable feature is asked for";
  EXPECT_EQ(hole_exclusion(all, 0, false), "");

  InspectionScope s;
  s.edge_points = std::set<int>{1};
  s.curves = {4};
  s.excluded_edge_points = {2};
  s.excluded_curves = {5};
  s.exclude_reason = "clamped";
  s.exclude_not_probeable = true;
  EXPECT_EQ(edge_exclusion(s, 1, 0, true), "");
  EXPECT_EQ(edge_exclusion(s, 9, 4, true), "") << "on an asked curve";
  EXPECT_EQ(edge_exclusion(s, 9, 0, true), kNotAskedFor);
  EXPECT_EQ(edge_exclusion(s, 1, 5, true), "clamped") << "a listed exclusion beats being asked for";
  EXPECT_EQ(edge_exclusion(s, 1, 0, false), kNotProbeable);
  s.holes = std::set<int>{};
  EXPECT_EQ(hole_exclusion(s, 0, true), kNotAskedFor);
}

TEST(InspectionScopeJson, ReadsEveryFormAndWritesTheSame) {
  const nlohmann::json in = {{"curves", {3, 4}},
                             {"holes", "none"},
                             {"exclude", {{"not_probeable", true}, {"edge_points", {7}}, {"reason", "under the clamp"}}}};
  description::JsonFields f(in, "/inspect");
  const InspectionScope s = read_inspection_scope(f);
  ASSERT_TRUE(f.ok());
  EXPECT_EQ(s.edge_points, std::set<int>{}) << "curves alone ask for their points only";
  EXPECT_EQ(s.curves, (std::set<int>{3, 4}));
  EXPECT_EQ(s.holes, std::set<int>{});
  EXPECT_TRUE(s.exclude_not_probeable);
  EXPECT_EQ(s.excluded_edge_points, std::set<int>{7});
  EXPECT_EQ(s.exclude_reason, "under the clamp");
  description::JsonFields again(to_json(s));
  EXPECT_EQ(read_inspection_scope(again), s);
  EXPECT_TRUE(again.ok());

  description::JsonFields missing(nlohmann::json::object());
  EXPECT_TRUE(read_inspection_scope(missing).everything());
  description::JsonFields everything({{"edge_points", "all"}, {"holes", {0, 2}}});
  const InspectionScope some_holes = read_inspection_scope(everything);
  EXPECT_FALSE(some_holes.edge_points.has_value());
  EXPECT_EQ(some_holes.holes, (std::set<int>{0, 2}));
}

TEST(InspectionScopeJson, BadFieldsAreNamedByTheirPointers) {
  const nlohmann::json in = {{"edge_points", "some"},
                             {"holes", {1, 1}},
                             {"curves", {-2}},
                             {"exclude", {{"holes", {0}}, {"not_probable", true}}},
                             {"colour", "red"}};
  description::JsonFields f(in, "/inspect");
  (void)read_inspection_scope(f);
  std::string all;
  try {
    f.throw_if_problems("job request");
  } catch (const description::FieldError& e) {
    for (const std::string& line : e.lines()) all += line + "\n";
  }
  EXPECT_NE(all.find("/inspect/colour"), std::string::npos) << all;
  EXPECT_NE(all.find("/inspect/exclude/not_probable"), std::string::npos) << all;
  EXPECT_NE(all.find("/inspect/edge_points"), std::string::npos) << all;
  EXPECT_NE(all.find("/inspect/holes/1: names feature 1 twice"), std::string::npos) << all;
  EXPECT_NE(all.find("/inspect/curves/0"), std::string::npos) << all;
  EXPECT_NE(all.find("/inspect/exclude/reason: must say why"), std::string::npos) << all;
}

}  // namespace
}  // namespace cmm::planner
