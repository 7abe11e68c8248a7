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
                                      "machine.qualify while the job was held")}};
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
}

TEST(JobQualifications, ATouchMadeUnderALaterQualificationIsMovedByTheRadiusDifferenceAlongItsApproach) {
  const double planned = 1.0;
  JobQualifications q{"T1", {in_force(tip(planned, hal::Vec3::Zero(), "2026-11-24T12:00:00Z"), "began"),
                             in_force(tip(1.004, hal::Vec3::Zero(), "2026-11-24T13:00:00Z"), "again")}};
  std::vector<planner::Touch> plan(3);
  for (int i = 0; i < 3; ++i) plan[static_cast<std::size_t>(i)].id = 10 + i;
  plan[0].direction = hal::Vec3(0, 0, -1);
  plan[1].direction = hal::Vec3(3, 4, 0);  // not unit: the approach is its direction
  plan[2].direction = hal::Vec3(1, 0, 0);
  std::map<int, hal::TouchResult> touches;
  for (int i = 0; i < 3; ++i) touches[10 + i] = {true, hal::Vec3(1, 2, 3), 1, 0, "T1"};
  touches[12].contact = false;  // a miss keeps where the ball stopped
  const std::map<int, int> made_under = {{10, 0}, {11, 1}, {12, 1}};
  const auto out = touches_at_radius(plan, touches, made_under, &q, planned);
  EXPECT_EQ(out.at(10).centre, hal::Vec3(1, 2, 3)) << "a touch of the plan's own qualification moved";
  EXPECT_NEAR((out.at(11).centre - (hal::Vec3(1, 2, 3) + 0.004 * hal::Vec3(0.6, 0.8, 0))).norm(), 0, 1e-15);
  EXPECT_EQ(out.at(12).centre, hal::Vec3(1, 2, 3));
  EXPECT_FALSE(out.at(12).contact);
  // Without a record (a job from before there was one) nothing moves.
  EXPECT_EQ(touches_at_radius(plan, touches, made_under, nullptr, planned).at(11).centre, hal::Vec3(1, 2, 3));
}

}  // namespace
}  // namespace cmm::daemon
