// The one-line progress bar cmmctl draws while it watches a job.
#include "daemon/client/progress_bar.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace cmm::daemon {

std::string duration_text(double seconds) {
  const long s = std::lround(std::max(0.0, seconds));
  char text[48];
  if (s >= 3600) std::snprintf(text, sizeof text, "%ld h %02ld min", s / 3600, (s % 3600) / 60);
  else if (s >= 60) std::snprintf(text, sizeof text, "%ld min %ld s", s / 60, s % 60);
  else std::snprintf(text, sizeof text, "%ld s", s);
  return text;
}

std::string progress_line(const std::string& phase, int done, int total, double eta_s, int bar_width) {
  const double fraction = total > 0 ? std::clamp(static_cast<double>(done) / total, 0.0, 1.0) : 0.0;
  const int filled = static_cast<int>(std::floor(fraction * bar_width + 1e-9));
  std::string bar(static_cast<std::size_t>(filled), '#');
  bar.append(static_cast<std::size_t>(bar_width - filled), '.');
  char text[256];
  std::snprintf(text, sizeof text, "%-11s [%s] %4d/%-4d touches  ETA %s", phase.c_str(), bar.c_str(), done, total,
                duration_text(eta_s).c_str());
  return text;
}

}  // namespace cmm::daemon
