// The durable writer: a replaced file is the old or the new one, never half; a record goes through
// its spare without new space; a chunk that fails leaves the file as it was before it.
#include "geometry/atomic_file.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "geometry/file_error.hpp"

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

}  // namespace
}  // namespace cmm::geometry
