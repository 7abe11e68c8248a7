// The line `cmmctl submit --watch` redraws while a job runs: phase, a bar of touches done, the
// count and the ETA, in a fixed width so a terminal line never wraps.
#pragma once

#include <string>

namespace cmm::daemon {

// "probing     [##########··········]  12/40 touches  ETA 1 min 20 s"
std::string progress_line(const std::string& phase, int done, int total, double eta_s, int bar_width = 30);

// "1 h 02 min", "1 min 20 s", "7 s": how long, for a person.
std::string duration_text(double seconds);

}  // namespace cmm::daemon
