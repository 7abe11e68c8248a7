// The job store on real folders: records round-trip, a restart turns running jobs into interrupted
// ones and keeps counting ids, a crash inside create is skipped, a damaged job.json is named, and a
// process killed with SIGKILL while creating and saving jobs leaves a store that recovers whole.
#include "daemon/job_store.hpp"

#include <filesystem>
#include <fstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "geometry/atomic_file.hpp"
#include "fresh_folder.hpp"
#include "geometry/file_error.hpp"
#include "killed_writer.hpp"

namespace cmm::daemon {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

nlohmann::json request(int seed) {
  return {{"model", "file:block.ply"}, {"delta_mm", 0.2}, {"seed", seed}, {"name", "block " + std::to_string(seed)}};
}

TEST(JobState, NamesRoundTripAndClassesDoNotOverlap) {
  for (JobState s : {JobState::queued, JobState::planning, JobState::registering, JobState::probing, JobState::paused,
                     JobState::interrupted, JobState::done, JobState::failed, JobState::cancelled}) {
    EXPECT_EQ(job_state_from_string(to_string(s)), s);
    EXPECT_LE(int(is_running(s)) + int(is_resumable(s)) + int(is_final(s)), 1) << to_string(s);
  }
  EXPECT_TRUE(is_running(JobState::registering));
  EXPECT_TRUE(is_resumable(JobState::interrupted));
  EXPECT_TRUE(is_final(JobState::cancelled));
  EXPECT_FALSE(is_running(JobState::queued) || is_resumable(JobState::queued) || is_final(JobState::queued));
  EXPECT_THROW(job_state_from_string("Running"), std::invalid_argument);
}

TEST(JobRecord, JsonIsTheApiRecordWithoutTheRequest) {
  JobRecord r;
  r.id = 7;
  r.name = "block";
  r.state = JobState::paused;
  r.reason = "operator stop";
  r.model = "sha256:" + std::string(64, 'a');
  r.created = "2026-11-24T12:00:00Z";
  r.updated = "2026-11-24T12:05:00Z";
  r.progress = {"probing", 12, 40, 93.5};
  r.fault = JobFault{"EStop", "e-stop pressed"};
  r.request = request(1);
  const nlohmann::json j = r;
  EXPECT_EQ(j, nlohmann::json::parse(R"({"id": 7, "name": "block", "state": "paused", "reason": "operator stop",
      "model": "sha256:aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa",
      "created": "2026-11-24T12:00:00Z", "updated": "2026-11-24T12:05:00Z",
      "progress": {"phase": "probing", "done": 12, "total": 40, "eta_s": 93.5},
      "fault": {"kind": "EStop", "message": "e-stop pressed"}, "verdict": null})"));
  const auto back = j.get<JobRecord>();
  EXPECT_EQ(nlohmann::json(back), j);
  r.fault.reset();
  EXPECT_TRUE(nlohmann::json(r).at("fault").is_null());
  EXPECT_FALSE(nlohmann::json(r).get<JobRecord>().fault.has_value());
  // A done job's verdict goes with the record; a record from before verdicts reads as none.
  r.verdict = {{"verdict", "fail"}, {"edge_points", {{"pass", 3}, {"fail", 1}}}, {"holes", {{"pass", 1}}}};
  EXPECT_EQ(nlohmann::json(r).get<JobRecord>().verdict, r.verdict);
  nlohmann::json old = r;
  old.erase("verdict");
  EXPECT_TRUE(old.get<JobRecord>().verdict.is_null());
}

TEST(JobStore, CreatedAndSavedJobsComeBackOnRecover) {
  const fs::path dir = fresh_folder("jobs-roundtrip");
  JobStore store(dir);
  JobRecord first = store.create(request(1), "first", "file:block.ply");
  const JobRecord second = store.create(request(2), "second", "sha256:" + std::string(64, 'b'));
  EXPECT_EQ(first.id, 1);
  EXPECT_EQ(second.id, 2);
  EXPECT_EQ(first.state, JobState::queued);
  EXPECT_EQ(store.folder(2), dir / "000002");
  first.state = JobState::done;
  first.progress = {"probing", 40, 40, 0};
  first.updated = "2026-11-24T13:00:00Z";
  store.save(first);
  store.write(1, JobFile::result, "{\"ok\": true}");

  const auto jobs = JobStore(dir).recover();
  ASSERT_EQ(jobs.size(), 2u);
  EXPECT_EQ(nlohmann::json(jobs[0]), nlohmann::json(first));
  EXPECT_EQ(jobs[0].request, request(1));
  EXPECT_EQ(nlohmann::json(jobs[1]), nlohmann::json(second));
  EXPECT_EQ(jobs[1].request, request(2));
  EXPECT_EQ(store.read(1, JobFile::result), "{\"ok\": true}");
  EXPECT_EQ(store.path(1, JobFile::result), dir / "000001" / "result.json");
  EXPECT_EQ(store.read(1, JobFile::plan), std::nullopt);
  EXPECT_THROW(store.write(9, JobFile::result, "x"), geometry::FileError);

  // A registration made again sets the journal aside, and the plan goes.
  store.write(1, JobFile::touches, "{}\n");
  store.write(1, JobFile::plan, "{}");
  store.set_aside(1, JobFile::touches);
  store.remove(1, JobFile::plan);
  EXPECT_FALSE(store.read(1, JobFile::touches));
  EXPECT_FALSE(store.read(1, JobFile::plan));
  int aside = 0;
  for (const auto& entry : fs::directory_iterator(store.folder(1)))
    aside += entry.path().filename().string().rfind("touches.before-", 0) == 0;
  EXPECT_EQ(aside, 1);
  EXPECT_NO_THROW(store.set_aside(1, JobFile::touches));  // nothing to set aside
  EXPECT_NO_THROW(store.remove(1, JobFile::plan));
}

TEST(JobStore, RunningJobsBecomeInterruptedAndIdsGoOnAfterARestart) {
  const fs::path dir = fresh_folder("jobs-restart");
  {
    JobStore store(dir);
    for (JobState s : {JobState::queued, JobState::planning, JobState::probing, JobState::paused, JobState::done}) {
      JobRecord r = store.create(request(1), to_string(s), "file:block.ply");
      r.state = s;
      store.save(r);
    }
  }
  JobStore store(dir);
  const auto jobs = store.recover();
  ASSERT_EQ(jobs.size(), 5u);
  EXPECT_EQ(jobs[0].state, JobState::queued);
  EXPECT_EQ(jobs[1].state, JobState::interrupted);
  EXPECT_EQ(jobs[1].reason, "cmmd restarted during planning");
  EXPECT_EQ(jobs[2].state, JobState::interrupted);
  EXPECT_EQ(jobs[2].reason, "cmmd restarted during probing");
  EXPECT_EQ(jobs[3].state, JobState::paused);
  EXPECT_EQ(jobs[4].state, JobState::done);
  // Saved so: the next restart finds the same.
  EXPECT_EQ(JobStore(dir).recover()[2].state, JobState::interrupted);
  EXPECT_EQ(store.create(request(6), "sixth", "file:block.ply").id, 6);
}

TEST(JobStore, AFolderLeftHalfCreatedIsSkippedAndItsIdNotReused) {
  const fs::path dir = fresh_folder("jobs-half");
  {
    JobStore store(dir);
    store.create(request(1), "one", "file:block.ply");
  }
  fs::create_directory(dir / "000002");
  std::ofstream(dir / "000002" / "request.json") << request(2).dump();
  fs::create_directory(dir / "notes");  // not a job folder: ignored
  JobStore store(dir);
  const auto jobs = store.recover();
  ASSERT_EQ(jobs.size(), 1u);
  EXPECT_EQ(jobs[0].id, 1);
  EXPECT_EQ(store.create(request(3), "three", "file:block.ply").id, 3);
}

// A damaged job.json must not keep cmmd from starting (a restart loop under systemd): the job comes
// back from its folder, resumable, its reason naming the file and what was wrong.
TEST(JobStore, ADamagedJobFileIsRebuiltFromTheFolderNamingTheDamage) {
  const fs::path dir = fresh_folder("jobs-damaged");
  {
    JobStore store(dir);
    store.create(request(1), "one", "file:block.ply");
    store.create(request(2), "two", "file:block.ply");
    store.create(request(3), "three", "file:block.ply");
  }
  std::ofstream(dir / "000002" / "job.json") << R"({"id": 2, "name": "two", "state": )";
  std::ofstream(dir / "000003" / "job.json") << R"({"id": 3, "name": "three", "state": "running"})";
  std::ofstream(dir / "000003" / "result.json") << "{}";
  const std::vector<JobRecord> jobs = JobStore(dir).recover();
  ASSERT_EQ(jobs.size(), 3u);
  EXPECT_EQ(jobs[0].state, JobState::queued);
  EXPECT_EQ(jobs[1].id, 2);
  EXPECT_EQ(jobs[1].state, JobState::interrupted);
  EXPECT_THAT(jobs[1].reason, HasSubstr("000002/job.json"));
  EXPECT_EQ(jobs[1].request, request(2));
  EXPECT_EQ(jobs[1].name, request(2).value("name", ""));
  EXPECT_EQ(jobs[2].state, JobState::done);  // its result was written before the record broke
  EXPECT_THAT(jobs[2].reason, HasSubstr("running"));
  // The rebuilt record is written back, so the next start reads it as it is.
  const std::vector<JobRecord> again = JobStore(dir).recover();
  EXPECT_EQ(again[1].state, JobState::interrupted);
  EXPECT_EQ(again[1].reason, jobs[1].reason);
}

TEST(JobStore, AProcessKilledWhileCreatingAndSavingLeavesARecoverableStore) {
  const fs::path dir = fresh_folder("jobs-killed");
  const fs::path jobs = dir / "jobs", reported = dir / "reported";
  auto jobs_made = [&] {
    std::error_code error;
    const auto n = std::distance(fs::directory_iterator(jobs, error), fs::directory_iterator());
    return error ? 0 : n;
  };
  ASSERT_TRUE(kill_writer_when(
      [&] {
        // Creates jobs for ever, saving each a few times; after save returns, its progress counts
        // as reported.
        JobStore store(jobs);
        for (int i = 1;; ++i) {
          JobRecord r = store.create(request(i), "job " + std::to_string(i), "file:block.ply");
          r.state = JobState::probing;
          for (int done = 1; done <= 3; ++done) {
            r.progress = {"probing", done, 3, 0};
            store.save(r);
            // Replaced whole: a kill between truncating and writing it would read as nothing reported.
            geometry::write_atomically(reported, std::to_string(r.id) + " " + std::to_string(done));
          }
        }
      },
      [&] { return jobs_made() >= 60; }));

  int last_id = 0, last_done = 0;
  std::ifstream(reported) >> last_id >> last_done;
  ASSERT_GT(last_id, 0);
  JobStore store(jobs);
  const auto recovered = store.recover();
  ASSERT_GE(static_cast<int>(recovered.size()), last_id);
  for (std::size_t i = 0; i < recovered.size(); ++i) {
    const JobRecord& r = recovered[i];
    ASSERT_EQ(r.id, static_cast<int>(i) + 1) << "a gap: only the last job may be missing";
    EXPECT_EQ(r.request, request(r.id));
    if (r.id > last_id && r.state == JobState::queued) continue;  // killed before its first save
    EXPECT_EQ(r.state, JobState::interrupted);
    EXPECT_EQ(r.reason, "cmmd restarted during probing");
    if (r.id < last_id) {
      EXPECT_EQ(r.progress.done, 3);
    } else if (r.id == last_id) {
      EXPECT_GE(r.progress.done, last_done);
    }
  }
  EXPECT_GT(store.create(request(0), "after", "file:block.ply").id, static_cast<int>(recovered.size()));
}

}  // namespace
}  // namespace cmm::daemon
