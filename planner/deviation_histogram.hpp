// The histogram of edge-point deviations as inline SVG for the job report: bars coloured as the
// map colours their deviation, the tolerance limits drawn as lines.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "planner/inspection.hpp"

namespace cmm::planner {

// `limits`: the tolerance zone the deviations are held against (against a nominal), drawn and used
// for the bar colours; none: deviations against the scan, coloured on the fixed scan scale. The
// axis is symmetric about 0 and reaches past the largest deviation and the limits. An empty list
// gives a frame with "no measured deviations".
std::string deviation_histogram_svg(const std::vector<double>& deviations_mm,
                                    const std::optional<ToleranceZone>& limits, int bins = 41);

}  // namespace cmm::planner
