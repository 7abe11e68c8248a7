// The store and journal layer on a really full disk (a small tmpfs, filled): every write that fails
// says which file and ENOSPC, leaves nothing half written that a later read would trust, and works
// again once there is room; job.json still saves on a full disk, from the space kept aside for it.
#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "geometry/atomic_file.hpp"
#include "daemon/client/base64.hpp"
#include "daemon/job_store.hpp"
#include "daemon/model_store.hpp"
#include "daemon/client/rpc_error.hpp"
#include "daemon/client/sha256.hpp"
#include "daemon/storage_error.hpp"
#include "daemon/touch_journal.hpp"
#include "fresh_folder.hpp"
#include "geometry/file_error.hpp"
#include "tests/tools/small_tmpfs.hpp"

namespace cmm::daemon {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// A 1 MiB tmpfs of the test's own; the test skips where it cannot be mounted (not root).
#define MOUNT_OR_SKIP(disk)                       \
  if (!(disk).mounted()) GTEST_SKIP() << (disk).error()

JournalEntry entry(int id) {
  JournalEntry e;
  e.touch_id = id;
  e.result.contact = true;
  e.result.centre = hal::Vec3(278.000123456789 + id * 0.1, 353.1 / 3, 42.000000912345 - id * 1e-7);
  e.result.travel_mm = 4.000731;
  e.result.t_s = 12.345678901234 * id;
  e.result.tip_id = "T1";
  e.qualification = id / 10;
  return e;
}

std::string read_all(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), {});
}

std::vector<std::string> names_in(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

// The FileError `call` throws, which must carry ENOSPC.
template <typename Call>
geometry::FileError enospc_of(Call call) {
  try {
    call();
  } catch (const geometry::FileError& e) {
    EXPECT_EQ(e.error_number(), ENOSPC) << e.what();
    EXPECT_THAT(e.what(), HasSubstr("No space left on device"));
    const auto failure = storage_failure(e);
    EXPECT_TRUE(failure && failure->full()) << e.what();
    return e;
  }
  ADD_FAILURE() << "the write succeeded on a full disk";
  return geometry::FileError::whole("none", "none");
}

TEST(StorageFull, AJournalLineThatDoesNotFitIsTakenBackWhole) {
  test::SmallTmpfs disk(fresh_folder("full-journal") / "disk", 1 << 20);
  MOUNT_OR_SKIP(disk);
  const fs::path file = disk.dir() / "touches.jsonl";
  TouchJournal journal(file);
  journal.append(entry(0));
  disk.fill();
  // The first lines still fit the page the file has; the one that needs a new page does not.
  int made = 1;
  std::uintmax_t size_before = fs::file_size(file);
  const geometry::FileError e = enospc_of([&] {
    for (;; ++made) {
      size_before = fs::file_size(file);
      journal.append(entry(made));
    }
  });
  EXPECT_EQ(e.file(), file);
  EXPECT_THAT(e.what(), HasSubstr("touches.jsonl: append"));
  EXPECT_EQ(fs::file_size(file), size_before) << "the line that did not fit was left half written";
  Recovery r = recover_journal(file);
  EXPECT_FALSE(r.torn_tail);
  ASSERT_EQ(static_cast<int>(r.entries.size()), made);

  disk.unfill();
  journal.append(entry(made));  // the same touch, once there is room
  r = recover_journal(file);
  EXPECT_FALSE(r.torn_tail);
  ASSERT_EQ(static_cast<int>(r.entries.size()), made + 1);
  for (int i = 0; i <= made; ++i) {
    EXPECT_EQ(r.entries[static_cast<std::size_t>(i)].touch_id, i);
    EXPECT_EQ(r.entries[static_cast<std::size_t>(i)].result.centre, entry(i).result.centre);
    EXPECT_EQ(r.entries[static_cast<std::size_t>(i)].qualification, entry(i).qualification);
  }
}

TEST(StorageFull, ATornTailIsCutWithoutNeedingSpace) {
  test::SmallTmpfs disk(fresh_folder("full-torn") / "disk", 1 << 20);
  MOUNT_OR_SKIP(disk);
  const fs::path file = disk.dir() / "touches.jsonl";
  {
    std::ofstream out(file, std::ios::binary);
    out << to_json_line(entry(0)) << "\n" << to_json_line(entry(1)).substr(0, 30);
  }
  disk.fill();
  TouchJournal journal(file);  // cuts the torn line in place: no copy of the journal is written
  EXPECT_EQ(fs::file_size(file), to_json_line(entry(0)).size() + 1);
  EXPECT_FALSE(recover_journal(file).torn_tail);
}

TEST(StorageFull, AnAtomicWriteThatDoesNotFitLeavesTheOldFileAndNoTempFile) {
  test::SmallTmpfs disk(fresh_folder("full-atomic") / "disk", 1 << 20);
  MOUNT_OR_SKIP(disk);
  const fs::path file = disk.dir() / "result.json";
  geometry::write_atomically(file, "old");
  disk.fill();
  const geometry::FileError e = enospc_of([&] { geometry::write_atomically(file, std::string(64 * 1024, 'n')); });
  EXPECT_EQ(e.file(), file);
  EXPECT_EQ(read_all(file), "old");
  EXPECT_EQ(names_in(disk.dir()), (std::vector<std::string>{"filler", "result.json"}));
}

TEST(StorageFull, JobJsonStillSavesOnAFullDiskAndACreateThatDoesNotFitLeavesNoJob) {
  test::SmallTmpfs disk(fresh_folder("full-store") / "disk", 1 << 20);
  MOUNT_OR_SKIP(disk);
  JobStore store(disk.dir() / "jobs");
  JobRecord r = store.create({{"model", "file:block.ply"}}, "one", "file:block.ply");
  disk.fill();
  for (const JobState state : {JobState::planning, JobState::probing, JobState::paused}) {
    r.state = state;
    r.reason = std::string("storage full: ") + std::string(300, 'x');
    store.save(r);  // from the spare, and the spare taken again from the old record's space
    EXPECT_EQ(JobStore(disk.dir() / "jobs").recover().at(0).state,
              state == JobState::paused ? JobState::paused : JobState::interrupted);
  }
  EXPECT_TRUE(nlohmann::json::parse(read_all(store.folder(1) / "job.json")).at("reason") == r.reason);

  const geometry::FileError e = enospc_of([&] { store.create({{"model", "file:block.ply"}}, "two", "file:block.ply"); });
  EXPECT_THAT(e.what(), HasSubstr("000002"));
  EXPECT_FALSE(fs::exists(store.folder(2))) << "a job folder half made was left";
  EXPECT_EQ(JobStore(disk.dir() / "jobs").recover().size(), 1u);
  disk.unfill();
  EXPECT_EQ(store.create({{"model", "file:block.ply"}}, "two", "file:block.ply").id, 2);
}

TEST(StorageFull, AnUploadChunkThatDoesNotFitIsStorageFullAndTheUploadGoesOnFromTheChunkBefore) {
  test::SmallTmpfs disk(fresh_folder("full-upload") / "disk", 1 << 20);
  MOUNT_OR_SKIP(disk);
  const fs::path sample = fs::path(CMMD_SOURCE_DIR) / "config/samples/case3_block.ply";
  const std::string bytes = read_all(sample), sha = sha256_hex_of_file(sample);
  ModelStore models(disk.dir() / "models", {});
  const auto chunk = [&](std::uint64_t offset, std::uint64_t length) {
    return UploadChunk{"block.ply", bytes.size(), sha, offset, encode_base64(std::string_view(bytes).substr(offset, length))};
  };
  const std::uint64_t first = 64 * 1024;
  EXPECT_EQ(models.upload(chunk(0, first)).received, first);
  const fs::path part = disk.dir() / "models" / ".partial" / (sha + ".part");
  disk.fill();
  try {
    models.upload(chunk(first, bytes.size() - first));
    FAIL() << "a chunk was taken on a full disk";
  } catch (const RpcError& e) {
    EXPECT_EQ(e.code(), rpc_code::storage_full) << e.what();
    EXPECT_EQ(e.data().at("file"), part.string());
    EXPECT_EQ(e.data().at("expected_offset"), first);
    EXPECT_THAT(e.what(), HasSubstr("No space left on device"));
  }
  EXPECT_EQ(fs::file_size(part), first) << "half a chunk was kept";
  EXPECT_THROW(models.resolve("sha256:" + sha), RpcError) << "a model was made of part of the upload";

  disk.unfill();
  const UploadStatus done = models.upload(chunk(first, bytes.size() - first));  // the same chunk again
  EXPECT_TRUE(done.complete);
  EXPECT_EQ(sha256_hex_of_file(models.resolve(done.model)), sha);
}

}  // namespace
}  // namespace cmm::daemon
