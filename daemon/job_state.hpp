// A job's life (docs/api.md): queued → planning → registering → probing → done | failed |
// cancelled, with paused and interrupted as the two resumable holds; and the wire names.
#pragma once

#include <string>

namespace cmm::daemon {

enum class JobState { queued, planning, registering, probing, paused, interrupted, done, failed, cancelled };

const char* to_string(JobState state);  // "queued", "planning", … as docs/api.md spells them
// The state named by to_string; throws std::invalid_argument naming the text otherwise.
JobState job_state_from_string(const std::string& text);

bool is_running(JobState state);    // planning, registering, probing: the job owns the machine or the planner
bool is_resumable(JobState state);  // paused, interrupted: job.resume continues it
bool is_final(JobState state);      // done, failed, cancelled: nothing changes it any more

}  // namespace cmm::daemon
