// A full disk under a real cmmd (docs/api.md, jobs): its state folder on a small tmpfs, filled with
// one file at a chosen moment of a job and emptied again. The job pauses, never fails, with the file
// and the errno in its reason; job.json says so too; the resumes lose no touch and make none twice
// (the simulator's trigger noise is one draw per touch, in order, so a touch made twice would shift
// every centre after it: the result must equal an uninterrupted run's to the last bit); a job whose
// result could not be written makes it again without moving the machine; an upload and a submit on
// a full disk are −32021 storage_full and leave nothing half written; the temp files of a cmmd killed
// mid-write are gone after the next start.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cmmd_instance.hpp"
#include "job_watch.hpp"
#include "scratch_folder.hpp"
#include "daemon/client/base64.hpp"
#include "daemon/client/rpc_error.hpp"
#include "daemon/client/sha256.hpp"
#include "daemon/touch_journal.hpp"
#include "tests/tools/small_tmpfs.hpp"

namespace cmm {
namespace {

using nlohmann::json;
using testing::CmmdInstance;

constexpr int storage_full = -32021;  // docs/api.md
constexpr double wait_s = 120;
constexpr double wall_time_scale = 100;  // about 10 ms of wall time per touch: the job is still running when the disk fills
constexpr std::uint64_t state_disk_bytes = 64u << 20;

struct Scratch : testing::ScratchFolder {
  explicit Scratch(const std::string& name) : ScratchFolder("cmmd_storage_test", name) {}
};

#define MOUNT_OR_SKIP(disk) \
  if (!(disk).mounted()) GTEST_SKIP() << (disk).error()

// What a finished job measured: its journal (the touches in the order made) and its result.
struct Measured {
  std::vector<daemon::JournalEntry> journal;
  std::vector<int> program;
  json result;
};

Measured measured(daemon::RpcClient& client, const std::filesystem::path& job_folder, int job) {
  Measured m;
  const daemon::Recovery r = daemon::recover_journal(job_folder / "touches.jsonl");
  EXPECT_FALSE(r.torn_tail) << "touches.jsonl ends in a torn line";
  m.journal = r.entries;
  m.program = testing::program_order(job_folder);
  m.result = client.call("job.result", {{"job", job}});
  return m;
}

std::vector<int> ids_of(const std::vector<daemon::JournalEntry>& journal) {
  std::vector<int> ids;
  for (const daemon::JournalEntry& e : journal) ids.push_back(e.touch_id);
  return ids;
}

// The job once, uninterrupted, on the in-process simulator with no wall time: the touches a job
// must end with.
const Measured& uninterrupted(const std::filesystem::path& scan, const json& request) {
  static const Measured once = [&] {
    const Scratch dir("baseline");
    CmmdInstance cmmd(dir.path / "cmmd", testing::timed_sim_block(0));
    cmmd.start();
    daemon::RpcClient client = cmmd.client();
    const int id = testing::submit_job(client, scan, request);
    testing::wait_for_job(client, id, {"done"}, wait_s);
    Measured m = measured(client, cmmd.job_folder(id), id);
    EXPECT_EQ(ids_of(m.journal), m.program);
    EXPECT_EQ(cmmd.terminate(), 0);
    return m;
  }();
  return once;
}

// Every planned touch made once, in order, with the very centres of the uninterrupted run, and the
// same points measured.
void expect_same_touches(const Measured& got, const Measured& want) {
  ASSERT_EQ(got.program, want.program) << "not the same plan";
  ASSERT_EQ(ids_of(got.journal), got.program) << "touches.jsonl does not hold the program's touches, each once";
  for (std::size_t i = 0; i < got.journal.size(); ++i) {
    ASSERT_EQ(got.journal[i].result.contact, want.journal[i].result.contact) << "touch " << got.journal[i].touch_id;
    ASSERT_EQ(got.journal[i].result.centre, want.journal[i].result.centre)
        << "touch " << got.journal[i].touch_id << " (line " << i + 1 << ") differs from the uninterrupted run's: "
        << "a touch was made twice or lost before it";
  }
  EXPECT_EQ(got.result.at("touches"), want.result.at("touches"));
  EXPECT_EQ(got.result.at("summary"), want.result.at("summary"));
  for (std::size_t i = 0; i < want.result.at("edge_points").size(); ++i)
    EXPECT_EQ(got.result["edge_points"][i]["measured_M"], want.result["edge_points"][i]["measured_M"]) << "edge point " << i;
}

// Notifications until `match`; the job ending first is a failure that says how.
json await_job(daemon::RpcClient& watch, int job, const std::string& what, const testing::NotificationMatch& match) {
  return testing::await_job(watch, job, what, match, wait_s, testing::job_ended);
}

// A job held for the disk: paused, its reason and fault naming the file and ENOSPC, and job.json on
// the disk saying the same as cmmd does.
json expect_held_for_storage(daemon::RpcClient& client, const std::filesystem::path& job_folder, int job) {
  const json record = client.call("job.get", {{"job", job}});
  EXPECT_EQ(record.at("state"), "paused") << record.dump();
  const std::string reason = record.at("reason");
  EXPECT_EQ(reason.rfind("storage full: ", 0), 0u) << reason;
  EXPECT_NE(reason.find("No space left on device"), std::string::npos) << reason;
  EXPECT_NE(reason.find("free space, then job.resume"), std::string::npos) << reason;
  EXPECT_TRUE(record.at("fault").is_object() && record["fault"].at("kind") == "StorageFull") << record.dump();
  const json on_disk = testing::read_json_file(job_folder / "job.json");
  EXPECT_EQ(on_disk.at("state"), record.at("state")) << "job.json says otherwise than cmmd: " << on_disk.dump();
  EXPECT_EQ(on_disk.at("reason"), record.at("reason"));
  return record;
}

// Nothing half written in the job's folder: no temp file of an atomic write, no partial PLY.
void expect_no_half_files(const std::filesystem::path& job_folder) {
  for (const auto& e : std::filesystem::directory_iterator(job_folder)) {
    const std::string name = e.path().filename().string();
    EXPECT_EQ(name.find(".tmp-"), std::string::npos) << name << " was left behind";
    EXPECT_EQ(name.find(".partial"), std::string::npos) << name << " was left behind";
  }
}

double machine_clock(daemon::RpcClient& client) { return client.call("machine.status").at("t_s").get<double>(); }

TEST(CmmdStorage, AFullDiskPausesTheJobBeforeATouchAndAtItsResultAndTheResumesLoseAndRepeatNoTouch) {
  const Scratch dir("job");
  const auto scan = testing::sample_scan(dir.path / "scan");
  const json request = testing::spaced_job_request(dir.path / "scan");
  test::SmallTmpfs disk(dir.path / "cmmd" / "state", state_disk_bytes);
  MOUNT_OR_SKIP(disk);
  const Measured& want = uninterrupted(scan, request);

  CmmdInstance cmmd(dir.path / "cmmd", testing::timed_sim_block(wall_time_scale));
  cmmd.start();
  daemon::RpcClient client = cmmd.client(), watch = cmmd.client();
  watch.call("server.subscribe", {{"topics", {"job"}}});
  const int id = testing::submit_job(client, scan, request);
  const std::filesystem::path folder = cmmd.job_folder(id);
  const int total = await_job(watch, id, "probing", testing::job_progress_at_least(id, "probing", 0))["params"]["total"];

  // Full a third of the way through: the next touch cannot record itself, so it does not begin.
  await_job(watch, id, "a third of the touches", testing::job_progress_at_least(id, "probing", total / 3));
  disk.fill();
  await_job(watch, id, "the hold for the full disk", testing::job_state_is(id, "paused"));
  const json held = expect_held_for_storage(client, folder, id);
  std::printf("full after %zu of %d touches: %s\n", testing::journal_touch_ids(folder).size(), total,
              held["reason"].get<std::string>().c_str());
  // Resumed while still full: it holds again at once, having made no touch.
  const std::size_t made = testing::journal_touch_ids(folder).size();
  client.call("job.resume", {{"job", id}});
  await_job(watch, id, "the hold again", testing::job_state_is(id, "paused"));
  expect_held_for_storage(client, folder, id);
  EXPECT_EQ(testing::journal_touch_ids(folder).size(), made) << "a touch was made on a full disk";
  expect_no_half_files(folder);
  disk.unfill();
  client.call("job.resume", {{"job", id}});

  // Full again once nearly every touch is made, with a few pages left for those: the result files
  // are what no longer fit (the merged cloud alone is far larger).
  await_job(watch, id, "the last touches", testing::job_progress_at_least(id, "probing", total - 20));
  client.call("job.pause", {{"job", id}});
  await_job(watch, id, "the operator's pause", testing::job_state_is(id, "paused"));
  disk.fill(32 * 1024);
  client.call("job.resume", {{"job", id}});
  await_job(watch, id, "the hold at the result", testing::job_state_is(id, "paused"));
  const json at_result = expect_held_for_storage(client, folder, id);
  const std::string reason = at_result["reason"];
  std::printf("full at the result: %s\n", reason.c_str());
  EXPECT_TRUE(reason.find("result.csv") != std::string::npos || reason.find("result.holes.csv") != std::string::npos ||
              reason.find("merged.ply") != std::string::npos || reason.find("result.json") != std::string::npos)
      << reason;
  EXPECT_EQ(testing::journal_touch_ids(folder), testing::program_order(folder)) << "not every touch was made before the result";
  EXPECT_FALSE(std::filesystem::exists(folder / "result.json"));
  expect_no_half_files(folder);

  // Room again: the result is made from the journal, and the machine does not move for it.
  const double clock_s = machine_clock(client);
  disk.unfill();
  client.call("job.resume", {{"job", id}});
  testing::wait_for_job(client, id, {"done"}, wait_s);
  EXPECT_EQ(machine_clock(client), clock_s) << "the machine moved to rebuild a result";
  expect_same_touches(measured(client, folder, id), want);
  EXPECT_EQ(cmmd.terminate(), 0);
}

// The journal on a disk of its own (the jobs folder its own tmpfs, the touch file not on it): the
// touch made when the journal no longer fits is kept and journalled first by the resume.
TEST(CmmdStorage, ATouchTheJournalHadNoRoomForIsKeptAndJournalledByTheResumeNotMadeAgain) {
  const Scratch dir("journal");
  const auto scan = testing::sample_scan(dir.path / "scan");
  const json request = testing::spaced_job_request(dir.path / "scan");
  test::SmallTmpfs disk(dir.path / "cmmd" / "state" / "jobs", state_disk_bytes);
  MOUNT_OR_SKIP(disk);
  const Measured& want = uninterrupted(scan, request);

  CmmdInstance cmmd(dir.path / "cmmd", testing::timed_sim_block(wall_time_scale));
  cmmd.start();
  daemon::RpcClient client = cmmd.client(), watch = cmmd.client();
  watch.call("server.subscribe", {{"topics", {"job"}}});
  const int id = testing::submit_job(client, scan, request);
  const std::filesystem::path folder = cmmd.job_folder(id);
  const int total = await_job(watch, id, "probing", testing::job_progress_at_least(id, "probing", 0))["params"]["total"];
  await_job(watch, id, "a third of the touches", testing::job_progress_at_least(id, "probing", total / 3));
  disk.fill();  // the journal's last page still takes a few lines; the line after does not fit
  await_job(watch, id, "the hold for the full disk", testing::job_state_is(id, "paused"));
  const json held = expect_held_for_storage(client, folder, id);
  EXPECT_NE(held["reason"].get<std::string>().find("touches.jsonl"), std::string::npos) << held.dump();
  const std::vector<int> journal = testing::journal_touch_ids(folder), program = testing::program_order(folder);
  ASSERT_LT(journal.size(), program.size());
  std::printf("the journal full after %zu of %d touches: %s\n", journal.size(), total, held["reason"].get<std::string>().c_str());

  disk.unfill();
  client.call("job.resume", {{"job", id}});
  const json first = await_job(watch, id, "the first touch after the resume",
                               [&](const json& n) { return n.at("method") == "job.touch" && n["params"].at("job") == id; });
  EXPECT_EQ(first["params"]["touch"], program[journal.size()]) << "the touch kept aside is not the first journalled";
  testing::wait_for_job(client, id, {"done"}, wait_s);
  expect_same_touches(measured(client, folder, id), want);
  EXPECT_EQ(cmmd.terminate(), 0);
}

// The RpcError `call` throws, which must be storage_full.
template <typename Call>
daemon::RpcError storage_full_of(Call call) {
  try {
    call();
  } catch (const daemon::RpcError& e) {
    EXPECT_EQ(e.code(), storage_full) << e.what() << " " << e.data().dump();
    EXPECT_NE(std::string(e.what()).find("No space left on device"), std::string::npos) << e.what();
    return e;
  }
  ADD_FAILURE() << "the call succeeded on a full disk";
  return daemon::RpcError(0, "none");
}

TEST(CmmdStorage, AnUploadAndASubmitOnAFullDiskAreStorageFullAndLeaveNothingHalfWritten) {
  const Scratch dir("upload");
  const auto scan = testing::sample_scan(dir.path / "scan");
  test::SmallTmpfs disk(dir.path / "cmmd" / "state", state_disk_bytes);
  MOUNT_OR_SKIP(disk);
  CmmdInstance cmmd(dir.path / "cmmd", testing::timed_sim_block(0));
  cmmd.start();
  daemon::RpcClient client = cmmd.client();

  std::ifstream in(scan, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), {});
  const std::string sha = daemon::sha256_hex_of_file(scan);
  const std::uint64_t first = bytes.size() / 3;
  const auto chunk = [&](std::uint64_t offset, std::uint64_t length) {
    return json{{"name", "scan.ply"}, {"size", bytes.size()}, {"sha256", sha}, {"offset", offset},
                {"data", daemon::encode_base64(std::string_view(bytes).substr(offset, length))}};
  };
  EXPECT_EQ(client.call("model.upload", chunk(0, first)).at("received"), first);
  disk.fill();
  const daemon::RpcError upload = storage_full_of([&] { client.call("model.upload", chunk(first, bytes.size() - first)); });
  const std::filesystem::path part = disk.dir() / "models" / ".partial" / (sha + ".part");
  EXPECT_EQ(std::filesystem::path(upload.data().value("file", "")).filename(), part.filename()) << upload.data().dump();
  EXPECT_EQ(upload.data().value("expected_offset", std::uint64_t{0}), first) << upload.data().dump();
  EXPECT_EQ(std::filesystem::file_size(part), first) << "the partial upload holds half a chunk";
  disk.unfill();
  const json done = client.call("model.upload", chunk(first, bytes.size() - first));  // the same chunk, now there is room
  ASSERT_TRUE(done.at("complete").get<bool>()) << done.dump();

  disk.fill();
  json request = testing::spaced_job_request(dir.path / "scan");
  request["model"] = done.at("model");
  const daemon::RpcError submit = storage_full_of([&] { client.call("job.submit", request); });
  EXPECT_NE(submit.data().value("file", "").find("jobs/000001"), std::string::npos) << submit.data().dump();
  EXPECT_FALSE(std::filesystem::exists(cmmd.job_folder(1))) << "a job folder half made was left";
  EXPECT_TRUE(client.call("job.list").at("jobs").empty());
  disk.unfill();
  const int id = client.call("job.submit", request).at("id");
  EXPECT_EQ(id, 1) << "the refused submit took an id";
  client.call("job.cancel", {{"job", id}});
  EXPECT_EQ(cmmd.terminate(), 0);
}

void write_text(const std::filesystem::path& file, const std::string& text) {
  std::filesystem::create_directories(file.parent_path());
  std::ofstream(file) << text;
}

TEST(CmmdStorage, TheTempFilesOfAWriterKilledMidWriteAreRemovedAtStartAndNothingElse) {
  const Scratch dir("temps");
  CmmdInstance cmmd(dir.path / "cmmd", testing::timed_sim_block(0));
  const std::filesystem::path state = dir.path / "cmmd" / "state", job = cmmd.job_folder(7);
  // No process has a pid above the kernel's limit (2^22): these writers are surely dead.
  const std::vector<std::filesystem::path> dead = {job / ".result.csv.tmp-2147483647", job / ".merged.ply.tmp-2147483646",
                                                   state / "models" / ".0123.ply.tmp-2147483645",
                                                   state / ".touch_in_progress.json.tmp-2147483644"};
  const std::vector<std::filesystem::path> kept = {job / "result.csv", job / "result.csv.tmp-1", job / ".notes.tmp-x",
                                                   job / (".report.html.tmp-" + std::to_string(::getpid()))};  // a live writer's
  for (const auto& file : dead) write_text(file, "half");
  for (const auto& file : kept) write_text(file, "whole");
  cmmd.start();
  for (const auto& file : dead) EXPECT_FALSE(std::filesystem::exists(file)) << file;
  for (const auto& file : kept) EXPECT_TRUE(std::filesystem::exists(file)) << file;
  EXPECT_EQ(cmmd.terminate(), 0);
}

}  // namespace
}  // namespace cmm
