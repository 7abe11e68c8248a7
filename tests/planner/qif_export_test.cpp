// QIF export: every document validates with xmllint against the QIF 3.0 schema (no xmllint or schema
// fails), every id reference resolves, and verdicts, values and escaping are where docs/qif.md says.
#include <unistd.h>

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <regex>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "planner/qif_export.hpp"
#include "tests/tools/run_command.hpp"

namespace {

namespace fs = std::filesystem;
using namespace cmm::planner;

// The repository's copy of ../shared/schemas/qif3 (tests/data/qif3/PROVENANCE.md).
const fs::path schema = fs::path(CMMD_TEST_DATA_DIR) / "qif3" / "QIFApplications" / "QIFDocument.xsd";

const std::string tricky_name = "Bracket <A&B> \"quoted\" 'single' \xC3\xBC";  // ends in ü (UTF-8)

QifContext context() {
  QifContext c;
  c.job_id = "j-000042";
  c.job_name = tricky_name;
  c.part_name = "bracket.ply";
  c.cmmd_version = "0.4.0";
  c.station = "Bay 3 & 4";
  c.machine.name = "Modbus machine at 127.0.0.1:1502";
  c.machine.travel_min_M = Vec3(-50, -50, -20);
  c.machine.travel_max_M = Vec3(400, 300, 150);
  c.tip.id = "T1";
  c.tip.ball_radius_mm = 0.9987;
  c.tip.offset_M = Vec3(0, 0, -30.0012);
  c.tip.qualified_utc = "2026-11-24T11:00:00Z";
  c.tip.qualification_residual_mm = 0.0008;
  c.started_utc = "2026-11-24T12:00:00Z";
  c.finished_utc = "2026-11-24T12:04:10Z";
  c.written_utc = "2026-11-24T12:04:11Z";
  c.nominal_model = "sha256:0123abcd";
  return c;
}

EdgeResult measured_edge(int id, const Vec3& reference, const Vec3& measured, double deviation_mm) {
  EdgeResult e;
  e.id = id;
  e.method = EdgeMethod::two_touch;
  e.status = FeatureStatus::measured;
  e.reference = reference;
  MeasuredPoint p;
  p.id = id;
  p.frame = PointFrame::scan;
  p.position = measured;
  p.sigma_mm = 0.0011;
  e.scan = p;
  p.frame = PointFrame::machine;
  e.machine = p;
  e.deviation.signed_mm = deviation_mm;
  return e;
}

EdgeInspection edge_inspection(int id, const Vec3& nominal, double deviation_mm, Verdict verdict) {
  EdgeInspection i;
  i.id = id;
  i.nominal_S = nominal;
  i.profile = {deviation_mm, 0.004, {-0.1, 0.1}, verdict};
  return i;
}

HoleResult measured_hole(int id, const Vec3& centre, double diameter_mm) {
  HoleResult h;
  h.id = id;
  h.status = FeatureStatus::measured;
  h.depth_mm = 2;
  h.nominal_centre = centre;
  h.nominal_diameter_mm = 8;
  BoreMeasurement b;
  b.hole_id = id;
  b.frame = PointFrame::scan;
  b.centre = centre + Vec3(0.01, 0, -2);
  b.diameter_mm = diameter_mm;
  b.roundness_mm = 0.002;
  b.centre_sigma_mm = 0.0006;
  b.diameter_sigma_mm = 0.0009;
  h.scan = b;
  h.centre_deviation_mm = 0.01;
  h.diameter_deviation_mm = diameter_mm - 8;
  return h;
}

// A job with a nominal: edge points 0 pass, 1 fail, 2 undecided, 3 not measured; hole 0 with its
// diameter failing and its position passing, hole 1 not planned.
MeasurementResult inspected_result() {
  MeasurementResult r;
  r.T_M_S = Eigen::Translation3d(100, 50, 10) * Eigen::AngleAxisd(std::numbers::pi / 2, Vec3::UnitZ());
  r.ball_radius_mm = 1;
  r.trigger_sigma_mm = 0.001;
  r.edges.push_back(measured_edge(0, Vec3(0, 0, 10), Vec3(0.0123456789, 0, 10), 0.0123456789));
  r.edges.push_back(measured_edge(1, Vec3(10, 0, 10), Vec3(10.25, 0, 10), 0.25));
  r.edges.push_back(measured_edge(2, Vec3(20, 0, 10), Vec3(20.098, 0, 10), 0.098));
  EdgeResult missed;
  missed.id = 3;
  missed.status = FeatureStatus::failed;
  missed.reason = "touch 7 (edge 3) missed: no contact within its 1.5 mm search";
  missed.reference = Vec3(30, 0, 10);
  r.edges.push_back(missed);
  r.holes.push_back(measured_hole(0, Vec3(20, 20, 10), 8.2));
  HoleResult unplanned;
  unplanned.id = 1;
  unplanned.reason = "open rim";
  unplanned.nominal_centre = Vec3(40, 20, 10);
  unplanned.nominal_diameter_mm = 6;
  r.holes.push_back(unplanned);
  r.summary = summarise(r.edges, r.holes);

  InspectionResult inspection;
  inspection.nominal.model = "sha256:0123abcd";
  inspection.nominal.method = "icp";
  inspection.nominal.T_S_N = Eigen::Translation3d(0.01, -0.02, 0.005) * Eigen::Isometry3d::Identity();
  inspection.nominal.iterations = 12;
  inspection.nominal.rms_mm = 0.0042;
  inspection.nominal.overlap = 0.97;
  inspection.edges.push_back(edge_inspection(0, Vec3(0.001, 0, 10), 0.012345678, Verdict::pass));
  inspection.edges.push_back(edge_inspection(1, Vec3(10, 0, 10), 0.25, Verdict::fail));
  inspection.edges.push_back(edge_inspection(2, Vec3(20, 0, 10), 0.098, Verdict::undecided));
  EdgeInspection not_measured;
  not_measured.id = 3;
  not_measured.nominal_S = Vec3(30, 0, 10);
  not_measured.profile.zone = {-0.1, 0.1};
  inspection.edges.push_back(not_measured);
  HoleInspection hole;
  hole.id = 0;
  hole.nominal_centre_S = Vec3(20, 20, 10);
  hole.nominal_axis_S = Vec3::UnitZ();
  hole.nominal_diameter_mm = 8;
  hole.diameter = {0.2, 0.002, {-0.05, 0.05}, Verdict::fail};
  hole.position = {0.02, 0.002, {0, 0.1}, Verdict::pass};
  inspection.holes.push_back(hole);
  HoleInspection unmeasured_hole;
  unmeasured_hole.id = 1;
  unmeasured_hole.nominal_centre_S = Vec3(40, 20, 10);
  unmeasured_hole.nominal_axis_S = Vec3::UnitZ();
  unmeasured_hole.nominal_diameter_mm = 6;
  unmeasured_hole.diameter.zone = {-0.05, 0.05};
  unmeasured_hole.position.zone = {0, 0.1};
  inspection.holes.push_back(unmeasured_hole);
  inspection.edge_counts = {1, 1, 1, 1};
  inspection.hole_counts = {0, 1, 0, 1};
  inspection.verdict = Verdict::fail;
  r.inspection = inspection;
  return r;
}

fs::path qif_file(const std::string& name) {
  return fs::temp_directory_path() / ("cmmd_qif_" + std::to_string(getpid()) + "_" + name + ".qif");
}

// Writes the document to a file of its own and runs xmllint on it; the output names what is wrong.
cmm::test::CommandResult validate(const std::string& xml, const std::string& name) {
  const fs::path file = qif_file(name);
  {
    std::ofstream out(file, std::ios::binary);
    out << xml;
  }
  auto result = cmm::test::run_command("xmllint --nonet --noout --schema '" + schema.string() + "' '" + file.string() + "'");
  if (result.exit_code == 0) fs::remove(file);  // kept for a look when it fails
  return result;
}

void expect_valid(const std::string& xml, const std::string& name) {
  ASSERT_TRUE(fs::exists(schema)) << "QIF 3.0 schema missing: " << schema;
  const auto result = validate(xml, name);
  EXPECT_EQ(result.exit_code, 0) << "xmllint (exit 127: not installed, apt-get install libxml2-utils):\n"
                                 << result.output;
}

// The text of every element named `tag`, from its start tag to its end tag.
std::vector<std::string> blocks(const std::string& xml, const std::string& tag) {
  std::vector<std::string> out;
  const std::string open = "<" + tag, close = "</" + tag + ">";
  for (std::size_t at = xml.find(open); at != std::string::npos; at = xml.find(open, at + 1)) {
    const char next = xml[at + open.size()];
    if (next != ' ' && next != '>') continue;
    const std::size_t end = xml.find(close, at);
    if (end == std::string::npos) break;
    out.push_back(xml.substr(at, end + close.size() - at));
  }
  return out;
}

std::string between(const std::string& text, const std::string& open, const std::string& close) {
  const std::size_t start = text.find(open);
  if (start == std::string::npos) return {};
  const std::size_t end = text.find(close, start + open.size());
  return end == std::string::npos ? std::string() : text.substr(start + open.size(), end - start - open.size());
}

std::string id_of(const std::string& block) { return between(block, "id=\"", "\""); }

// The text of a block's <Value …> element.
std::string value_of(const std::string& block) {
  const std::size_t start = block.find("<Value");
  return start == std::string::npos ? std::string() : between(block.substr(start), ">", "</Value>");
}

// The measurement of the characteristic item named `name` ("edge point 1 profile"); empty if none.
std::string measurement_of(const std::string& xml, const std::string& kind, const std::string& name) {
  for (const std::string& item : blocks(xml, kind + "CharacteristicItem")) {
    if (item.find("<Name>" + name + "</Name>") == std::string::npos) continue;
    const std::string reference = "<CharacteristicItemId>" + id_of(item) + "</CharacteristicItemId>";
    for (const std::string& m : blocks(xml, kind + "CharacteristicMeasurement"))
      if (m.find(reference) != std::string::npos) return m;
  }
  return {};
}

// The schema's enumerated status, or the free-text one (OtherCharacteristicStatus) where it has no word.
std::string status_of(const std::string& measurement) {
  const std::string status = between(measurement, "<CharacteristicStatusEnum>", "</CharacteristicStatusEnum>");
  return status.empty() ? "other " + between(measurement, "<OtherCharacteristicStatus>", "</OtherCharacteristicStatus>")
                        : status;
}

// The part's status the same way (InspectionStatusEnum or OtherInspectionStatus).
std::string part_status_of(const std::string& block) {
  const std::string status = between(block, "<InspectionStatusEnum>", "</InspectionStatusEnum>");
  return status.empty() ? "other " + between(block, "<OtherInspectionStatus>", "</OtherInspectionStatus>") : status;
}

// Ids unique, idMax their largest, and every reference (an element whose name ends in "Id" holding
// a number, or an <Id> in a list) naming one of them: the schema's keyrefs cover only some.
void expect_references_resolve(const std::string& xml) {
  std::set<long> ids;
  long largest = 0;
  static const std::regex id_attribute(R"( id="(\d+)\")");
  for (auto it = std::sregex_iterator(xml.begin(), xml.end(), id_attribute); it != std::sregex_iterator(); ++it) {
    const long id = std::stol((*it)[1]);
    EXPECT_TRUE(ids.insert(id).second) << "id " << id << " used twice";
    largest = std::max(largest, id);
  }
  EXPECT_EQ(between(xml, "idMax=\"", "\""), std::to_string(largest));
  static const std::regex reference(R"(<(\w*Id)>(\d+)</\1>)");
  int references = 0;
  for (auto it = std::sregex_iterator(xml.begin(), xml.end(), reference); it != std::sregex_iterator(); ++it) {
    ++references;
    EXPECT_TRUE(ids.count(std::stol((*it)[2]))) << (*it)[0] << " names no element";
  }
  EXPECT_GT(references, 5);
}

TEST(QifExport, InspectedResultValidatesAndCarriesTheVerdicts) {
  const std::string xml = to_qif(inspected_result(), context());
  expect_valid(xml, "inspected");
  expect_references_resolve(xml);

  EXPECT_EQ(status_of(measurement_of(xml, "PointProfile", "edge point 0 profile")), "PASS");
  EXPECT_EQ(status_of(measurement_of(xml, "PointProfile", "edge point 1 profile")), "FAIL");
  EXPECT_EQ(status_of(measurement_of(xml, "PointProfile", "edge point 2 profile")), "INDETERMINATE");
  EXPECT_EQ(status_of(measurement_of(xml, "Diameter", "hole 0 diameter")), "FAIL");
  EXPECT_EQ(status_of(measurement_of(xml, "Position", "hole 0 position")), "PASS");

  // Values: the signed deviation to 1e-9 mm, the diameter as a size, the position as a zone diameter.
  EXPECT_EQ(value_of(measurement_of(xml, "PointProfile", "edge point 0 profile")), "0.012345678");
  EXPECT_EQ(value_of(measurement_of(xml, "Diameter", "hole 0 diameter")), "8.2");
  EXPECT_EQ(value_of(measurement_of(xml, "Position", "hole 0 position")), "0.02");
  // Its combined standard uncertainty: U / k.
  EXPECT_NE(measurement_of(xml, "Position", "hole 0 position").find("combinedUncertainty=\"0.001\""), std::string::npos);

  // Not measured: the characteristic is there, NOT_MEASURED (free text: the enumeration has no such
  // word, and NOT_ANALYZED would say measured, not evaluated), with its reason and no actual.
  const std::string missed = measurement_of(xml, "PointProfile", "edge point 3 profile");
  EXPECT_EQ(status_of(missed), "other NOT_MEASURED");
  EXPECT_NE(missed.find("touch 7 (edge 3) missed"), std::string::npos) << missed;
  EXPECT_EQ(missed.find("<Value"), std::string::npos);
  EXPECT_EQ(missed.find("FeatureMeasurementIds"), std::string::npos);
  EXPECT_EQ(status_of(measurement_of(xml, "Diameter", "hole 1 diameter")), "other NOT_MEASURED");
  EXPECT_EQ(measurement_of(xml, "Diameter", "hole 1 diameter").find("<Value"), std::string::npos);

  // Features: all four points and both holes are defined, the three measured points and one hole measured.
  EXPECT_EQ(blocks(xml, "PointFeatureItem").size(), 4u);
  EXPECT_EQ(blocks(xml, "CircleFeatureItem").size(), 2u);
  EXPECT_EQ(blocks(xml, "PointFeatureMeasurement").size(), 3u);
  EXPECT_EQ(blocks(xml, "CircleFeatureMeasurement").size(), 1u);
  // One profile definition serves the four points (same zone), ±0.1 = a 0.2 wide zone.
  ASSERT_EQ(blocks(xml, "PointProfileCharacteristicDefinition").size(), 1u);
  EXPECT_NE(xml.find("<ToleranceValue>0.2</ToleranceValue>"), std::string::npos);
  // Nominal point of edge 0 is the nominal's, not the reference (0 0 10).
  EXPECT_NE(xml.find("<Location>0.001 0 10</Location>"), std::string::npos);

  EXPECT_EQ(between(xml, "<InspectionStatusEnum>", "</InspectionStatusEnum>"), "FAIL");

  // T_M_S: a quarter turn about z, then (100, 50, 10): x of S is y of M.
  const std::string transform = blocks(xml, "Transform").at(0);
  EXPECT_NE(transform.find("<XDirection>0 1 0</XDirection>"), std::string::npos) << transform;
  EXPECT_NE(transform.find("<YDirection>-1 0 0</YDirection>"), std::string::npos) << transform;
  EXPECT_NE(transform.find("<Origin>100 50 10</Origin>"), std::string::npos) << transform;
  EXPECT_EQ(blocks(xml, "Transform").size(), 2u);  // and T_M_N

  // The tip: diameter 2r, its qualification time.
  EXPECT_NE(xml.find("<TipEndDiameter>1.9974</TipEndDiameter>"), std::string::npos);
  EXPECT_NE(xml.find("value=\"2026-11-24T11:00:00Z\""), std::string::npos);
}

// The check itself: a document the schema does not allow is refused, naming the element.
TEST(QifExport, SchemaCheckRefusesAMisnamedElement) {
  std::string xml = to_qif(inspected_result(), context());
  const std::size_t at = xml.find("<TipEndDiameter>");
  ASSERT_NE(at, std::string::npos);
  xml.replace(at, 16, "<TipDiameter>");
  xml.replace(xml.find("</TipEndDiameter>"), 17, "</TipDiameter>");
  ASSERT_TRUE(fs::exists(schema)) << schema;
  const auto result = validate(xml, "misnamed");
  EXPECT_NE(result.exit_code, 0);
  EXPECT_NE(result.output.find("TipDiameter"), std::string::npos) << result.output;
  fs::remove(qif_file("misnamed"));
}

TEST(QifExport, EscapesTheJobNameInTextAndAttributes) {
  const std::string xml = to_qif(inspected_result(), context());
  EXPECT_EQ(xml.find(tricky_name), std::string::npos);
  EXPECT_EQ(xml.find("<A&B>"), std::string::npos);
  EXPECT_NE(xml.find("Bracket &lt;A&amp;B&gt; &quot;quoted&quot; &apos;single&apos; \xC3\xBC"), std::string::npos);
  EXPECT_NE(xml.find("<LocationDescription>Bay 3 &amp; 4</LocationDescription>"), std::string::npos);

  // Bytes that are not UTF-8 and control characters become U+FFFD; the document stays valid.
  QifContext c = context();
  c.job_name = std::string("bad \xFF\xC0\x80 byte \x01 and a\nline break");
  const std::string odd = to_qif(inspected_result(), c);
  expect_valid(odd, "odd_name");
  EXPECT_NE(odd.find("bad \xEF\xBF\xBD\xEF\xBF\xBD\xEF\xBF\xBD byte \xEF\xBF\xBD and a&#10;line break"), std::string::npos);
}

TEST(QifExport, WithoutNominalWritesMeasuredFeaturesAndNoCharacteristics) {
  MeasurementResult r = inspected_result();
  r.inspection.reset();
  QifContext c = context();
  c.nominal_model.clear();
  const std::string xml = to_qif(r, c);
  expect_valid(xml, "no_nominal");
  expect_references_resolve(xml);
  EXPECT_EQ(xml.find("<Characteristics>"), std::string::npos);
  EXPECT_EQ(xml.find("CharacteristicMeasurement"), std::string::npos);
  EXPECT_EQ(xml.find("DigitalModel"), std::string::npos);
  // Only what was measured, its nominal the reference point.
  EXPECT_EQ(blocks(xml, "PointFeatureItem").size(), 3u);
  EXPECT_EQ(blocks(xml, "CircleFeatureItem").size(), 1u);
  EXPECT_NE(xml.find("<Location>0 0 10</Location>"), std::string::npos);
  EXPECT_EQ(between(xml, "<InspectionStatusEnum>", "</InspectionStatusEnum>"), "NOT_CALCULATED");
  EXPECT_EQ(blocks(xml, "Transform").size(), 1u);
}

// QIF's part status has no INCOMPLETE: an incomplete job is the free-text OtherInspectionStatus
// "INCOMPLETE", never PASS and not the UNKNOWN an undecided one gets; each form validates.
TEST(QifExport, PartStatusFollowsTheJobVerdict) {
  MeasurementResult r = inspected_result();
  const std::pair<Verdict, const char*> cases[] = {{Verdict::pass, "PASS"},
                                                   {Verdict::fail, "FAIL"},
                                                   {Verdict::undecided, "UNKNOWN"},
                                                   {Verdict::incomplete, "other INCOMPLETE"}};
  for (const auto& [verdict, status] : cases) {
    r.inspection->verdict = verdict;
    const std::string xml = to_qif(r, context());
    for (const std::string& block : blocks(xml, "InspectionStatus")) EXPECT_EQ(part_status_of(block), status);
    EXPECT_EQ(blocks(xml, "InspectionStatus").size(), 1u);
    EXPECT_EQ(part_status_of(blocks(xml, "ActualComponent").at(0)), status);
    expect_valid(xml, to_string(verdict));
  }
}

// A characteristic left out on purpose: there, EXCLUDED (free text), with the request's reason and no
// actual, even when its feature was measured.
TEST(QifExport, AnExcludedCharacteristicIsWrittenAsExcludedWithItsReason) {
  MeasurementResult r = inspected_result();
  r.inspection->edges[3].profile.verdict = Verdict::excluded;
  r.inspection->edges[3].reason = "standing on the plate";
  r.inspection->edges[0].profile.verdict = Verdict::excluded;
  r.inspection->edges[0].reason = "not asked for";
  r.inspection->edge_counts = {.pass = 0, .fail = 1, .undecided = 1, .not_measured = 0, .excluded = 2};
  const std::string xml = to_qif(r, context());
  expect_valid(xml, "excluded");
  expect_references_resolve(xml);
  const std::string left_out = measurement_of(xml, "PointProfile", "edge point 3 profile");
  EXPECT_EQ(status_of(left_out), "other EXCLUDED");
  EXPECT_NE(left_out.find("excluded: standing on the plate"), std::string::npos) << left_out;
  const std::string measured_but_not_asked = measurement_of(xml, "PointProfile", "edge point 0 profile");
  EXPECT_EQ(status_of(measured_but_not_asked), "other EXCLUDED");
  EXPECT_EQ(measured_but_not_asked.find("<Value"), std::string::npos) << "an excluded characteristic is not judged";
}

TEST(QifExport, EmptyResultAndEmptyContextStillValidate) {
  MeasurementResult r;
  const std::string xml = to_qif(r, QifContext{});
  expect_valid(xml, "empty");
  expect_references_resolve(xml);
  EXPECT_EQ(xml.find("<Features>"), std::string::npos);

  // A nominal whose every feature went unmeasured: characteristics, none with a value.
  MeasurementResult unmeasured = inspected_result();
  for (EdgeResult& e : unmeasured.edges) e.status = FeatureStatus::not_planned;
  for (HoleResult& h : unmeasured.holes) h.status = FeatureStatus::not_planned;
  unmeasured.inspection->verdict = Verdict::incomplete;
  const std::string none = to_qif(unmeasured, context());
  expect_valid(none, "unmeasured");
  expect_references_resolve(none);
  EXPECT_EQ(none.find("<MeasuredFeatures"), std::string::npos);
  EXPECT_EQ(none.find("<Value"), std::string::npos);
}

TEST(QifExport, RefusesBadTimeStampsAndNonFiniteNumbers) {
  QifContext c = context();
  c.started_utc = "yesterday";
  try {
    to_qif(inspected_result(), c);
    ADD_FAILURE() << "a bad time stamp was written";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("started_utc \"yesterday\""), std::string::npos) << e.what();
  }

  MeasurementResult r = inspected_result();
  r.edges[1].scan->position.x() = std::nan("");
  try {
    to_qif(r, context());
    ADD_FAILURE() << "a NaN was written";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("edge point 1: measured position"), std::string::npos) << e.what();
  }
}

TEST(QifExport, EachDocumentHasItsOwnUuid) {
  const std::string a = to_qif(inspected_result(), context()), b = to_qif(inspected_result(), context());
  const std::string id_a = between(a, "<QPId>", "</QPId>"), id_b = between(b, "<QPId>", "</QPId>");
  EXPECT_TRUE(std::regex_match(id_a, std::regex("[0-9a-f]{8}-[0-9a-f]{4}-4[0-9a-f]{3}-[89ab][0-9a-f]{3}-[0-9a-f]{12}"))) << id_a;
  EXPECT_NE(id_a, id_b);
}

}  // namespace
