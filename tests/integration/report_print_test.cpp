// The job report in a real browser: headless Chromium opens a report of a synthetic inspection of
// the case3 block (hundreds of edge points, its holes) and prints it to PDF; the PDF must come out
// whole, over several A4 pages. Release build only: it skips itself under the sanitizers and with
// CMMD_BROWSER_TESTS off (the browser is not ours to sanitize, and it takes seconds).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <random>
#include <regex>
#include <sstream>

#include "child_process.hpp"
#include "geometry/analytic_parts.hpp"
#include "planner/job_report.hpp"
#include "scratch_folder.hpp"

namespace cmm::planner {
namespace {

namespace fs = std::filesystem;
using geometry::Vec3;

// A finished job on the case3 block: a point every 3 mm along its true sharp edges is an edge point,
// most within ±0.1 mm of the nominal, a few outside or straddling the limit, every 10th not
// measured; its five holes, one out of position.
ReportInputs synthetic_job(const geometry::AnalyticPart& part) {
  ReportInputs in;
  in.job_id = 7;
  in.job_name = "case3 block <print test> & co";
  in.state = "done";
  in.model = "file:case3_block.ply";
  in.nominal_model = "file:case3_block_nominal.stl";
  in.station = "test station";
  in.cmmd_version = "test";
  in.created_utc = "2026-11-24T10:00:00Z";
  in.finished_utc = "2026-11-24T10:12:34Z";
  in.machine = {.driver = "sim", .name = "simulated CMM", .travel_box = {Vec3(0, 0, -400), Vec3(600, 500, 0)}};
  in.tip = {.id = "T1", .nominal_ball_radius_mm = 2.5,
            .qualification = description::TipQualification{.ball_radius_mm = 2.4987, .residual_rms_mm = 0.0004,
                                                           .touches = 25, .time_utc = "2026-11-24T09:58:00Z"}};
  in.registration = {.method = "measured", .corners = {{1, 0.011}, {2, 0.009}, {3, 0.013}, {4, 0.012}},
                     .rms_mm = 0.0114};
  in.reference_mesh = &part.mesh;

  std::mt19937_64 rng(18);
  std::normal_distribution<double> noise(0, 0.03);
  MeasurementResult& r = in.result;
  InspectionResult inspection;
  inspection.nominal = {.model = *in.nominal_model, .method = "given"};
  const ToleranceZone zone{-0.1, 0.1};
  int id = -1;
  for (const geometry::TrueEdge& edge : part.sharp_edges) {
    Vec3 last = Vec3::Constant(1e9);
    for (const geometry::TrueEdgeSample& sample : edge.samples) {
      const Vec3 at = sample.position;
      if ((at - last).norm() < 3) continue;
      last = at;
      ++id;
      EdgeResult e;
      e.id = id;
      e.reference = at;
      e.method = EdgeMethod::two_touch;
      EdgeInspection nominal;
      nominal.id = id;
      nominal.nominal_S = at;
      if (id % 10 == 9) {
        e.reason = "no probe window";
        nominal.reason = "not measured";
        ++inspection.edge_counts.not_measured;
      } else {
        const double deviation = id % 17 == 0 ? 0.15 + 0.01 * (id % 3) : noise(rng);
        e.status = FeatureStatus::measured;
        e.scan.emplace();
        e.scan->id = id;
        e.scan->frame = PointFrame::scan;
        e.scan->position = at;
        e.deviation.signed_mm = deviation + 0.01;
        const double u = 0.004;
        const Verdict verdict = std::abs(deviation) + u <= 0.1   ? Verdict::pass
                                : std::abs(deviation) - u > 0.1 ? Verdict::fail
                                                                 : Verdict::undecided;
        nominal.profile = {.deviation_mm = deviation, .uncertainty_mm = u, .zone = zone, .verdict = verdict};
        ++(verdict == Verdict::pass ? inspection.edge_counts.pass
           : verdict == Verdict::fail ? inspection.edge_counts.fail
                                      : inspection.edge_counts.undecided);
      }
      r.edges.push_back(e);
      inspection.edges.push_back(nominal);
    }
  }
  for (std::size_t k = 0; k < part.holes.size(); ++k) {
    const geometry::TrueHole& true_hole = part.holes[k];
    HoleResult h;
    h.id = static_cast<int>(k);
    h.status = FeatureStatus::measured;
    h.nominal_centre = true_hole.centre;
    h.nominal_diameter_mm = 2 * true_hole.radius;
    const double off = k == 2 ? 0.08 : 0.01;
    h.scan.emplace();
    h.scan->hole_id = h.id;
    h.scan->frame = PointFrame::scan;
    h.scan->centre = true_hole.centre + Vec3(off, 0, 0);
    h.scan->diameter_mm = 2 * true_hole.radius + 0.004;
    h.diameter_deviation_mm = 0.004;
    h.centre_deviation_mm = off;
    r.holes.push_back(h);
    HoleInspection hi;
    hi.id = h.id;
    hi.nominal_centre_S = true_hole.centre;
    hi.nominal_axis_S = true_hole.axis;
    hi.nominal_diameter_mm = h.nominal_diameter_mm;
    hi.diameter = {.deviation_mm = 0.004, .uncertainty_mm = 0.003, .zone = {-0.05, 0.05}, .verdict = Verdict::pass};
    hi.position = {.deviation_mm = 2 * off, .uncertainty_mm = 0.004, .zone = {0, 0.1},
                   .verdict = k == 2 ? Verdict::fail : Verdict::pass};
    ++(k == 2 ? inspection.hole_counts.fail : inspection.hole_counts.pass);
    inspection.holes.push_back(hi);
  }
  inspection.verdict = Verdict::fail;
  r.summary = summarise(r.edges, r.holes);
  r.inspection = inspection;
  return in;
}

TEST(ReportPrint, ChromiumPrintsTheReportToPdf) {
#if defined(CMMD_SANITIZED) || defined(CMMD_NO_BROWSER_TESTS)
  GTEST_SKIP() << "the browser tests run in the release build only (CMMD_BROWSER_TESTS)";
#endif
  const fs::path chromium = "/usr/bin/chromium";
  ASSERT_TRUE(fs::exists(chromium)) << "chromium is missing: scripts/setup installs it";
  testing::ScratchFolder scratch("report_print", "pdf");
  const geometry::AnalyticPart part = geometry::make_case3_block(3.0);
  const ReportInputs inputs = synthetic_job(part);
  ASSERT_GT(inputs.result.edges.size(), 200u);
  const fs::path html = scratch.path / "report.html", pdf = scratch.path / "report.pdf";
  std::ofstream(html) << render_report(inputs);

  // timeout(1) signals its whole process group: the browser's helpers go with it.
  const auto start = std::chrono::steady_clock::now();
  cmm::testing::ChildProcess browser(
      {"/usr/bin/timeout", "-k", "10", "120", chromium.string(), "--headless", "--no-sandbox", "--disable-gpu",
       "--disable-dev-shm-usage", "--no-first-run", "--no-default-browser-check", "--disable-extensions",
       "--user-data-dir=" + (scratch.path / "profile").string(), "--no-pdf-header-footer",
       "--print-to-pdf=" + pdf.string(), "file://" + html.string()},
      /*with_stderr=*/true);
  std::string log;
  try {
    for (;;) log += browser.read_line(150) + '\n';
  } catch (const std::runtime_error&) {
    // its output closed: the browser has exited (or timeout(1) ended it)
  }
  const int status = browser.wait();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_EQ(status, 0) << "chromium exited " << status << " after " << seconds << " s:\n" << log;

  ASSERT_TRUE(fs::exists(pdf)) << log;
  std::ifstream file(pdf, std::ios::binary);
  std::stringstream bytes;
  bytes << file.rdbuf();
  const std::string content = bytes.str();
  EXPECT_EQ(content.rfind("%PDF", 0), 0u);
  EXPECT_GT(content.size(), 20'000u);
  // Page objects: the summary, the map and histogram, the feature table over a few more.
  const std::regex page("/Type\\s*/Page\\b(?!s)");
  const auto pages = std::distance(std::sregex_iterator(content.begin(), content.end(), page), std::sregex_iterator());
  EXPECT_GE(pages, 4) << "pages counted in " << pdf;
  std::cout << "report.pdf: " << content.size() << " bytes, " << pages << " pages, " << seconds << " s\n";
}

}  // namespace
}  // namespace cmm::planner
