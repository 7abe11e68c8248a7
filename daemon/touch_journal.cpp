// touches.jsonl: JSON lines, fsync per append, a torn tail dropped on recovery and cut before appending.
#include "daemon/touch_journal.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "hal/description/eigen_json.hpp"
#include "geometry/atomic_file.hpp"
#include "geometry/file_error.hpp"

namespace cmm::daemon {

namespace {
JournalEntry from_json(const nlohmann::json& j) {
  JournalEntry e;
  e.touch_id = j.at("touch").get<int>();
  e.result.contact = j.at("contact").get<bool>();
  e.result.centre = description::vec3_from_json(j.at("centre"));
  e.result.travel_mm = j.at("travel_mm").get<double>();
  e.result.t_s = j.at("t_s").get<double>();
  e.result.tip_id = j.at("tip").get<std::string>();
  e.qualification = j.value("q", 0);
  return e;
}

[[noreturn]] void fail(const std::filesystem::path& file, const std::string& step, int error = errno) {
  throw geometry::FileError::system(file, step, error);
}
}  // namespace

std::string to_json_line(const JournalEntry& e) {
  // nlohmann prints the shortest text that reads back as the same double: a touch read back is the
  // very number that was measured.
  nlohmann::json j = {{"touch", e.touch_id},        {"contact", e.result.contact}, {"centre", description::vec3_json(e.result.centre)},
                      {"travel_mm", e.result.travel_mm}, {"t_s", e.result.t_s},     {"tip", e.result.tip_id},
                      {"q", e.qualification}};
  return j.dump();
}

std::string to_json_line(const TipChangeEntry& c) { return nlohmann::json{{"change_tip", c.tip}, {"utc", c.utc}}.dump(); }

Recovery recover_journal(const std::filesystem::path& file) {
  Recovery out;
  std::ifstream in(file, std::ios::binary);
  if (!in) return out;
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string text = buffer.str();
  std::size_t line_start = 0, line_number = 0;
  while (line_start < text.size()) {
    ++line_number;
    const std::size_t end = text.find('\n', line_start);
    const bool complete = end != std::string::npos;
    const std::string line = text.substr(line_start, (complete ? end : text.size()) - line_start);
    const bool last = !complete || end + 1 >= text.size();
    try {
      if (!complete) throw std::runtime_error("no newline");
      const nlohmann::json j = nlohmann::json::parse(line);
      if (j.contains("change_tip"))
        out.tip_changes.push_back({j.at("change_tip").get<std::string>(), j.value("utc", "")});
      else
        out.entries.push_back(from_json(j));
      out.kept_bytes = end + 1;
    } catch (const std::exception& e) {
      if (!last) throw geometry::FileError::at_line(file, line_number, std::string("not a journal line: ") + e.what());
      out.torn_tail = true;  // a crash mid-append: the touch it held was never reported as made
    }
    if (!complete) break;
    line_start = end + 1;
  }
  return out;
}

TouchJournal::TouchJournal(const std::filesystem::path& file) : file_(file) {
  const Recovery recovered = recover_journal(file);
  fd_ = ::open(file.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (fd_ < 0) fail(file, "cannot open the touch journal");
  // Cut a torn tail so the next line starts on a line of its own. Only the tail may be torn (a bad
  // line before it is an error above), so the complete lines end where the tail begins.
  if (recovered.torn_tail && (::ftruncate(fd_, static_cast<off_t>(recovered.kept_bytes)) != 0 || ::fdatasync(fd_) != 0)) {
    const int error = errno;
    ::close(fd_);
    fd_ = -1;
    fail(file, "cutting the torn last line", error);
  }
  geometry::sync_folder(file.has_parent_path() ? file.parent_path() : ".");
}

TouchJournal::~TouchJournal() {
  if (fd_ >= 0) ::close(fd_);
}

void TouchJournal::append(const JournalEntry& entry) { append_line(to_json_line(entry) + "\n"); }

void TouchJournal::append(const TipChangeEntry& change) { append_line(to_json_line(change) + "\n"); }

void TouchJournal::append_line(const std::string& line) {
  const off_t end = ::lseek(fd_, 0, SEEK_END);
  if (end < 0) fail(file_, "append");
  // A line half written (the disk filled up under it) or not known to be on disk is taken back.
  const auto take_back = [&](const std::string& step, int error) {
    if (::ftruncate(fd_, end) == 0) (void)::fdatasync(fd_);
    fail(file_, step, error);
  };
  for (std::size_t done = 0; done < line.size();) {
    const ssize_t n = ::write(fd_, line.data() + done, line.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) take_back("append", n < 0 ? errno : EIO);
    done += static_cast<std::size_t>(n);
  }
  if (::fdatasync(fd_) != 0) take_back("fdatasync", errno);
}

}  // namespace cmm::daemon
