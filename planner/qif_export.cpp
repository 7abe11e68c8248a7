// Writes the QIF 3.0 results document by hand: it is write-only and its shape is fixed, so a small
// writer with one escaping function does what an XML library would. See docs/qif.md.
#include "planner/qif_export.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <optional>
#include <random>
#include <regex>
#include <stdexcept>
#include <string_view>
#include <utility>
#include <vector>

namespace cmm::planner {

namespace {

// mm to the picometre, trailing zeros dropped: µm keep six digits to spare and a rotation's columns
// stay unit vectors to 1e-9.
constexpr int kDecimals = 9;

// ---- Text -----------------------------------------------------------------------------------------

// XML 1.0 text and attribute values: the markup characters as entities, tab and line breaks as
// character references (an attribute value would turn them into spaces), and every byte that is not
// UTF-8 or a character XML 1.0 forbids as U+FFFD, so any job name gives a well-formed document.
std::string xml_escaped(std::string_view text) {
  static constexpr const char* replacement = "\xEF\xBF\xBD";
  std::string out;
  out.reserve(text.size());
  std::size_t i = 0;
  while (i < text.size()) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c < 0x80) {
      switch (c) {
        case '&': out += "&amp;"; break;
        case '<': out += "&lt;"; break;
        case '>': out += "&gt;"; break;
        case '"': out += "&quot;"; break;
        case '\'': out += "&apos;"; break;
        case '\t': out += "&#9;"; break;
        case '\n': out += "&#10;"; break;
        case '\r': out += "&#13;"; break;
        default:
          if (c < 0x20)
            out += replacement;
          else
            out += static_cast<char>(c);
      }
      ++i;
      continue;
    }
    const std::size_t length = c >= 0xF8 ? 0 : c >= 0xF0 ? 4 : c >= 0xE0 ? 3 : c >= 0xC0 ? 2 : 0;
    std::uint32_t code = length == 4 ? c & 0x07u : length == 3 ? c & 0x0Fu : c & 0x1Fu;
    bool valid = length != 0 && i + length <= text.size();
    for (std::size_t k = 1; valid && k < length; ++k) {
      const auto next = static_cast<unsigned char>(text[i + k]);
      valid = (next & 0xC0u) == 0x80u;
      code = (code << 6) | (next & 0x3Fu);
    }
    static constexpr std::uint32_t smallest[] = {0, 0, 0x80, 0x800, 0x10000};
    valid = valid && code >= smallest[length] && code <= 0x10FFFF && (code < 0xD800 || code > 0xDFFF) &&
            code != 0xFFFE && code != 0xFFFF;
    if (valid) {
      out.append(text.substr(i, length));
      i += length;
    } else {
      out += replacement;
      ++i;
    }
  }
  return out;
}

// Which value a number is, for the error when it is not finite: "edge point 12: measured position".
struct Field {
  const char* owner;  // "edge point", "hole", "transform"
  int id;             // < 0: no number
  const char* name;
};

[[noreturn]] void throw_not_finite(const Field& field) {
  std::string message = "QIF: ";
  message.append(field.owner);
  if (field.id >= 0) message.append(" ").append(std::to_string(field.id));
  message.append(": ").append(field.name).append(" is not a finite number");
  throw std::invalid_argument(message);
}

// Fixed-point (xs:decimal admits no exponent), trailing zeros dropped, never "-0".
std::string number(double value, const Field& field) {
  if (!std::isfinite(value)) throw_not_finite(field);
  char buffer[512];  // %.9f of the largest double is 319 characters
  std::snprintf(buffer, sizeof buffer, "%.*f", kDecimals, value);
  std::string text = buffer;
  const std::size_t last = text.find_last_not_of('0');
  text.erase(text[last] == '.' ? last : last + 1);
  if (text == "-0") text = "0";
  return text;
}

std::string vector3(const Vec3& v, const Field& field) {
  std::string text = number(v.x(), field);
  text.append(" ").append(number(v.y(), field)).append(" ").append(number(v.z(), field));
  return text;
}

// xs:dateTime's lexical form; a bad stamp would make the whole document invalid, so it is refused.
const std::string& checked_time(const std::string& stamp, const char* field) {
  static const std::regex date_time(R"(-?\d{4,}-\d{2}-\d{2}T\d{2}:\d{2}:\d{2}(\.\d+)?(Z|[+-]\d{2}:\d{2})?)");
  if (!stamp.empty() && !std::regex_match(stamp, date_time)) {
    std::string message = "QIF context: ";
    message.append(field).append(" \"").append(stamp).append(
        "\" is not an ISO 8601 date-time (YYYY-MM-DDThh:mm:ss[.s][Z|+hh:mm])");
    throw std::invalid_argument(message);
  }
  return stamp;
}

// The document's QPId: a random (version 4) UUID, one per document written.
std::string random_uuid() {
  std::random_device device;
  std::mt19937_64 engine((static_cast<std::uint64_t>(device()) << 32) ^ device());
  std::uint64_t high = engine(), low = engine();
  high = (high & ~0xF000ull) | 0x4000ull;                  // version 4
  low = (low & ~(0xC0ull << 56)) | (0x80ull << 56);         // RFC 4122 variant
  char text[37];
  std::snprintf(text, sizeof text, "%08x-%04x-%04x-%04x-%012llx", static_cast<unsigned>(high >> 32),
                static_cast<unsigned>((high >> 16) & 0xFFFF), static_cast<unsigned>(high & 0xFFFF),
                static_cast<unsigned>(low >> 48), static_cast<unsigned long long>(low & 0xFFFFFFFFFFFFull));
  return text;
}

// ---- The writer -----------------------------------------------------------------------------------

using XmlAttributes = std::vector<std::pair<const char*, std::string>>;

class XmlWriter {
 public:
  XmlWriter() : out_("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n") {}

  void open(const char* tag, const XmlAttributes& attributes = {}) {
    start(tag, attributes);
    out_ += ">\n";
    open_.push_back(tag);
  }
  void close() {
    const char* tag = open_.back();
    open_.pop_back();
    indent();
    out_.append("</").append(tag).append(">\n");
  }
  void leaf(const char* tag, std::string_view text, const XmlAttributes& attributes = {}) {
    start(tag, attributes);
    out_.append(">").append(xml_escaped(text)).append("</").append(tag).append(">\n");
  }
  void leaf(const char* tag, int id) { leaf(tag, std::to_string(id)); }
  void empty(const char* tag, const XmlAttributes& attributes = {}) {
    start(tag, attributes);
    out_ += "/>\n";
  }
  std::string take() { return std::move(out_); }

 private:
  void indent() { out_.append(2 * open_.size(), ' '); }
  void start(const char* tag, const XmlAttributes& attributes) {
    indent();
    out_.append("<").append(tag);
    for (const auto& [name, value] : attributes) out_.append(" ").append(name).append("=\"").append(xml_escaped(value)).append("\"");
  }

  std::string out_;
  std::vector<const char*> open_;
};

// QIF's user attributes (an Attributes element): AttributeStr, AttributeD1, AttributeD3, AttributeTime, …
struct QifAttribute {
  const char* type;
  const char* name;
  std::string value;
};

void write_attributes(XmlWriter& w, const std::vector<QifAttribute>& attributes) {
  if (attributes.empty()) return;
  w.open("Attributes", {{"n", std::to_string(attributes.size())}});
  for (const QifAttribute& a : attributes) w.empty(a.type, {{"name", a.name}, {"value", a.value}});
  w.close();
}

// A list of references: <Tag n="1"><Id>7</Id></Tag>.
void write_ids(XmlWriter& w, const char* tag, const std::vector<int>& ids) {
  w.open(tag, {{"n", std::to_string(ids.size())}});
  for (int id : ids) w.leaf("Id", id);
  w.close();
}

// ---- Verdicts -------------------------------------------------------------------------------------

// A status element's tag and text: the schema's enumeration where it has our word, else its
// free-text alternative (OtherCharacteristicStatus, OtherInspectionStatus), which QIF offers for that.
struct Status {
  const char* element;
  const char* value;
};

// A characteristic's Status. Our undecided (deviation ± U straddles a limit: ISO 14253-1 proves
// neither conformance nor non-conformance) is QIF's INDETERMINATE. CharacteristicStatusEnum has no
// word for a characteristic asked for and not measured (NOT_ANALYZED would say measured and not
// evaluated), nor for one left out on purpose: NOT_MEASURED and EXCLUDED go as free text.
Status characteristic_status(Verdict verdict) {
  switch (verdict) {
    case Verdict::pass: return {"CharacteristicStatusEnum", "PASS"};
    case Verdict::fail: return {"CharacteristicStatusEnum", "FAIL"};
    case Verdict::undecided: return {"CharacteristicStatusEnum", "INDETERMINATE"};
    case Verdict::excluded: return {"OtherCharacteristicStatus", "EXCLUDED"};
    case Verdict::incomplete:
    case Verdict::not_measured: break;
  }
  return {"OtherCharacteristicStatus", "NOT_MEASURED"};
}

// The part's InspectionStatus (InspectionStatusEnum, which has neither INDETERMINATE nor INCOMPLETE):
// undecided is UNKNOWN; incomplete (a characteristic asked for and not measured) is the free-text
// OtherInspectionStatus "INCOMPLETE", never a PASS and not the UNKNOWN an undecided part gets; a job
// without a nominal (no verdicts at all) NOT_CALCULATED.
Status inspection_status(const std::optional<InspectionResult>& inspection) {
  if (!inspection) return {"InspectionStatusEnum", "NOT_CALCULATED"};
  switch (inspection->verdict) {
    case Verdict::pass: return {"InspectionStatusEnum", "PASS"};
    case Verdict::fail: return {"InspectionStatusEnum", "FAIL"};
    case Verdict::undecided: return {"InspectionStatusEnum", "UNKNOWN"};
    case Verdict::incomplete:
    case Verdict::not_measured:
    case Verdict::excluded: break;
  }
  return {"OtherInspectionStatus", "INCOMPLETE"};
}

// ---- What is written, with its ids ------------------------------------------------------------------

// One characteristic: its definition (shared by every characteristic of the same kind and zone),
// nominal, item and measurement ids; definition 0 = the feature has none.
struct CharacteristicIds {
  int definition = 0, nominal = 0, item = 0, measurement = 0;
};

struct EdgeEntry {
  const EdgeResult* edge = nullptr;
  const EdgeInspection* inspection = nullptr;  // null: no characteristic
  bool measured = false;
  Vec3 nominal_S = Vec3::Zero();
  int feature_nominal = 0, feature_item = 0, feature_measurement = 0;  // measurement 0: not measured
  CharacteristicIds profile;
};

struct HoleEntry {
  const HoleResult* hole = nullptr;
  const HoleInspection* inspection = nullptr;
  bool measured = false;
  Vec3 centre_S = Vec3::Zero(), axis_S = Vec3::UnitZ();
  double diameter_mm = 0;
  int feature_definition = 0, feature_nominal = 0, feature_item = 0, feature_measurement = 0;
  CharacteristicIds diameter, position;
};

enum class CharacteristicKind { point_profile, diameter, position };

struct CharacteristicDefinition {
  CharacteristicKind kind;
  ToleranceZone zone;
  int id;
};

template <typename T>
const T* find_by_id(const std::vector<T>& list, std::size_t index, int id) {
  if (index < list.size() && list[index].id == id) return &list[index];
  for (const T& item : list)
    if (item.id == id) return &item;
  return nullptr;
}

class QifDocument {
 public:
  QifDocument(const MeasurementResult& result, const QifContext& context) : result_(result), context_(context) {
    checked_time(context.started_utc, "started_utc");
    checked_time(context.finished_utc, "finished_utc");
    checked_time(context.written_utc, "written_utc");
    checked_time(context.tip.qualified_utc, "tip.qualified_utc");
    plan();
  }

  std::string write() {
    w_.open("QIFDocument", {{"xmlns", "http://qifstandards.org/xsd/qif3"},
                            {"versionQIF", "3.0.0"},
                            {"idMax", std::to_string(next_id_ - 1)}});
    w_.leaf("QPId", random_uuid());
    if (!context_.written_utc.empty()) {
      w_.open("Version");
      w_.leaf("TimeCreated", context_.written_utc);
      w_.close();
    }
    write_header();
    write_standards_and_software();
    write_units();
    write_coordinate_systems();
    write_resources();
    write_product();
    write_features();
    write_characteristics();
    write_results();
    w_.close();
    return w_.take();
  }

 private:
  int take_id() { return next_id_++; }
  bool has_characteristics() const { return !definitions_.empty(); }

  // Every id, in document order, before anything is written: references point forward too (the CMM
  // names its probe, an item its nominal).
  void plan() {
    const std::optional<InspectionResult>& inspection = result_.inspection;
    for (std::size_t i = 0; i < result_.edges.size(); ++i) {
      const EdgeResult& e = result_.edges[i];
      EdgeEntry entry;
      entry.edge = &e;
      entry.measured = e.status == FeatureStatus::measured && e.scan.has_value();
      if (inspection) entry.inspection = find_by_id(inspection->edges, i, e.id);
      // Without a nominal there is nothing to hold an unmeasured point against: it is left out.
      if (!inspection && !entry.measured) continue;
      entry.nominal_S = entry.inspection && entry.inspection->nominal_S ? *entry.inspection->nominal_S : e.reference;
      edges_.push_back(entry);
    }
    for (std::size_t i = 0; i < result_.holes.size(); ++i) {
      const HoleResult& h = result_.holes[i];
      HoleEntry entry;
      entry.hole = &h;
      entry.measured = h.status == FeatureStatus::measured && h.scan.has_value();
      if (inspection) entry.inspection = find_by_id(inspection->holes, i, h.id);
      if (!inspection && !entry.measured) continue;
      const HoleInspection* n = entry.inspection;
      const bool nominal = n && n->nominal_centre_S;
      entry.centre_S = nominal ? *n->nominal_centre_S : h.nominal_centre;
      entry.axis_S = nominal && n->nominal_axis_S ? *n->nominal_axis_S : h.nominal_axis;
      entry.diameter_mm = nominal ? n->nominal_diameter_mm : h.nominal_diameter_mm;
      holes_.push_back(entry);
    }

    for (const EdgeEntry& e : edges_)
      if (e.inspection) definition_for(CharacteristicKind::point_profile, e.inspection->profile.zone);
    for (const HoleEntry& h : holes_) {
      if (!h.inspection) continue;
      definition_for(CharacteristicKind::diameter, h.inspection->diameter.zone);
      definition_for(CharacteristicKind::position, h.inspection->position.zone);
    }

    // Document order from here on.
    if (has_characteristics()) standard_ = take_id();
    software_ = take_id();
    cs_S_ = take_id();
    cs_M_ = take_id();
    if (inspection) cs_N_ = take_id();
    cmm_ = take_id();
    if (!context_.station.empty()) location_ = take_id();
    probe_ = take_id();
    part_ = take_id();
    if (!context_.nominal_model.empty()) {
      definition_external_ = take_id();
      digital_model_ = take_id();
    }
    if (!edges_.empty()) point_definition_ = take_id();
    for (HoleEntry& h : holes_) h.feature_definition = take_id();
    for (EdgeEntry& e : edges_) e.feature_nominal = take_id();
    for (HoleEntry& h : holes_) h.feature_nominal = take_id();
    for (EdgeEntry& e : edges_) e.feature_item = take_id();
    for (HoleEntry& h : holes_) h.feature_item = take_id();
    for (CharacteristicDefinition& d : definitions_) d.id = take_id();
    for (EdgeEntry& e : edges_)
      if (e.inspection) e.profile.definition = definition_for(CharacteristicKind::point_profile, e.inspection->profile.zone);
    for (HoleEntry& h : holes_) {
      if (!h.inspection) continue;
      h.diameter.definition = definition_for(CharacteristicKind::diameter, h.inspection->diameter.zone);
      h.position.definition = definition_for(CharacteristicKind::position, h.inspection->position.zone);
    }
    for (EdgeEntry& e : edges_)
      if (e.profile.definition) e.profile.nominal = take_id();
    for (HoleEntry& h : holes_)
      if (h.diameter.definition) h.diameter.nominal = take_id(), h.position.nominal = take_id();
    for (EdgeEntry& e : edges_)
      if (e.profile.definition) e.profile.item = take_id();
    for (HoleEntry& h : holes_)
      if (h.diameter.definition) h.diameter.item = take_id(), h.position.item = take_id();
    measurement_results_ = take_id();
    for (EdgeEntry& e : edges_)
      if (e.measured) e.feature_measurement = take_id();
    for (HoleEntry& h : holes_)
      if (h.measured) h.feature_measurement = take_id();
    for (EdgeEntry& e : edges_)
      if (e.profile.definition) e.profile.measurement = take_id();
    for (HoleEntry& h : holes_)
      if (h.diameter.definition) h.diameter.measurement = take_id(), h.position.measurement = take_id();
    transform_M_S_ = take_id();
    if (inspection) transform_M_N_ = take_id();
    actual_component_ = take_id();
  }

  // The definition of a kind and zone, added on first use; its id once ids are taken.
  int definition_for(CharacteristicKind kind, const ToleranceZone& zone) {
    for (const CharacteristicDefinition& d : definitions_)
      if (d.kind == kind && d.zone == zone) return d.id;
    definitions_.push_back({kind, zone, 0});
    return 0;
  }

  // ---- Sections, in the order QIFDocument's sequence demands ----

  void write_header() {
    w_.open("Header");
    w_.open("Application");
    w_.leaf("Name", "cmmd");
    w_.close();
    std::string description = "cmmd ";
    description.append(context_.cmmd_version).append(" measurement results of job ").append(context_.job_id);
    if (!context_.job_name.empty()) description.append(": ").append(context_.job_name);
    w_.leaf("Description", description);
    w_.close();
  }

  void write_standards_and_software() {
    if (has_characteristics()) {
      // The characteristics follow ISO GPS: profile and position of ISO 1101; the decision rule
      // (ISO 14253-1) is stated on the results.
      w_.open("StandardsDefinitions", {{"n", "1"}});
      w_.open("Standard", {{"id", std::to_string(standard_)}});
      w_.open("Organization");
      w_.leaf("StandardsOrganizationEnum", "ISO");
      w_.close();
      w_.leaf("Designator", "1101");
      w_.leaf("Year", "2017");
      w_.leaf("Title", "Geometrical product specifications (GPS) - Geometrical tolerancing");
      w_.close();
      w_.close();
    }
    w_.open("SoftwareDefinitions", {{"n", "1"}});
    w_.open("Software", {{"id", std::to_string(software_)}});
    w_.leaf("VendorName", "cmmd");
    w_.leaf("ApplicationName", "cmmd");
    if (!context_.cmmd_version.empty()) w_.leaf("Version", context_.cmmd_version);
    w_.leaf("Description", "CMM control daemon: plans, probes, compensates and inspects");
    w_.close();
    w_.close();
  }

  void write_units() {
    w_.open("FileUnits");
    w_.open("PrimaryUnits");
    w_.open("LinearUnit");
    w_.leaf("SIUnitName", "meter");
    w_.leaf("UnitName", "mm");
    w_.open("UnitConversion");
    w_.leaf("Factor", "0.001");
    w_.close();
    w_.close();
    w_.close();
    w_.close();
  }

  // S is the common system every feature is given in; M the machine's; N the nominal model's. The
  // transforms that place them are actuals, in the results (ActualTransforms).
  void write_coordinate_systems() {
    w_.open("CoordinateSystems");
    w_.open("CoordinateSystemDefinitions", {{"n", cs_N_ ? "3" : "2"}});
    auto system = [&](int id, const char* name) {
      w_.open("CoordinateSystem", {{"id", std::to_string(id)}});
      w_.leaf("Name", name);
      w_.close();
    };
    system(cs_S_, "S: the part, as the scan (the job's reference) gives it");
    system(cs_M_, "M: the machine");
    if (cs_N_) system(cs_N_, "N: the nominal model");
    w_.close();
    w_.leaf("CommonCoordinateSystemId", cs_S_);
    w_.open("MachineCoordinateSystem");
    w_.leaf("CoordinateSystemId", cs_M_);
    w_.leaf("MeasurementDeviceId", cmm_);
    w_.close();
    w_.close();
  }

  void write_resources() {
    const QifContext::Machine& machine = context_.machine;
    const QifContext::Tip& tip = context_.tip;
    w_.open("MeasurementResources");
    w_.open("MeasurementDevices", {{"n", "1"}});
    w_.open("CartesianCMM", {{"id", std::to_string(cmm_)}});
    w_.leaf("Name", machine.name.empty() ? std::string("CMM") : machine.name);
    if (location_) {
      w_.open("Location", {{"id", std::to_string(location_)}});
      w_.leaf("LocationDescription", context_.station);
      w_.close();
    }
    const Vec3 travel = machine.travel_max_M - machine.travel_min_M;
    const bool box = (travel.array() > 0).all();
    if (box) {
      const Field field{"machine", -1, "travel box"};
      write_attributes(w_, {{"AttributeD3", "travel_min_M", vector3(machine.travel_min_M, field)},
                            {"AttributeD3", "travel_max_M", vector3(machine.travel_max_M, field)}});
      w_.open("CartesianWorkingVolume");
      w_.leaf("XAxisLength", number(travel.x(), field));
      w_.leaf("YAxisLength", number(travel.y(), field));
      w_.leaf("ZAxisLength", number(travel.z(), field));
      w_.close();
    }
    write_ids(w_, "SensorIds", {probe_});
    w_.close();
    w_.close();

    w_.open("DetachableSensors", {{"n", "1"}});
    w_.open("SimpleTactileProbeSensor", {{"id", std::to_string(probe_)}});
    // A tip measured with its nominal values says so where a reader of the QIF looks for the sensor.
    w_.leaf("Name", (tip.id.empty() ? std::string("tip") : "tip " + tip.id) +
                        (tip.qualified_utc.empty() ? " (nominal tip, not qualified)" : ""));
    const Field field{"tip", -1, "offset"};
    write_attributes(w_, {{"AttributeD3", "offset_M", vector3(tip.offset_M, field)}});
    if (!tip.qualified_utc.empty()) {
      w_.open("Qualifications", {{"n", "1"}});
      w_.open("Qualification");
      write_attributes(w_, {{"AttributeTime", "time", tip.qualified_utc},
                            {"AttributeD1", "residual_mm",
                             number(tip.qualification_residual_mm, {"tip", -1, "qualification residual"})}});
      w_.leaf("Description", "sphere fit on the reference sphere: effective ball radius and offset");
      w_.close();
      w_.close();
    }
    w_.open("TipEndGeometry");
    w_.leaf("TipEndGeometryEnum", "SPHERE");
    w_.close();
    const double radius = tip.ball_radius_mm > 0 ? tip.ball_radius_mm : result_.ball_radius_mm;
    w_.leaf("TipEndDiameter", number(2 * radius, {"tip", -1, "ball radius"}));
    w_.close();
    w_.close();
    w_.close();
  }

  void write_product() {
    w_.open("Product");
    w_.open("PartSet", {{"n", "1"}});
    w_.open("Part", {{"id", std::to_string(part_)}});
    w_.open("Header");
    w_.leaf("Name", context_.part_name.empty() ? std::string("part") : context_.part_name);
    w_.close();
    if (definition_external_) {
      w_.open("DefinitionExternal", {{"id", std::to_string(definition_external_)}, {"n", "1"}});
      w_.open("DigitalModel", {{"id", std::to_string(digital_model_)}});
      w_.leaf("Name", context_.nominal_model);
      w_.open("File");
      w_.leaf("Name", context_.nominal_model);
      w_.close();
      w_.leaf("Description", "the nominal model the characteristics are held against");
      w_.close();
      w_.close();
    }
    w_.close();
    w_.close();
    w_.close();
  }

  void write_features() {
    if (edges_.empty() && holes_.empty()) return;
    w_.open("Features");

    w_.open("FeatureDefinitions", {{"n", std::to_string((point_definition_ ? 1 : 0) + holes_.size())}});
    if (point_definition_) w_.empty("PointFeatureDefinition", {{"id", std::to_string(point_definition_)}});
    for (const HoleEntry& h : holes_) {
      w_.open("CircleFeatureDefinition", {{"id", std::to_string(h.feature_definition)}});
      w_.leaf("InternalExternal", "INTERNAL");
      w_.leaf("Diameter", number(h.diameter_mm, {"hole", h.hole->id, "nominal diameter"}));
      w_.close();
    }
    w_.close();

    w_.open("FeatureNominals", {{"n", std::to_string(edges_.size() + holes_.size())}});
    for (const EdgeEntry& e : edges_) {
      w_.open("PointFeatureNominal", {{"id", std::to_string(e.feature_nominal)}});
      write_attributes(w_, {{"AttributeStr", "kind", geometry::to_string(e.edge->kind)}});
      w_.leaf("FeatureDefinitionId", point_definition_);
      w_.leaf("Location", vector3(e.nominal_S, {"edge point", e.edge->id, "nominal position"}));
      w_.close();
    }
    for (const HoleEntry& h : holes_) {
      w_.open("CircleFeatureNominal", {{"id", std::to_string(h.feature_nominal)}});
      w_.leaf("FeatureDefinitionId", h.feature_definition);
      w_.leaf("Location", vector3(h.centre_S, {"hole", h.hole->id, "nominal centre"}));
      w_.leaf("Normal", vector3(h.axis_S, {"hole", h.hole->id, "nominal axis"}));
      w_.close();
    }
    w_.close();

    w_.open("FeatureItems", {{"n", std::to_string(edges_.size() + holes_.size())}});
    auto item = [&](const char* tag, int id, int nominal, const std::string& name) {
      w_.open(tag, {{"id", std::to_string(id)}});
      w_.leaf("FeatureNominalId", nominal);
      w_.leaf("FeatureName", name);
      w_.open("DeterminationMode");
      w_.open("Checked");
      w_.open("CheckDetails");
      w_.empty("Measured");
      w_.close();
      w_.close();
      w_.close();
      w_.close();
    };
    for (const EdgeEntry& e : edges_) item("PointFeatureItem", e.feature_item, e.feature_nominal, edge_name(e));
    for (const HoleEntry& h : holes_) item("CircleFeatureItem", h.feature_item, h.feature_nominal, hole_name(h));
    w_.close();

    w_.close();
  }

  void write_characteristics() {
    if (!has_characteristics()) return;
    w_.open("Characteristics");
    w_.leaf("FormalStandardId", standard_);

    w_.open("CharacteristicDefinitions", {{"n", std::to_string(definitions_.size())}});
    for (const CharacteristicDefinition& d : definitions_) write_definition(d);
    w_.close();

    int count = 0;
    for (const EdgeEntry& e : edges_) count += e.profile.definition ? 1 : 0;
    for (const HoleEntry& h : holes_) count += h.diameter.definition ? 2 : 0;

    w_.open("CharacteristicNominals", {{"n", std::to_string(count)}});
    auto nominal = [&](const char* tag, const CharacteristicIds& ids, int feature_nominal,
                       const std::string* target = nullptr) {
      w_.open(tag, {{"id", std::to_string(ids.nominal)}});
      w_.leaf("CharacteristicDefinitionId", ids.definition);
      write_ids(w_, "FeatureNominalIds", {feature_nominal});
      if (target) w_.leaf("TargetValue", *target);
      w_.close();
    };
    for (const EdgeEntry& e : edges_)
      if (e.profile.definition) nominal("PointProfileCharacteristicNominal", e.profile, e.feature_nominal);
    for (const HoleEntry& h : holes_) {
      if (!h.diameter.definition) continue;
      const std::string target = number(h.diameter_mm, {"hole", h.hole->id, "nominal diameter"});
      nominal("DiameterCharacteristicNominal", h.diameter, h.feature_nominal, &target);
      nominal("PositionCharacteristicNominal", h.position, h.feature_nominal);
    }
    w_.close();

    w_.open("CharacteristicItems", {{"n", std::to_string(count)}});
    auto item = [&](const char* tag, const CharacteristicIds& ids, int feature_item, const std::string& name) {
      w_.open(tag, {{"id", std::to_string(ids.item)}});
      w_.leaf("Name", name);
      write_ids(w_, "FeatureItemIds", {feature_item});
      write_ids(w_, "MeasurementDeviceIds", {cmm_});
      w_.leaf("CharacteristicNominalId", ids.nominal);
      w_.close();
    };
    for (const EdgeEntry& e : edges_)
      if (e.profile.definition) item("PointProfileCharacteristicItem", e.profile, e.feature_item, edge_name(e) + " profile");
    for (const HoleEntry& h : holes_) {
      if (!h.diameter.definition) continue;
      item("DiameterCharacteristicItem", h.diameter, h.feature_item, hole_name(h) + " diameter");
      item("PositionCharacteristicItem", h.position, h.feature_item, hole_name(h) + " position");
    }
    w_.close();

    w_.close();
  }

  void write_definition(const CharacteristicDefinition& d) {
    const Field field{"tolerance zone", -1, "limit"};
    switch (d.kind) {
      case CharacteristicKind::point_profile: {
        // ISO 1101: the zone's width; an unequal zone (ISO's UZ) by its centre, positive outside the
        // material, which is our deviations' sign.
        w_.open("PointProfileCharacteristicDefinition", {{"id", std::to_string(d.id)}});
        w_.leaf("ToleranceValue", number(d.zone.upper_mm - d.zone.lower_mm, field));
        const double centre = (d.zone.upper_mm + d.zone.lower_mm) / 2;
        if (number(centre, field) != "0") w_.leaf("UnequallyDisposedZone", number(centre, field));
        w_.close();
        break;
      }
      case CharacteristicKind::diameter:
        // Limits on the deviation from the nominal diameter (DefinedAsLimit false: not absolute sizes).
        w_.open("DiameterCharacteristicDefinition", {{"id", std::to_string(d.id)}});
        w_.open("Tolerance");
        w_.leaf("MaxValue", number(d.zone.upper_mm, field));
        w_.leaf("MinValue", number(d.zone.lower_mm, field));
        w_.leaf("DefinedAsLimit", "false");
        w_.close();
        w_.close();
        break;
      case CharacteristicKind::position:
        // A cylindrical zone of this diameter about the nominal axis, no datums, no material modifier.
        w_.open("PositionCharacteristicDefinition", {{"id", std::to_string(d.id)}});
        w_.leaf("ToleranceValue", number(d.zone.upper_mm, field));
        w_.leaf("MaterialCondition", "NONE");
        w_.open("ZoneShape");
        w_.empty("DiametricalZone");
        w_.close();
        w_.close();
        break;
    }
  }

  void write_results() {
    const std::optional<InspectionResult>& inspection = result_.inspection;
    w_.open("Results");
    w_.open("MeasurementResultsSet", {{"n", "1"}});
    w_.open("MeasurementResults", {{"id", std::to_string(measurement_results_)}});
    if (inspection) {
      const Tolerances& t = inspection->tolerances;
      write_attributes(w_, {{"AttributeStr", "decision_rule",
                             "ISO 14253-1: PASS when deviation +- U lies inside the tolerance zone, FAIL when "
                             "wholly outside, INDETERMINATE when it straddles a limit; U = k * sqrt(sigma^2 + "
                             "u_machine^2)"},
                            {"AttributeD1", "coverage_factor", number(t.coverage_factor, {"tolerances", -1, "k"})},
                            {"AttributeD1", "machine_uncertainty_mm",
                             number(t.machine_uncertainty_mm, {"tolerances", -1, "machine uncertainty"})}});
    }
    write_traceability();

    int measured_features = 0;
    for (const EdgeEntry& e : edges_) measured_features += e.measured ? 1 : 0;
    for (const HoleEntry& h : holes_) measured_features += h.measured ? 1 : 0;
    if (measured_features > 0) {
      w_.open("MeasuredFeatures", {{"n", std::to_string(measured_features)}});
      for (const EdgeEntry& e : edges_)
        if (e.measured) write_edge_measurement(e);
      for (const HoleEntry& h : holes_)
        if (h.measured) write_hole_measurement(h);
      w_.close();
    }

    if (has_characteristics()) {
      int count = 0;
      for (const EdgeEntry& e : edges_) count += e.profile.definition ? 1 : 0;
      for (const HoleEntry& h : holes_) count += h.diameter.definition ? 2 : 0;
      w_.open("MeasuredCharacteristics");
      w_.open("CharacteristicMeasurements", {{"n", std::to_string(count)}});
      for (const EdgeEntry& e : edges_) {
        if (!e.profile.definition) continue;
        const std::string reason = e.inspection->reason.empty() ? e.edge->reason : e.inspection->reason;
        write_characteristic_measurement("PointProfileCharacteristicMeasurement", e.profile, e.inspection->profile,
                                         0, e.feature_measurement, reason, {"edge point", e.edge->id, "profile"});
      }
      for (const HoleEntry& h : holes_) {
        if (!h.diameter.definition) continue;
        const std::string reason = h.inspection->reason.empty() ? h.hole->reason : h.inspection->reason;
        // A diameter's value is the size itself: the nominal plus the deviation the verdict is on.
        write_characteristic_measurement("DiameterCharacteristicMeasurement", h.diameter, h.inspection->diameter,
                                         h.diameter_mm, h.feature_measurement, reason, {"hole", h.hole->id, "diameter"});
        write_characteristic_measurement("PositionCharacteristicMeasurement", h.position, h.inspection->position, 0,
                                         h.feature_measurement, reason, {"hole", h.hole->id, "position"});
      }
      w_.close();
      w_.close();
    }

    write_transforms();

    w_.open("InspectionStatus");
    w_.leaf(inspection_status(inspection).element, inspection_status(inspection).value);
    w_.close();
    write_ids(w_, "ActualComponentIds", {actual_component_});
    w_.close();
    w_.close();

    w_.open("ActualComponentSets", {{"n", "1"}});
    w_.open("ActualComponentSet", {{"n", "1"}});
    w_.open("ActualComponent", {{"id", std::to_string(actual_component_)}});
    w_.open("Status");
    w_.leaf(inspection_status(inspection).element, inspection_status(inspection).value);
    w_.close();
    w_.close();
    w_.close();
    w_.close();
    w_.close();
  }

  void write_traceability() {
    w_.open("InspectionTraceability");
    if (!context_.job_id.empty()) w_.leaf("ReportNumber", context_.job_id);
    if (!context_.started_utc.empty()) w_.leaf("InspectionStart", context_.started_utc);
    if (!context_.finished_utc.empty()) w_.leaf("InspectionEnd", context_.finished_utc);
    w_.open("InspectionSoftwareItems");
    write_ids(w_, "InspectionProgramGenerationSoftware", {software_});
    write_ids(w_, "InspectionProgramExecutionSoftware", {software_});
    write_ids(w_, "AnalysisSoftware", {software_});
    w_.close();
    if (!context_.written_utc.empty()) w_.leaf("ReportPreparationDate", context_.written_utc);
    std::vector<QifAttribute> attributes;
    if (!context_.job_name.empty()) attributes.push_back({"AttributeStr", "job_name", context_.job_name});
    if (!context_.station.empty()) attributes.push_back({"AttributeStr", "station", context_.station});
    write_attributes(w_, attributes);
    w_.close();
  }

  void write_edge_measurement(const EdgeEntry& e) {
    const EdgeResult& edge = *e.edge;
    const MeasuredPoint& point = *edge.scan;
    w_.open("PointFeatureMeasurement", {{"id", std::to_string(e.feature_measurement)}});
    // The deviation against the scan (the job's reference), as result.json reports it.
    write_attributes(w_, {{"AttributeStr", "method", to_string(point.method)},
                          {"AttributeD1", "reference_deviation_mm",
                           number(edge.deviation.signed_mm, {"edge point", edge.id, "reference deviation"})}});
    w_.leaf("FeatureItemId", e.feature_item);
    // combinedUncertainty: the point's 1-σ from the trigger noise (worst direction).
    w_.leaf("Location", vector3(point.position, {"edge point", edge.id, "measured position"}),
            {{"combinedUncertainty", number(std::max(0.0, point.sigma_mm), {"edge point", edge.id, "sigma"})}});
    w_.close();
  }

  void write_hole_measurement(const HoleEntry& h) {
    const HoleResult& hole = *h.hole;
    const BoreMeasurement& bore = *hole.scan;
    w_.open("CircleFeatureMeasurement", {{"id", std::to_string(h.feature_measurement)}});
    write_attributes(w_, {{"AttributeD1", "depth_mm", number(hole.depth_mm, {"hole", hole.id, "depth"})},
                          {"AttributeD1", "reference_diameter_deviation_mm",
                           number(hole.diameter_deviation_mm, {"hole", hole.id, "diameter deviation"})},
                          {"AttributeD1", "reference_centre_deviation_mm",
                           number(hole.centre_deviation_mm, {"hole", hole.id, "centre deviation"})}});
    w_.leaf("FeatureItemId", h.feature_item);
    w_.leaf("Location", vector3(bore.centre, {"hole", hole.id, "measured centre"}),
            {{"combinedUncertainty", number(std::max(0.0, bore.centre_sigma_mm), {"hole", hole.id, "centre sigma"})}});
    w_.leaf("Normal", vector3(bore.axis, {"hole", hole.id, "axis"}));
    w_.leaf("Diameter", number(bore.diameter_mm, {"hole", hole.id, "measured diameter"}),
            {{"combinedUncertainty",
              number(std::max(0.0, bore.diameter_sigma_mm), {"hole", hole.id, "diameter sigma"})}});
    w_.leaf("Form", number(bore.roundness_mm, {"hole", hole.id, "roundness"}));
    w_.close();
  }

  // A characteristic's actual: the status always; the value (offset + deviation) only when the
  // feature was measured and judged; otherwise the reason why not.
  void write_characteristic_measurement(const char* tag, const CharacteristicIds& ids, const Characteristic& c,
                                        double offset, int feature_measurement, const std::string& reason,
                                        const Field& field) {
    const bool judged = feature_measurement != 0 && planner::judged(c.verdict);
    const Verdict verdict = judged || c.verdict == Verdict::excluded ? c.verdict : Verdict::not_measured;
    w_.open(tag, {{"id", std::to_string(ids.measurement)}});
    if (judged) {
      write_attributes(w_, {{"AttributeD1", "expanded_uncertainty_mm", number(c.uncertainty_mm, field)}});
    } else {
      const std::string why = verdict == Verdict::excluded ? "excluded" : "not measured";
      w_.leaf("Description", reason.empty() ? why : why + ": " + reason);
    }
    w_.open("Status");
    w_.leaf(characteristic_status(verdict).element, characteristic_status(verdict).value);
    w_.close();
    w_.leaf("CharacteristicItemId", ids.item);
    if (feature_measurement) write_ids(w_, "FeatureMeasurementIds", {feature_measurement});
    if (judged) {
      const double k = result_.inspection->tolerances.coverage_factor;
      XmlAttributes attributes;
      if (k > 0 && c.uncertainty_mm >= 0)
        attributes.push_back({"combinedUncertainty", number(c.uncertainty_mm / k, field)});
      w_.leaf("Value", number(offset + c.deviation_mm, field), attributes);
    }
    w_.close();
  }

  // TransformMatrixType maps "before" into "after" coordinates (X = R x + O, XDirection R's first
  // column): the coordinates of S, and of N, in M.
  void write_transforms() {
    w_.open("ActualTransforms", {{"n", transform_M_N_ ? "2" : "1"}});
    write_transform(transform_M_S_, result_.T_M_S, {}, "T_M_S: S into M (the registration)");
    if (transform_M_N_) {
      const NominalPlacement& n = result_.inspection->nominal;
      write_transform(transform_M_N_, result_.T_M_S * n.T_S_N,
                      {{"AttributeStr", "method", n.method},
                       {"AttributeD1", "rms_mm", number(n.rms_mm, {"nominal placement", -1, "rms"})},
                       {"AttributeD1", "overlap", number(n.overlap, {"nominal placement", -1, "overlap"})},
                       {"AttributeI1", "iterations", std::to_string(n.iterations)},
                       {"AttributeBool", "converged", n.converged ? "true" : "false"}},
                      "T_M_N: N into M (T_M_S T_S_N, the nominal's placement)");
    }
    w_.close();
    w_.open("CoordinateSystemActualTransformAssociations", {{"n", transform_M_N_ ? "2" : "1"}});
    auto association = [&](int transform, int system) {
      w_.open("CoordinateSystemActualTransformAssociation");
      w_.leaf("ActualTransformId", transform);
      w_.leaf("CoordinateSystemId", system);
      w_.close();
    };
    association(transform_M_S_, cs_S_);
    if (transform_M_N_) association(transform_M_N_, cs_N_);
    w_.close();
  }

  void write_transform(int id, const Eigen::Isometry3d& T, const std::vector<QifAttribute>& attributes,
                       const char* name) {
    const Field field{"transform", -1, name};
    w_.open("Transform", {{"id", std::to_string(id)}});
    w_.open("Rotation");
    w_.leaf("XDirection", vector3(T.linear().col(0), field));
    w_.leaf("YDirection", vector3(T.linear().col(1), field));
    w_.leaf("ZDirection", vector3(T.linear().col(2), field));
    w_.close();
    w_.leaf("Origin", vector3(T.translation(), field));
    write_attributes(w_, attributes);
    w_.leaf("Name", name);
    w_.close();
  }

  static std::string edge_name(const EdgeEntry& e) { return std::string("edge point ").append(std::to_string(e.edge->id)); }
  static std::string hole_name(const HoleEntry& h) { return std::string("hole ").append(std::to_string(h.hole->id)); }

  const MeasurementResult& result_;
  const QifContext& context_;
  XmlWriter w_;
  int next_id_ = 1;

  std::vector<EdgeEntry> edges_;
  std::vector<HoleEntry> holes_;
  std::vector<CharacteristicDefinition> definitions_;
  int standard_ = 0, software_ = 0, cs_S_ = 0, cs_M_ = 0, cs_N_ = 0, cmm_ = 0, location_ = 0, probe_ = 0, part_ = 0;
  int definition_external_ = 0, digital_model_ = 0, point_definition_ = 0, measurement_results_ = 0;
  int transform_M_S_ = 0, transform_M_N_ = 0, actual_component_ = 0;
};

}  // namespace

std::string to_qif(const MeasurementResult& result, const QifContext& context) {
  return QifDocument(result, context).write();
}

}  // namespace cmm::planner
