// A job's append-only touches.jsonl: one JSON line per touch the machine made, fsynced before the
// job goes on, so a daemon killed at any moment keeps every touch it reported (DESIGN.md, Files).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "hal/motion.hpp"

namespace cmm::daemon {

// One journal line: which planned touch it was, what the machine reported, and under which of the
// job's tip qualifications it was made (an index into qualifications.json; lines written before
// there was one read as 0).
struct JournalEntry {
  int touch_id = -1;       // the plan's touch id
  hal::TouchResult result;
  int qualification = 0;
};

std::string to_json_line(const JournalEntry& entry);  // one line, no newline

// A tip change the job made (a line of its own between the touches): which tip, and when.
struct TipChangeEntry {
  std::string tip;
  std::string utc;
};
std::string to_json_line(const TipChangeEntry& change);

struct Recovery {
  std::vector<JournalEntry> entries;  // every complete touch line, in order
  std::vector<TipChangeEntry> tip_changes;
  bool torn_tail = false;             // the last line was cut short by a crash, and was dropped
  std::uintmax_t kept_bytes = 0;      // the length of the complete lines: where a torn tail begins
};

// Reads a journal back. A missing file is an empty journal. A torn last line (no newline, or not
// JSON) is what a crash mid-append leaves: it is dropped and reported. A bad line before the last
// is not a crash's doing: geometry::FileError naming the file and the line.
Recovery recover_journal(const std::filesystem::path& file);

class TouchJournal {
 public:
  // Opens `file` for appending (creating it and syncing its folder). A torn tail left by a crash is
  // cut off first (truncated, which needs no free space), so new lines never follow half a line.
  explicit TouchJournal(const std::filesystem::path& file);
  ~TouchJournal();
  TouchJournal(const TouchJournal&) = delete;
  TouchJournal& operator=(const TouchJournal&) = delete;

  // Appends one line and fsyncs it; when this returns, the touch survives a crash. When the write
  // or the sync fails (a full disk: geometry::FileError with its errno) the file is cut back to
  // where it ended before, so it holds no half line and the touch is not in it.
  void append(const JournalEntry& entry);
  void append(const TipChangeEntry& change);  // the same way
  const std::filesystem::path& file() const { return file_; }

 private:
  void append_line(const std::string& line);

  std::filesystem::path file_;
  int fd_ = -1;
};

}  // namespace cmm::daemon
