// The durable writer: a replaced file is the old or the new one, never half; a record goes through
// its spare without new space; a chunk that fails leaves the file as it was before it; the temp files
// of writers killed mid-write are swept, and nothing else.
#include "geometry/atomic_file.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "geometry/file_error.hpp"
#include "tests/daemon/killed_writer.hpp"

namespace cmm::geometry {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

fs::path fresh_folder(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("cmmd_atomic_file_test_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string read_all(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

TEST(AtomicFile, ReplacesWholeAndLeavesNoTempFile) {
  const fs::path dir = fresh_folder("replace");
  const fs::path file = dir / "result.json";
  write_atomically(file, "first");
  write_atomically(file, "second, longer");
  EXPECT_EQ(read_all(file), "second, longer");
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);
  try {
    write_atomically(dir / "no" / "such" / "folder.json", "x");
    FAIL() << "wrote into a folder that does not exist";
  } catch (const FileError& e) {
    EXPECT_THAT(e.what(), HasSubstr("folder.json"));
    EXPECT_NE(e.error_number(), 0);
  }
  fs::remove_all(dir);
}

TEST(AtomicFile, ARecordGoesThroughItsSpare) {
  const fs::path dir = fresh_folder("spare");
  const fs::path file = dir / "job.json", spare = dir / ".job.json.spare";
  EXPECT_FALSE(write_through_spare(file, spare, "no spare yet", 64));
  ASSERT_TRUE(allocate_spare(spare, 64));
  EXPECT_EQ(fs::file_size(spare), 64u);
  EXPECT_TRUE(write_through_spare(file, spare, "{\"state\": \"paused\"}", 64));
  EXPECT_EQ(read_all(file), "{\"state\": \"paused\"}");
  EXPECT_FALSE(fs::exists(spare)) << "the spare became the record";
  ASSERT_TRUE(allocate_spare(spare, 64));
  EXPECT_FALSE(write_through_spare(file, spare, std::string(65, 'x'), 64)) << "too big for the spare";
  EXPECT_EQ(read_all(file), "{\"state\": \"paused\"}");
  fs::remove_all(dir);
}

TEST(AtomicFile, ChunksGoAtTheirOffsetAndCutWhatLayBeyond) {
  const fs::path dir = fresh_folder("chunk");
  const fs::path file = dir / "upload.part";
  write_chunk(file, 0, "abcdef");
  write_chunk(file, 6, "ghi");
  EXPECT_EQ(read_all(file), "abcdefghi");
  write_chunk(file, 3, "XY");  // a chunk sent again from offset 3: what lay beyond goes
  EXPECT_EQ(read_all(file), "abcXY");
  EXPECT_THROW(write_chunk(dir / "no" / "such" / "upload.part", 0, "x"), FileError);
  fs::remove_all(dir);
}

TEST(AtomicFile, TempNamesAreKnownByTheirOnePattern) {
  EXPECT_EQ(atomic_temp_writer(".result.csv.tmp-4242"), 4242);
  EXPECT_EQ(atomic_temp_writer("/state/jobs/000007/.merged.ply.tmp-17"), 17);
  EXPECT_TRUE(is_atomic_temp(".a.tmp-1"));
  for (const char* name : {"result.csv", "result.csv.tmp-12", ".result.csv.tmp-", ".result.csv.tmp-12a",
                           ".result.csv.tmp--3", ".result.csv.tmp-+3", "..tmp-12", ".tmp-12", ""})
    EXPECT_FALSE(is_atomic_temp(name)) << '"' << name << '"';
}

void touch(const fs::path& file) { std::ofstream(file) << "x"; }

// A writer killed mid-write: its temp is the writer's own name for it, and the sweep takes it.
TEST(AtomicFile, TheSweepRemovesTheTempsOfDeadWritersOnly) {
  const fs::path dir = fresh_folder("sweep");
  const fs::path file = dir / "jobs" / "000007" / "result.csv";
  fs::create_directories(file.parent_path());
  const auto temps_of_result = [&] {
    int n = 0;
    for (const auto& entry : fs::directory_iterator(file.parent_path()))
      n += entry.path().filename().string().starts_with(".result.csv.tmp-");
    return n;
  };
  // The kill may land between two writes, after a rename: then there is no temp, and it goes again.
  const std::string content(4 << 20, 'r');
  for (int attempt = 0; attempt < 50 && temps_of_result() == 0; ++attempt)
    ASSERT_TRUE(cmm::daemon::kill_writer_when([&] { for (;;) write_atomically(file, content); },
                                              [&] { return temps_of_result() > 0; }));
  ASSERT_EQ(temps_of_result(), 1) << "no writer was killed mid-write";

  const fs::path same_pid = dir / (".merged.ply.tmp-" + std::to_string(::getpid()));  // an earlier process's
  touch(same_pid);
  const fs::path live = dir / ("model.ply.tmp-" + std::to_string(::getppid()));       // no temp: no leading dot
  const fs::path live_temp = dir / (".model.ply.tmp-" + std::to_string(::getppid()));
  for (const fs::path& f : {live, live_temp, dir / "result.csv.tmp-1", dir / ".notes.tmp-x"}) touch(f);

  const TempSweep sweep = remove_stale_atomic_temps(dir);
  EXPECT_EQ(sweep.removed, 2u);
  EXPECT_TRUE(sweep.problems.empty()) << sweep.problems.front();
  EXPECT_EQ(temps_of_result(), 0);
  EXPECT_FALSE(fs::exists(same_pid));
  EXPECT_TRUE(fs::exists(live_temp)) << "a temp of a live writer (this test's parent) was removed";
  for (const fs::path& f : {live, dir / "result.csv.tmp-1", dir / ".notes.tmp-x"}) EXPECT_TRUE(fs::exists(f)) << f;
  EXPECT_EQ(remove_stale_atomic_temps(dir / "none").removed, 0u);
  EXPECT_TRUE(remove_stale_atomic_temps(dir / "none").problems.empty()) << "a missing folder is nothing to sweep";
  fs::remove_all(dir);
}

}  // namespace
}  // namespace cmm::geometry
