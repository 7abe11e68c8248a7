// The touch journal and atomic files against crashes: exact round trips, a torn tail dropped and
// cut, a damaged middle named by line, and a process killed with SIGKILL mid-append losing nothing
// it had reported.
#include "daemon/touch_journal.hpp"

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

JournalEntry entry(int id) {
  JournalEntry e;
  e.touch_id = id;
  e.result.contact = id % 7 != 3;
  e.result.centre = hal::Vec3(278.000123456789 + id * 0.1, 353.1 / 3, 42.000000912345 - id * 1e-7);
  e.result.travel_mm = 4.000731 + id;
  e.result.t_s = 12.345678901234 * id;
  e.result.tip_id = "T1";
  return e;
}

std::size_t lines_in(const fs::path& file) {
  std::ifstream in(file);
  return static_cast<std::size_t>(std::count(std::istreambuf_iterator<char>(in), {}, '\n'));
}

TEST(TouchJournal, ReadsBackExactlyWhatWasAppended) {
  const fs::path file = fresh_folder("journal") / "touches.jsonl";
  {
    TouchJournal journal(file);
    for (int i = 0; i < 5; ++i) journal.append(entry(i));
  }
  const Recovery r = recover_journal(file);
  EXPECT_FALSE(r.torn_tail);
  ASSERT_EQ(r.entries.size(), 5u);
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(r.entries[static_cast<std::size_t>(i)].touch_id, i);
    EXPECT_EQ(r.entries[static_cast<std::size_t>(i)].result.centre, entry(i).result.centre);  // bit for bit
    EXPECT_EQ(r.entries[static_cast<std::size_t>(i)].result.t_s, entry(i).result.t_s);
    EXPECT_EQ(r.entries[static_cast<std::size_t>(i)].result.contact, entry(i).result.contact);
  }
  EXPECT_TRUE(recover_journal(file.parent_path() / "none.jsonl").entries.empty());
}

TEST(TouchJournal, ATornTailIsDroppedAndCutBeforeTheNextAppend) {
  const fs::path file = fresh_folder("torn") / "touches.jsonl";
  {
    std::ofstream out(file, std::ios::binary);
    out << to_json_line(entry(0)) << "\n" << to_json_line(entry(1)) << "\n" << to_json_line(entry(2)).substr(0, 25);
  }
  Recovery r = recover_journal(file);
  EXPECT_TRUE(r.torn_tail);
  EXPECT_EQ(r.entries.size(), 2u);
  {
    TouchJournal journal(file);
    journal.append(entry(2));
  }
  r = recover_journal(file);
  EXPECT_FALSE(r.torn_tail);
  ASSERT_EQ(r.entries.size(), 3u);
  EXPECT_EQ(r.entries[2].touch_id, 2);
}

TEST(TouchJournal, ADamagedLineBeforeTheLastIsAnErrorNamingIt) {
  const fs::path file = fresh_folder("damaged") / "touches.jsonl";
  {
    std::ofstream out(file, std::ios::binary);
    out << to_json_line(entry(0)) << "\n{\"touch\": oops}\n" << to_json_line(entry(2)) << "\n";
  }
  try {
    recover_journal(file);
    FAIL() << "a damaged middle line was accepted";
  } catch (const geometry::FileError& e) {
    EXPECT_THAT(e.what(), HasSubstr("touches.jsonl"));
    EXPECT_THAT(e.what(), HasSubstr("line 2"));
  }
}

TEST(TouchJournal, AProcessKilledMidAppendLosesNoReportedTouch) {
  const fs::path dir = fresh_folder("killed");
  const fs::path file = dir / "touches.jsonl", reported = dir / "reported";
  ASSERT_TRUE(kill_writer_when(
      [&] {
        // Appends for ever; after each append returns, the touch counts as reported.
        TouchJournal journal(file);
        for (int i = 0;; ++i) {
          journal.append(entry(i));
          std::ofstream(reported, std::ios::trunc) << i;
        }
      },
      [&] { return lines_in(file) >= 200; }));

  int last_reported = -1;
  std::ifstream(reported) >> last_reported;
  const Recovery r = recover_journal(file);
  ASSERT_GE(r.entries.size(), 200u);
  EXPECT_GE(static_cast<int>(r.entries.size()) - 1, last_reported);  // every reported touch is there
  for (std::size_t i = 0; i < r.entries.size(); ++i) {
    ASSERT_EQ(r.entries[i].touch_id, static_cast<int>(i)) << "a gap or a repeat";
    EXPECT_EQ(r.entries[i].result.centre, entry(static_cast<int>(i)).result.centre);
  }
}

}  // namespace
}  // namespace cmm::daemon
