// ending_of, the one mapping from what ended a run to the job's state: a hold keeps its own state,
// unless a cancel or a shutdown came while the run was running into it.
#include "daemon/job_ending.hpp"

#include <gtest/gtest.h>

namespace cmm::daemon {
namespace {

JobEnding end_with_hold(const JobControl& control) {
  return ending_of(std::make_exception_ptr(JobHold(JobState::paused, "tip T1 is not qualified", JobFault{"Qualification", "x"})),
                   control);
}

TEST(JobEnding, AHoldPausesWithItsReasonAndFault) {
  const JobControl nothing;
  const JobEnding e = end_with_hold(nothing);
  EXPECT_EQ(e.state, JobState::paused);
  EXPECT_EQ(e.reason, "tip T1 is not qualified");
  ASSERT_TRUE(e.fault);
  EXPECT_EQ(e.fault->kind, "Qualification");
}

TEST(JobEnding, ACancelOrAShutdownThatCameMeanwhileIsNotLostToAPause) {
  JobControl cancel;
  cancel.cancel = true;
  EXPECT_EQ(end_with_hold(cancel).state, JobState::cancelled);
  EXPECT_EQ(end_with_hold(cancel).reason, "cancelled by the operator");
  JobControl shutdown;
  shutdown.shutdown = true;
  EXPECT_EQ(end_with_hold(shutdown).state, JobState::interrupted);
  // A hold that is itself a cancel stays one.
  EXPECT_EQ(ending_of(std::make_exception_ptr(JobHold(JobState::cancelled, "cancelled by the operator")), shutdown).state,
            JobState::cancelled);
}

}  // namespace
}  // namespace cmm::daemon
