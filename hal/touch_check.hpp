// A touch the controller reports is held against the search that was commanded before anyone uses
// it (DESIGN: a driver never takes a controller's report on faith): a ball centre off the search
// line, or beyond either end of it, is a touch the machine cannot have made on that search.
#pragma once

#include <string>

#include "hal/motion.hpp"

namespace cmm::hal {

// How far a reported ball centre may lie from the commanded search, in mm: the trigger's own scatter
// (about 1 µm on a touch-trigger probe) lies along the line, so sideways only the controller's path
// error and its position resolution (nm on Modbus, µm on Grbl) remain; 10 µm holds both with a wide
// margin and still refuses a report a few hundredths of a millimetre off.
inline constexpr double kTouchLateralToleranceMm = 0.010;
// Along the line the trigger scatter and the controller's latency of a few µm count: before the start
// or past the search's end by more than this is refused.
inline constexpr double kTouchAlongToleranceMm = 0.010;

// Returns `touch` when it is a contact on the search of `move` (or a miss), and otherwise throws
// Protocol naming `machine`, the reported centre and how far off it lies.
TouchResult checked_touch(const ProbeMove& move, const TouchResult& touch, const std::string& machine);

}  // namespace cmm::hal
