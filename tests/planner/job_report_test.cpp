// The job report on a small hand-made result (a cube, edge points that pass, fail, are undecided
// and not measured, one hole): the verdict and its counts, every feature row, escaped user text,
// an embedded PNG that is one (signature, IHDR size), and the report without a nominal.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <string>

#include "geometry/analytic_parts.hpp"
#include "planner/job_report.hpp"
#include "planner/report_text.hpp"

namespace cmm::planner {
namespace {

using geometry::Vec3;
using ::testing::HasSubstr;
using ::testing::Not;

std::string decode_base64(const std::string& text) {
  static const std::string kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  std::uint32_t bits = 0;
  int count = 0;
  for (char c : text) {
    if (c == '=') break;
    const std::size_t v = kAlphabet.find(c);
    if (v == std::string::npos) throw std::invalid_argument(std::string("not base64: ") + c);
    bits = (bits << 6) | static_cast<std::uint32_t>(v);
    count += 6;
    if (count >= 8) {
      count -= 8;
      out += static_cast<char>((bits >> count) & 0xff);
    }
  }
  return out;
}

std::uint32_t read_u32(const std::string& bytes, std::size_t at) {
  std::uint32_t v = 0;
  for (std::size_t i = 0; i < 4; ++i) v = (v << 8) | static_cast<std::uint8_t>(bytes.at(at + i));
  return v;
}

EdgeResult measured_edge(int id, const Vec3& at, double scan_deviation_mm) {
  EdgeResult e;
  e.id = id;
  e.method = EdgeMethod::two_touch;
  e.status = FeatureStatus::measured;
  e.reference = at;
  e.scan.emplace();
  e.scan->id = id;
  e.scan->frame = PointFrame::scan;
  e.scan->position = at + Vec3(0, -scan_deviation_mm, 0);
  e.deviation.signed_mm = scan_deviation_mm;
  return e;
}

EdgeInspection inspected(int id, double deviation_mm, double u_mm, Verdict verdict) {
  EdgeInspection e;
  e.id = id;
  e.nominal_S = Vec3(10.0 * id, 0, 40);
  e.profile = {.deviation_mm = deviation_mm, .uncertainty_mm = u_mm, .zone = {-0.1, 0.1}, .verdict = verdict};
  return e;
}

class JobReport : public ::testing::Test {
 protected:
  void SetUp() override {
    in.job_id = 42;
    in.job_name = "bracket <rev B> & \"quote\" <script>alert(1)</script>";
    in.state = "done";
    in.model = "sha256:abc";
    in.station = "station-3";
    in.cmmd_version = "0.1.0";
    in.created_utc = "2026-11-24T10:00:00Z";
    in.finished_utc = "2026-11-24T10:12:00Z";
    in.machine = {.driver = "sim", .name = "simulated CMM", .travel_box = {Vec3(0, 0, -300), Vec3(500, 400, 0)}};
    in.tip = {.id = "T1", .nominal_ball_radius_mm = 1.0,
              .qualification = description::TipQualification{.ball_radius_mm = 0.998512, .offset = Vec3(0, 0, -50),
                                                             .residual_rms_mm = 0.00042, .touches = 25,
                                                             .time_utc = "2026-11-24T09:00:00Z"}};
    in.registration = {.method = "measured", .corners = {{1, 0.0123}, {2, 0.0081}, {3, 0.0140}}, .rms_mm = 0.0117};
    in.reference_mesh = &cube.mesh;

    MeasurementResult& r = in.result;
    r.ball_radius_mm = 0.998512;
    r.edges = {measured_edge(1, Vec3(10, 0, 40), 0.004), measured_edge(2, Vec3(20, 0, 40), 0.21),
               measured_edge(3, Vec3(30, 0, 40), 0.097)};
    EdgeResult missing;
    missing.id = 4;
    missing.reference = Vec3(40, 20, 40);
    missing.reason = "no probe window: the face is too narrow";
    r.edges.push_back(missing);
    HoleResult hole;
    hole.id = 7;
    hole.status = FeatureStatus::measured;
    hole.nominal_centre = Vec3(20, 20, 40);
    hole.nominal_diameter_mm = 10;
    hole.scan.emplace();
    hole.scan->hole_id = 7;
    hole.scan->frame = PointFrame::scan;
    hole.scan->centre = Vec3(20.03, 20, 38);
    hole.scan->diameter_mm = 10.0125;
    hole.diameter_deviation_mm = 0.0125;
    hole.centre_deviation_mm = 0.03;
    r.holes.push_back(hole);
    r.summary = summarise(r.edges, r.holes);
    r.notes = {"touch 99 belongs to no feature"};

    InspectionResult inspection;
    inspection.nominal = {.model = "file:bracket_nominal.stl", .method = "icp", .iterations = 12, .rms_mm = 0.0031,
                          .overlap = 0.97};
    inspection.edges = {inspected(1, 0.0051, 0.0042, Verdict::pass), inspected(2, 0.2134, 0.0042, Verdict::fail),
                        inspected(3, 0.0981, 0.0042, Verdict::undecided), EdgeInspection()};
    inspection.edges.back().id = 4;
    inspection.edges.back().reason = "not measured: no probe window";
    HoleInspection h;
    h.id = 7;
    h.nominal_centre_S = Vec3(20, 20, 40);
    h.nominal_axis_S = Vec3::UnitZ();
    h.nominal_diameter_mm = 10;
    h.diameter = {.deviation_mm = 0.0125, .uncertainty_mm = 0.003, .zone = {-0.05, 0.05}, .verdict = Verdict::pass};
    h.position = {.deviation_mm = 0.06, .uncertainty_mm = 0.004, .zone = {0, 0.05}, .verdict = Verdict::fail};
    inspection.holes = {h};
    inspection.edge_counts = {.pass = 1, .fail = 1, .undecided = 1, .not_measured = 1};
    inspection.hole_counts = {.pass = 0, .fail = 1, .undecided = 0, .not_measured = 0};
    inspection.verdict = Verdict::fail;
    r.inspection = inspection;
  }

  geometry::AnalyticPart cube = geometry::make_cube(40, 4.0);
  ReportInputs in;
};

TEST_F(JobReport, HoldsTheVerdictAndEveryFeature) {
  const std::string html = render_report(in);
  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_THAT(html, HasSubstr("<div class=\"verdict v-fail\">FAIL</div>"));
  EXPECT_THAT(html, HasSubstr("<th>Edge points</th><td class=\"num v-pass\">1</td><td class=\"num v-fail\">1</td>"
                              "<td class=\"num v-undecided\">1</td><td class=\"num v-not-measured\">1</td>"));
  EXPECT_THAT(html, HasSubstr("<th>Holes</th><td class=\"num v-pass\">0</td><td class=\"num v-fail\">1</td>"));
  // What the verdict covers, in the words every output uses.
  EXPECT_THAT(html, HasSubstr("<p class=\"coverage\">3 of 4 inspected edge points measured (1 not measured), 1 of 1 "
                              "inspected holes measured.</p>"));
  // Edge rows: nominal, measured, deviation with its sign, tolerance, U and a coloured verdict.
  EXPECT_THAT(html, HasSubstr("<td>E1</td><td class=\"kind\">sharp edge, 2 touches</td><td class=\"num\">10.0000, 0.0000, 40.0000"
                              "</td><td class=\"num\">10.0000, -0.0040, 40.0000</td><td class=\"num\">+0.0051</td>"
                              "<td class=\"num\">±0.1000</td><td class=\"num\">0.0042</td>"
                              "<td class=\"verdict-cell v-pass\">pass</td>"));
  EXPECT_THAT(html, HasSubstr("<td class=\"num\">+0.2134</td><td class=\"num\">±0.1000</td><td class=\"num\">0.0042"
                              "</td><td class=\"verdict-cell v-fail\">fail</td>"));
  EXPECT_THAT(html, HasSubstr("<td class=\"num\">+0.0981</td><td class=\"num\">±0.1000</td><td class=\"num\">0.0042"
                              "</td><td class=\"verdict-cell v-undecided\">undecided</td>"));
  EXPECT_THAT(html, HasSubstr("<tr class=\"quiet\"><td>E4</td><td class=\"kind\">sharp edge</td><td class=\"num\">—</td>"
                              "<td>no probe window: the face is too narrow</td><td class=\"num\">—</td>"
                              "<td class=\"num\">—</td><td class=\"num\">—</td>"));
  EXPECT_THAT(html, HasSubstr("no probe window: the face is too narrow"));
  EXPECT_THAT(html, HasSubstr("<td class=\"verdict-cell v-not-measured\">not measured</td>"));
  // The hole: diameter and position rows.
  EXPECT_THAT(html, HasSubstr("<td>H7 Ø</td><td class=\"kind\">hole diameter</td><td class=\"num\">Ø 10.0000</td>"
                              "<td class=\"num\">Ø 10.0125</td><td class=\"num\">+0.0125</td>"
                              "<td class=\"num\">±0.0500</td>"));
  EXPECT_THAT(html, HasSubstr("<td>H7 position</td>"));
  EXPECT_THAT(html, HasSubstr("<td class=\"num\">+0.0600</td><td class=\"num\">Ø 0.0500</td><td class=\"num\">0.0040"
                              "</td><td class=\"verdict-cell v-fail\">fail</td>"));
  // Header, tip, registration.
  EXPECT_THAT(html, HasSubstr("station-3"));
  EXPECT_THAT(html, HasSubstr("qualified 0.9985 mm"));
  EXPECT_THAT(html, HasSubstr("sphere fit residual RMS 0.0004 mm over 25 touches"));
  EXPECT_THAT(html, HasSubstr("RMS residual <b>0.0117 mm</b> over 3 corners"));
  EXPECT_THAT(html, HasSubstr("<tr><td>3</td><td class=\"num\">0.0140</td></tr>"));
  EXPECT_THAT(html, HasSubstr("point-to-plane ICP: 12 iterations, converged"));
  EXPECT_THAT(html, HasSubstr("touch 99 belongs to no feature"));
  // Histogram with its limits; no script anywhere.
  EXPECT_THAT(html, HasSubstr("<svg class=\"histogram\""));
  EXPECT_THAT(html, HasSubstr("upper limit 0.1000"));
  EXPECT_THAT(html, Not(HasSubstr("<script")));
}

TEST(ReportText, LengthsInMillimetresWithMicrometresVisible) {
  EXPECT_EQ(report_mm(12.34564), "12.3456");
  EXPECT_EQ(report_mm(-0.00004), "0.0000");
  EXPECT_EQ(report_signed_mm(-0.00004), "+0.0000");
  EXPECT_EQ(report_signed_mm(-0.0012), "-0.0012");
  EXPECT_EQ(report_signed_mm(0.0012), "+0.0012");
  EXPECT_EQ(report_zone({-0.1, 0.1}), "±0.1000");
  EXPECT_EQ(report_zone({-0.05, 0.08}), "-0.0500 / +0.0800");
  EXPECT_EQ(report_point(Vec3(1, -2.5, 0.00001)), "1.0000, -2.5000, 0.0000");
}

TEST_F(JobReport, EscapesUserText) {
  const std::string html = render_report(in);
  EXPECT_THAT(html, Not(HasSubstr("<rev B>")));
  EXPECT_THAT(html, Not(HasSubstr("<script>")));
  EXPECT_THAT(html, HasSubstr("bracket &lt;rev B&gt; &amp; &quot;quote&quot; &lt;script&gt;alert(1)&lt;/script&gt;"));
}

TEST_F(JobReport, EmbedsTheColourMapAsAPng) {
  const std::string html = render_report(in);
  const std::string prefix = "src=\"data:image/png;base64,";
  const std::size_t at = html.find(prefix);
  ASSERT_NE(at, std::string::npos);
  const std::size_t from = at + prefix.size(), to = html.find('"', from);
  const std::string png = decode_base64(html.substr(from, to - from));
  ASSERT_GT(png.size(), 1000u);
  EXPECT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  EXPECT_EQ(png.substr(12, 4), "IHDR");
  EXPECT_EQ(read_u32(png, 16), 900u);
  EXPECT_EQ(read_u32(png, 20), 600u);
  EXPECT_EQ(png.substr(png.size() - 8, 4), "IEND");
}

TEST_F(JobReport, WithoutANominalSaysSoAndGivesNoVerdict) {
  in.result.inspection.reset();
  in.reference_mesh = nullptr;
  const std::string html = render_report(in);
  EXPECT_THAT(html, HasSubstr("NO VERDICT"));
  EXPECT_THAT(html, HasSubstr("No nominal: no verdict, deviations are against the scan."));
  EXPECT_THAT(html, Not(HasSubstr("verdict v-fail")));
  EXPECT_THAT(html, Not(HasSubstr("class=\"limit\"")));
  // The table holds the deviations against the scan and the status instead of a verdict.
  EXPECT_THAT(html, HasSubstr("Deviation vs scan"));
  EXPECT_THAT(html, HasSubstr("<td class=\"num\">+0.2100</td><td class=\"num\">—</td><td class=\"num\">—</td>"
                              "<td class=\"verdict-cell v-none\">measured</td>"));
  EXPECT_THAT(html, HasSubstr("<td class=\"verdict-cell v-not-measured\">not planned</td>"));
  EXPECT_THAT(html, HasSubstr("<td>H7 position</td><td class=\"kind\">hole centre offset</td>"));
  EXPECT_THAT(html, HasSubstr("No reference mesh was given"));
  EXPECT_THAT(html, HasSubstr("data:image/png;base64,"));
}

}  // namespace
}  // namespace cmm::planner
