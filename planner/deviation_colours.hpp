// The colours of deviations in the report's map, histogram and legend: against a nominal, relative
// to each point's tolerance (green inside, yellow and orange toward the upper limit, cyan and blue
// toward the lower, red outside); against the scan, on a fixed symmetric scale with no red, since
// nothing fails against the scan. Grey: not measured.
#pragma once

#include <string>
#include <vector>

#include "planner/deviation_map.hpp"
#include "planner/inspection.hpp"
#include "planner/measurement_result.hpp"
#include "planner/png_image.hpp"

namespace cmm::planner {

// The half-range of the scale against the scan, mm: the scan's own error at edges is of this order.
inline constexpr double kScanColourScaleMm = 0.1;

// Deviation over the limit on its side (upper for ≥ 0, lower for < 0): 0 on the nominal, ±1 at a
// limit, beyond ±1 outside. A deviation on the side of a limit of zero (a one-sided zone) is ±∞.
double relative_deviation(double deviation_mm, const ToleranceZone& zone);

Rgb relative_colour(double relative);  // −1 … +1 (clamped): blue, cyan, green, yellow, orange; NaN grey
Rgb outside_colour();                  // red
Rgb not_measured_colour();             // grey

Rgb tolerance_colour(double deviation_mm, const ToleranceZone& zone);  // red outside the zone
Rgb scan_colour(double deviation_mm, double scale_mm = kScanColourScaleMm);

std::string css_colour(Rgb colour);  // "#rrggbb"

// The map's points for a result: with an inspection, each measured edge point at its measured
// position (S) coloured by its deviation from the nominal against its own tolerance; without, by
// its deviation against the scan. Points not measured are small grey discs at the reference point.
// Ordered for drawing: grey first, then by growing relative deviation, so failures are on top.
std::vector<MapPoint> deviation_map_points(const MeasurementResult& result);

}  // namespace cmm::planner
