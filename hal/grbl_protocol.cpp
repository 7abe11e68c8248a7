// Parsing and printing the lines of the Grbl 1.1 dialect, and the error/alarm → fault table.
#include "hal/grbl_protocol.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <vector>

namespace cmm::hal::grbl {

namespace {
std::vector<std::string> split(const std::string& s, char by) {
  std::vector<std::string> out(1);
  for (char c : s) {
    if (c == by) out.emplace_back();
    else out.back().push_back(c);
  }
  return out;
}

std::optional<double> number(const std::string& s) {
  double v = 0;
  const char* end = s.data() + s.size();
  auto [ptr, ec] = std::from_chars(s.data(), end, v);
  // Grbl prints no nan or inf; a driver that took one would compute with it.
  if (ec != std::errc() || ptr != end || s.empty() || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::optional<Vec3> coords(const std::string& s) {
  auto parts = split(s, ',');
  if (parts.size() != 3) return std::nullopt;
  Vec3 v;
  for (int i = 0; i < 3; ++i) {
    auto x = number(parts[static_cast<std::size_t>(i)]);
    if (!x) return std::nullopt;
    v[i] = *x;
  }
  return v;
}

std::optional<int> code_after(const std::string& line, const std::string& prefix) {
  if (line.rfind(prefix, 0) != 0) return std::nullopt;
  int code = 0;
  const char* begin = line.data() + prefix.size();
  const char* end = line.data() + line.size();
  auto [ptr, ec] = std::from_chars(begin, end, code);
  if (ec != std::errc() || ptr != end || begin == end) return std::nullopt;
  return code;
}
}  // namespace

std::string format_number(double value) {
  char text[48];
  const double nm = std::round(value * 1e6);
  std::snprintf(text, sizeof text, "%.6f", nm == 0 ? 0.0 : value);  // never "-0.000000"
  return text;
}

std::string format_coords(const Vec3& v) {
  return format_number(v.x()) + "," + format_number(v.y()) + "," + format_number(v.z());
}

std::optional<StatusReport> parse_status(const std::string& line) {
  if (line.size() < 3 || line.front() != '<' || line.back() != '>') return std::nullopt;
  auto fields = split(line.substr(1, line.size() - 2), '|');
  StatusReport r;
  auto state = split(fields[0], ':');
  r.state = state[0];
  if (r.state.empty() || state.size() > 2) return std::nullopt;
  if (state.size() == 2) {  // Hold:0, Door:1: a small code, never a double cast to int (1e307 is UB)
    const char* end = state[1].data() + state[1].size();
    auto [ptr, ec] = std::from_chars(state[1].data(), end, r.substate);
    if (ec != std::errc() || ptr != end || state[1].empty() || r.substate < 0) return std::nullopt;
  }
  bool have_position = false;
  for (std::size_t i = 1; i < fields.size(); ++i) {
    const auto colon = fields[i].find(':');
    if (colon == std::string::npos) return std::nullopt;
    const std::string key = fields[i].substr(0, colon), value = fields[i].substr(colon + 1);
    if (key == "MPos") {
      auto v = coords(value);
      if (!v) return std::nullopt;
      r.mpos = *v, have_position = true;
    } else if (key == "FS" || key == "F") {
      auto f = number(split(value, ',')[0]);
      if (!f) return std::nullopt;
      r.feed_mm_min = *f;
    } else if (key == "Pn") {
      r.pins = value;
    } else if (key == "T") {
      r.clock_s = number(value);
      if (!r.clock_s) return std::nullopt;
    }  // Bf, Ln, WCO, Ov, A and anything newer: not ours to judge
  }
  if (!have_position) return std::nullopt;  // our driver needs MPos ($10 must report it)
  return r;
}

std::string format_status(const StatusReport& r) {
  // Appended piece by piece: GCC 12 at -O3 reports a false -Wrestrict for "literal" + a temporary
  // std::string (GCC bug 105329).
  std::string out = "<";
  out += r.state;
  if (r.substate >= 0) {
    out += ':';
    out += std::to_string(r.substate);
  }
  out += "|MPos:";
  out += format_coords(r.mpos);
  out += "|FS:";
  out += format_number(r.feed_mm_min);
  out += ",0";
  if (!r.pins.empty()) out += "|Pn:" + r.pins;
  if (r.clock_s) out += "|T:" + format_number(*r.clock_s);
  out += '>';
  return out;
}

std::optional<ProbeReport> parse_probe(const std::string& line) {
  if (line.rfind("[PRB:", 0) != 0 || line.back() != ']') return std::nullopt;
  auto parts = split(line.substr(5, line.size() - 6), ':');
  if (parts.size() != 2 || (parts[1] != "0" && parts[1] != "1")) return std::nullopt;
  auto v = coords(parts[0]);
  if (!v) return std::nullopt;
  return ProbeReport{*v, parts[1] == "1"};
}

std::string format_probe(const ProbeReport& r) {
  return "[PRB:" + format_coords(r.position) + ":" + (r.success ? "1" : "0") + "]";
}

std::optional<int> parse_error(const std::string& line) { return code_after(line, "error:"); }
std::optional<int> parse_alarm(const std::string& line) { return code_after(line, "ALARM:"); }

FaultKind fault_from_error(int code) {
  switch (code) {
    case kErrorLocked: return FaultKind::not_homed;
    case kErrorTravelExceeded: return FaultKind::soft_limit;
    default: return FaultKind::protocol;  // the driver sent something the machine refused
  }
}

FaultKind fault_from_alarm(int code) {
  switch (code) {
    case kAlarmHardLimit: return FaultKind::hard_limit;
    case kAlarmSoftLimit: return FaultKind::soft_limit;
    case kAlarmAbortCycle: return FaultKind::aborted;  // EStop when the status shows Pn:R
    case kAlarmProbeInitial: return FaultKind::early_trigger;
    case kAlarmProbeContact: return FaultKind::no_contact;
    case 6: case 7: case 8: case 9: return FaultKind::hard_limit;  // homing failed at a switch
    default: return FaultKind::protocol;
  }
}

std::string error_text(int code) {
  switch (code) {
    case kErrorExpectedLetter: return "expected command letter";
    case kErrorBadNumber: return "bad number format";
    case kErrorInvalidStatement: return "invalid $ statement";
    case kErrorLocked: return "G-code locked out during alarm or jog state";
    case kErrorLineTooLong: return "max characters per line exceeded";
    case kErrorTravelExceeded: return "travel exceeded";
    case kErrorUnsupported: return "unsupported command";
    case kErrorNoFeed: return "undefined feed rate";
    case kErrorNoAxisWords: return "no axis words";
    case kErrorG53: return "G53 only with G0 and G1";
    case kErrorInvalidTarget: return "motion command target is invalid";
    default: return "error " + std::to_string(code);
  }
}

std::string alarm_text(int code) {
  switch (code) {
    case kAlarmHardLimit: return "hard limit triggered";
    case kAlarmSoftLimit: return "soft limit: target exceeds machine travel";
    case kAlarmAbortCycle: return "reset while in motion: position lost";
    case kAlarmProbeInitial: return "probe not in the expected initial state";
    case kAlarmProbeContact: return "probe did not contact within the search distance";
    default: return "alarm " + std::to_string(code);
  }
}

}  // namespace cmm::hal::grbl
