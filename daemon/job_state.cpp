// Job state names and classes.
#include "daemon/job_state.hpp"

#include <array>
#include <stdexcept>
#include <utility>

namespace cmm::daemon {

namespace {
constexpr std::array<std::pair<JobState, const char*>, 9> names = {{
    {JobState::queued, "queued"},
    {JobState::planning, "planning"},
    {JobState::registering, "registering"},
    {JobState::probing, "probing"},
    {JobState::paused, "paused"},
    {JobState::interrupted, "interrupted"},
    {JobState::done, "done"},
    {JobState::failed, "failed"},
    {JobState::cancelled, "cancelled"},
}};
}  // namespace

const char* to_string(JobState state) {
  for (const auto& [s, name] : names)
    if (s == state) return name;
  return "?";
}

JobState job_state_from_string(const std::string& text) {
  for (const auto& [s, name] : names)
    if (text == name) return s;
  throw std::invalid_argument("unknown job state \"" + text +
                              "\" (expected queued, planning, registering, probing, paused, interrupted, done, failed "
                              "or cancelled)");
}

bool is_running(JobState state) {
  return state == JobState::planning || state == JobState::registering || state == JobState::probing;
}

bool is_resumable(JobState state) { return state == JobState::paused || state == JobState::interrupted; }

bool is_final(JobState state) { return state == JobState::done || state == JobState::failed || state == JobState::cancelled; }

}  // namespace cmm::daemon
