// The tip qualifications a job records (qualifications.json) and how its touches are compensated
// for them: what counts as the same qualification, the file's round trip, and a touch made under a
// later qualification moved by the radius difference along its approach, with the others untouched.
#include "daemon/job_qualifications.hpp"

#include <gtest/gtest.h>

#include "daemon/job_result.hpp"

namespace cmm::daemon {
namespace {

description::StylusTip tip(double radius, const hal::Vec3& offset, const char* qualified_utc) {
  description::StylusTip t;
  t.id = "T1";
  t.ball_radius_mm = radius;
  t.offset = offset;
  if (qualified_utc != nullptr) {
    description::TipQualification q;
    q.ball_radius_mm = radius;
    q.offset = offset;
    q.residual_rms_mm = 0.0004;
    q.touches = 9;
    q.time_utc = qualified_utc;
    t.qualification = q;
  }
  return t;
}

TEST(JobQualifications, TheSameQualificationIsTheSameRadiusOffsetAndTimeStamp) {
  const hal::Vec3 offset(0.012, -0.010, 0.013);
  const QualificationInForce a = in_force(tip(0.998512, offset, "2026-11-24T12:00:00Z"), "in force when the job began");
  EXPECT_TRUE(same_qualification(a, tip(0.998512, offset, "2026-11-24T12:00:00Z")));
  // A controller that restarted: nominal values, no qualification.
  EXPECT_FALSE(same_qualification(a, tip(1.0, hal::Vec3::Zero(), nullptr)));
  // Qualified again: another time stamp, whatever the values.
  EXPECT_FALSE(same_qualification(a, tip(0.998512, offset, "2026-11-24T12:30:00Z")));
  EXPECT_FALSE(same_qualification(a, tip(0.998513, offset, "2026-11-24T12:00:00Z")));
  EXPECT_FALSE(same_qualification(a, tip(0.998512, offset + hal::Vec3(0, 0, 1e-6), "2026-11-24T12:00:00Z")));
  // Never qualified, still never qualified.
  const QualificationInForce nominal = in_force(tip(1.0, hal::Vec3::Zero(), nullptr), "in force when the job began");
  EXPECT_TRUE(same_qualification(nominal, tip(1.0, hal::Vec3::Zero(), nullptr)));
  EXPECT_FALSE(same_qualification(nominal, tip(1.0, hal::Vec3::Zero(), "2026-11-24T12:00:00Z")));
  EXPECT_EQ(describe(a), "r 0.998512 mm, qualified 2026-11-24T12:00:00Z");
  EXPECT_EQ(describe(nominal), "r 1.000000 mm nominal (never qualified)");
}

TEST(JobQualifications, TheFileReadsBackAsWritten) {
  JobQualifications q{"T1", {in_force(tip(1.0, hal::Vec3::Zero(), nullptr), "in force when the job began"),
                             in_force(tip(0.998512, hal::Vec3(0.012, -0.01, 0.013), "2026-11-24T12:00:00Z"),
                                      "machine.qualify while the job was held")},
                      std::nullopt, ""};
  q.list[0].since_utc = "2026-11-24T11:00:00Z";
  q.list[1].since_utc = "2026-11-24T12:01:00Z";
  const nlohmann::json j = to_json(q);
  EXPECT_EQ(j["qualifications"][1]["index"], 1);
  EXPECT_TRUE(j["qualifications"][0]["qualification"].is_null());
  const JobQualifications back = job_qualifications_from_json(j);
  EXPECT_EQ(to_json(back), j);
  EXPECT_TRUE(same_qualification(back.list[1], tip(0.998512, hal::Vec3(0.012, -0.01, 0.013), "2026-11-24T12:00:00Z")));
  EXPECT_THROW(job_qualifications_from_json({{"tip", "T1"}, {"qualifications", nlohmann::json::array()}}),
               std::invalid_argument);
  // A tip the operator was asked to fit by hand is kept until it is confirmed.
  q.fitting = "T2";
  q.fitting_since_utc = "2026-11-24T12:02:00Z";
  const JobQualifications fitting = job_qualifications_from_json(to_json(q));
  EXPECT_EQ(fitting.fitting, "T2");
  EXPECT_EQ(fitting.fitting_since_utc, "2026-11-24T12:02:00Z");
  // A file from before jobs used several tips names the tip once: every entry is that tip's.
  nlohmann::json old = j;
  for (nlohmann::json& e : old["qualifications"]) e.erase("tip");
  EXPECT_EQ(job_qualifications_from_json(old).list[1].tip, "T1");
}

TEST(JobQualifications, EachTipsEntriesAreItsOwn) {
  description::StylusTip t2 = tip(2.5, hal::Vec3(0, 0, -20), "2026-11-24T12:00:00Z");
  t2.id = "T2";
  const JobQualifications q{"T1",
                            {in_force(tip(1.0, hal::Vec3::Zero(), "2026-11-24T12:00:00Z"), "began"),
                             in_force(t2, "first used"),
                             in_force(tip(1.001, hal::Vec3::Zero(), "2026-11-24T13:00:00Z"), "again")},
                            std::nullopt, ""};
  EXPECT_EQ(q.current("T1"), 2);
  EXPECT_EQ(q.current("T2"), 1);
  EXPECT_EQ(q.current("T3"), std::nullopt);
  EXPECT_FALSE(same_qualification(q.list[1], tip(2.5, hal::Vec3(0, 0, -20), "2026-11-24T12:00:00Z")))
      << "T1 with T2's values is not T2";
  // Each touch is moved from the radius its own tip was planned with.
  std::vector<planner::Touch> plan(2);
  plan[0].id = 1, plan[0].direction = hal::Vec3(0, 0, -1), plan[0].tip = "T1";
  plan[1].id = 2, plan[1].direction = hal::Vec3(1, 0, 0), plan[1].tip = "T2";
  std::map<int, hal::TouchResult> touches = {{1, {true, hal::Vec3(1, 2, 3), 1, 0, "T1"}}, {2, {true, hal::Vec3(1, 2, 3), 1, 0, "T2"}}};
  const auto out = touches_at_radius(plan, touches, {{1, 2}, {2, 1}}, &q, {{"T1", 1.0}, {"T2", 2.49}});
  EXPECT_NEAR((out.at(1).centre - hal::Vec3(1, 2, 3 - 0.001)).norm(), 0, 1e-12);
  EXPECT_NEAR((out.at(2).centre - hal::Vec3(1 + 0.01, 2, 3)).norm(), 0, 1e-12);
}

TEST(JobQualifications, ATouchMadeUnderALaterQualificationIsMovedByTheRadiusDifferenceAlongItsApproach) {
  const double planned = 1.0;
  JobQualifications q{"T1", {in_force(tip(planned, hal::Vec3::Zero(), "2026-11-24T12:00:00Z"), "began"),
                             in_force(tip(1.004, hal::Vec3::Zero(), "2026-11-24T13:00:00Z"), "again")},
                      std::nullopt, ""};
  std::vector<planner::Touch> plan(3);
  for (int i = 0; i < 3; ++i) plan[static_cast<std::size_t>(i)].id = 10 + i;
  plan[0].direction = hal::Vec3(0, 0, -1);
  plan[1].direction = hal::Vec3(3, 4, 0);  // not unit: the approach is its direction
  plan[2].direction = hal::Vec3(1, 0, 0);
  std::map<int, hal::TouchResult> touches;
  for (int i = 0; i < 3; ++i) touches[10 + i] = {true, hal::Vec3(1, 2, 3), 1, 0, "T1"};
  touches[12].contact = false;  // a miss keeps where the ball stopped
  const std::map<int, int> made_under = {{10, 0}, {11, 1}, {12, 1}};
  const auto out = touches_at_radius(plan, touches, made_under, &q, {{"T1", planned}});
  EXPECT_EQ(out.at(10).centre, hal::Vec3(1, 2, 3)) << "a touch of the plan's own qualification moved";
  EXPECT_NEAR((out.at(11).centre - (hal::Vec3(1, 2, 3) + 0.004 * hal::Vec3(0.6, 0.8, 0))).norm(), 0, 1e-15);
  EXPECT_EQ(out.at(12).centre, hal::Vec3(1, 2, 3));
  EXPECT_FALSE(out.at(12).contact);
  // Without a record (a job from before there was one) nothing moves.
  EXPECT_EQ(touches_at_radius(plan, touches, made_under, nullptr, {{"T1", planned}}).at(11).centre, hal::Vec3(1, 2, 3));
}

}  // namespace
}  // namespace cmm::daemon
