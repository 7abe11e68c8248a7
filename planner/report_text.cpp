// Numbers and verdict labels of the report; see report_text.hpp.
#include "planner/report_text.hpp"

#include "planner/html_text.hpp"
#include "planner/number_text.hpp"

namespace cmm::planner {

namespace {
constexpr int kDecimals = 4;  // 0.1 µm would be noise; 1 µm must show
}

std::string report_mm(double mm) {
  std::string text = fixed(mm, kDecimals);
  if (text.find_first_not_of("-0.") == std::string::npos && text.front() == '-') text.erase(0, 1);  // no "-0.0000"
  return text;
}

std::string report_signed_mm(double mm) {
  std::string text = report_mm(mm);
  if (text.front() != '-') text.insert(0, 1, '+');
  return text;
}

std::string report_point(const geometry::Vec3& p) {
  return concat(report_mm(p.x()), ", ", report_mm(p.y()), ", ", report_mm(p.z()));
}

std::string report_zone(const ToleranceZone& zone) {
  if (zone.lower_mm == -zone.upper_mm) return concat("±", report_mm(zone.upper_mm));
  return concat(report_signed_mm(zone.lower_mm), " / ", report_signed_mm(zone.upper_mm));
}

const char* verdict_label(Verdict verdict) {
  switch (verdict) {
    case Verdict::pass: return "pass";
    case Verdict::fail: return "fail";
    case Verdict::undecided: return "undecided";
    case Verdict::incomplete: return "incomplete";
    case Verdict::not_measured: return "not measured";
    case Verdict::excluded: return "excluded";
  }
  return "?";
}

const char* verdict_class(Verdict verdict) {
  switch (verdict) {
    case Verdict::pass: return "v-pass";
    case Verdict::fail: return "v-fail";
    case Verdict::undecided: return "v-undecided";
    case Verdict::incomplete: return "v-incomplete";
    case Verdict::not_measured: return "v-not-measured";
    case Verdict::excluded: return "v-excluded";
  }
  return "v-none";
}

}  // namespace cmm::planner
