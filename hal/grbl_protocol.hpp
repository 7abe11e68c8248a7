// The Grbl 1.1 wire dialect shared by the serial driver (hal/grbl_cmm.hpp) and cmm-sim's Grbl side
// (sim/grbl_server.hpp): status reports, probe reports, error:N / ALARM:N and their typed faults.
#pragma once

#include <cstddef>
#include <optional>
#include <string>

#include "hal/fault.hpp"
#include "hal/motion.hpp"

namespace cmm::hal::grbl {

inline constexpr const char* kBanner = "Grbl 1.1h ['$' for help]";
inline constexpr std::size_t kRxBufferBytes = 128;  // Grbl's serial RX buffer: the driver counts into it
inline constexpr char kStatusQuery = '?', kFeedHold = '!', kCycleStart = '~', kSoftReset = 0x18;

// Grbl 1.1's alarm codes that our dialect raises.
inline constexpr int kAlarmHardLimit = 1, kAlarmSoftLimit = 2, kAlarmAbortCycle = 3, kAlarmProbeInitial = 4,
                     kAlarmProbeContact = 5;
// Grbl 1.1's error codes that our dialect answers with.
inline constexpr int kErrorUnsupported = 20, kErrorLocked = 9, kErrorTravelExceeded = 15, kErrorNoFeed = 22,
                     kErrorNoAxisWords = 26, kErrorInvalidTarget = 33, kErrorBadNumber = 2, kErrorExpectedLetter = 1,
                     kErrorInvalidStatement = 3, kErrorG53 = 30, kErrorLineTooLong = 11;

// `<Idle|MPos:x,y,z|FS:f,s|Pn:R|T:t>`; T (the machine clock, s) is our dialect's extension.
struct StatusReport {
  std::string state;  // Idle, Run, Hold, Jog, Alarm, Door, Check, Home, Sleep
  int substate = -1;  // Hold:0 / Hold:1
  Vec3 mpos = Vec3::Zero();
  double feed_mm_min = 0;
  std::string pins;  // Pn: letters (P probe, R reset/e-stop, X Y Z limits…)
  std::optional<double> clock_s;
};
std::optional<StatusReport> parse_status(const std::string& line);
std::string format_status(const StatusReport& report);

// `[PRB:x,y,z:1]`: the last probe's trigger position in machine coordinates, and whether it triggered.
struct ProbeReport {
  Vec3 position = Vec3::Zero();
  bool success = false;
};
std::optional<ProbeReport> parse_probe(const std::string& line);
std::string format_probe(const ProbeReport& report);

std::optional<int> parse_error(const std::string& line);  // error:N
std::optional<int> parse_alarm(const std::string& line);  // ALARM:N

// x,y,z with 6 decimals (1 nm; real Grbl prints 3): the conformance suite compares paths to 1e-6 mm.
std::string format_coords(const Vec3& v);
std::string format_number(double value);  // 6 decimals, no trailing noise

// The typed fault for a code, as docs/hal.md's table gives it, and Grbl's own short text.
FaultKind fault_from_error(int code);
FaultKind fault_from_alarm(int code);
std::string error_text(int code);
std::string alarm_text(int code);

}  // namespace cmm::hal::grbl
