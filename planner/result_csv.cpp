// Writes the two CSV tables; see result_csv.hpp.
#include "planner/result_csv.hpp"

#include <initializer_list>

#include "planner/number_text.hpp"

namespace cmm::planner {

namespace {

constexpr int kDecimals = 6;  // 1 nm in mm: µm survive with room to spare

// RFC 4180: a field with a comma, a quote or a line break is quoted, its quotes doubled.
std::string quoted(const std::string& text) {
  if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
  std::string out = "\"";
  for (char c : text) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + '"';
}

// Cells of a feature that has no value stay empty: `measured` false blanks them all.
class Row {
 public:
  explicit Row(bool measured) : measured_(measured) {}
  Row& text(const std::string& cell) { return add(cell); }
  Row& value(double v) { return add(measured_ ? fixed(v, kDecimals) : std::string()); }
  Row& vector(const Vec3* v) {
    for (int k = 0; k < 3; ++k) add(v ? fixed((*v)(k), kDecimals) : std::string());
    return *this;
  }
  std::string line() const { return cells_ + '\n'; }

 private:
  Row& add(const std::string& cell) {
    cells_ += (first_ ? "" : ",") + cell;
    first_ = false;
    return *this;
  }
  bool measured_;
  bool first_ = true;
  std::string cells_;
};

// The inspection's cells of one characteristic: deviation, U, limits, verdict (all empty without a nominal).
void characteristic(Row& row, const Characteristic* c) {
  const bool measured = c && judged(c->verdict);
  row.text(measured ? fixed(c->deviation_mm, kDecimals) : "").text(measured ? fixed(c->uncertainty_mm, kDecimals) : "");
  row.text(c ? fixed(c->zone.lower_mm, kDecimals) : "").text(c ? fixed(c->zone.upper_mm, kDecimals) : "");
  row.text(c ? to_string(c->verdict) : "");
}

// The row's reason: why the request left the feature out when it did (that says more than the
// plan's reason, which it quotes), else the feature's own.
const std::string& reason_of(const std::string& feature_reason, Verdict verdict, const std::string& inspection_reason) {
  return verdict == Verdict::excluded ? inspection_reason : feature_reason;
}

std::string header(std::initializer_list<const char*> names) {
  Row row(false);
  for (const char* name : names) row.text(name);
  return row.line();
}

}  // namespace

std::string to_csv(const MeasurementResult& result) {
  std::string out = header({"id", "kind", "method", "status", "x_S", "y_S", "z_S", "x_M", "y_M", "z_M", "deviation_mm",
                            "sigma_mm", "nominal_deviation_mm", "uncertainty_mm", "tolerance_lower_mm",
                            "tolerance_upper_mm", "verdict", "reason"});
  const InspectionResult* inspection = result.inspection ? &*result.inspection : nullptr;
  for (std::size_t i = 0; i < result.edges.size(); ++i) {
    const EdgeResult& e = result.edges[i];
    const bool measured = e.status == FeatureStatus::measured;
    Row row(measured);
    row.text(std::to_string(e.id)).text(geometry::to_string(e.kind)).text(to_string(e.method)).text(to_string(e.status));
    row.vector(measured ? &e.scan->position : nullptr).vector(measured ? &e.machine->position : nullptr);
    row.value(e.deviation.signed_mm).value(measured ? e.scan->sigma_mm : 0);
    const EdgeInspection* nominal = inspection && i < inspection->edges.size() ? &inspection->edges[i] : nullptr;
    characteristic(row, nominal ? &nominal->profile : nullptr);
    row.text(quoted(nominal ? reason_of(e.reason, nominal->profile.verdict, nominal->reason) : e.reason));
    out += row.line();
  }
  return out;
}

std::string holes_to_csv(const MeasurementResult& result) {
  std::string out = header({"id", "status", "x_S", "y_S", "z_S", "x_M", "y_M", "z_M", "diameter_mm", "nominal_diameter_mm",
                            "diameter_deviation_mm", "centre_deviation_mm", "roundness_mm", "centre_sigma_mm",
                            "diameter_sigma_mm", "diameter_nominal_deviation_mm", "diameter_uncertainty_mm",
                            "diameter_lower_mm", "diameter_upper_mm", "diameter_verdict", "position_mm",
                            "position_uncertainty_mm", "position_lower_mm", "position_upper_mm", "position_verdict",
                            "verdict", "reason"});
  const InspectionResult* inspection = result.inspection ? &*result.inspection : nullptr;
  for (std::size_t i = 0; i < result.holes.size(); ++i) {
    const HoleResult& h = result.holes[i];
    const bool measured = h.status == FeatureStatus::measured;
    const BoreMeasurement none;
    const BoreMeasurement& bore = measured ? *h.scan : none;
    Row row(measured);
    row.text(std::to_string(h.id)).text(to_string(h.status));
    row.vector(measured ? &h.scan->centre : nullptr).vector(measured ? &h.machine->centre : nullptr);
    row.value(bore.diameter_mm).text(fixed(h.nominal_diameter_mm, kDecimals)).value(h.diameter_deviation_mm);
    row.value(h.centre_deviation_mm).value(bore.roundness_mm).value(bore.centre_sigma_mm).value(bore.diameter_sigma_mm);
    const HoleInspection* hole = inspection && i < inspection->holes.size() ? &inspection->holes[i] : nullptr;
    characteristic(row, hole ? &hole->diameter : nullptr);
    characteristic(row, hole ? &hole->position : nullptr);
    const Verdict verdict = hole ? worse(hole->diameter.verdict, hole->position.verdict) : Verdict::not_measured;
    row.text(hole ? to_string(verdict) : "");
    row.text(quoted(hole ? reason_of(h.reason, verdict, hole->reason) : h.reason));
    out += row.line();
  }
  return out;
}

}  // namespace cmm::planner
