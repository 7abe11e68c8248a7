// Renders the job report; see job_report.hpp and docs/report.md. Sections in print order: the job,
// machine and tip; the registration; the verdict; (new page) the colour map and the histogram;
// (new page) the feature table; the notes.
#include "planner/job_report.hpp"

#include <array>
#include <cctype>

#include "planner/deviation_colours.hpp"
#include "planner/deviation_histogram.hpp"
#include "planner/deviation_map.hpp"
#include "planner/html_text.hpp"
#include "planner/number_text.hpp"
#include "planner/png_image.hpp"
#include "planner/report_features.hpp"
#include "planner/report_style.hpp"
#include "planner/report_text.hpp"

namespace cmm::planner {

namespace {

const std::string kNone = "—";

std::string or_none(const std::string& text) { return text.empty() ? kNone : text; }

// A row of a two-column facts table; `html` is already escaped.
std::string fact(const char* name, const std::string& html) {
  return concat("<tr><th>", name, "</th><td>", html, "</td></tr>\n");
}

std::string job_section(const ReportInputs& in) {
  const ReportTip& tip = in.tip;
  const std::optional<description::TipQualification>& q = tip.qualification;
  std::string state = escape_html(or_none(in.state));
  if (!in.state_reason.empty()) state += concat(" (", escape_html(in.state_reason), ")");
  std::optional<std::string> nominal = in.nominal_model;
  if (!nominal && in.result.inspection) nominal = in.result.inspection->nominal.model;

  std::string html = "<section id=\"job\">\n<h2>Part, machine and tip</h2>\n<table class=\"facts\">\n";
  html += fact("Part", escape_html(or_none(in.job_name)));
  html += fact("Job", concat(std::to_string(in.job_id), ", ", state));
  html += fact("Date", concat(escape_html(or_none(in.finished_utc)), " <span class=\"small\">(submitted ",
                              escape_html(or_none(in.created_utc)), ")</span>"));
  html += fact("Station", escape_html(or_none(in.station)));
  html += fact("Reference model", escape_html(or_none(in.model)));
  html += fact("Nominal model", nominal ? escape_html(*nominal) : "none: deviations are against the scan");
  html += fact("Machine", concat(escape_html(or_none(in.machine.name)), " (driver ",
                                 escape_html(or_none(in.machine.driver)), ")"));
  html += fact("Travel box (M)", concat(report_point(in.machine.travel_box.min), " … ",
                                        report_point(in.machine.travel_box.max), " mm"));
  html += fact("Tip", escape_html(or_none(tip.id)));
  html += fact("Ball radius", concat("nominal ", report_mm(tip.nominal_ball_radius_mm), " mm; ",
                                     q ? concat("qualified ", report_mm(q->ball_radius_mm), " mm")
                                       : std::string("never qualified: the nominal radius was used")));
  html += fact("Tip offset (M)", concat(report_point(q ? q->offset : tip.nominal_offset), " mm",
                                        q ? " (qualified)" : " (nominal)"));
  if (q) {
    html += fact("Qualification", concat(escape_html(or_none(q->time_utc)), ", sphere fit residual RMS ",
                                         report_mm(q->residual_rms_mm), " mm over ", std::to_string(q->touches),
                                         " touches"));
  }
  html += fact("cmmd", escape_html(or_none(in.cmmd_version)));
  html += "</table>\n</section>\n";
  return html;
}

std::string registration_section(const ReportRegistration& r) {
  std::string html = "<section id=\"registration\">\n<h2>Registration</h2>\n<p>";
  html += r.method == "measured"   ? "The machine measured the base plate's corners"
          : r.method == "given"    ? "Corners given with the job"
                                   : concat("Method: ", escape_html(or_none(r.method)));
  html += concat("; RMS residual <b>", report_mm(r.rms_mm), " mm</b> over ", std::to_string(r.corners.size()),
                 " corners.</p>\n<div class=\"verdict-box keep\">\n");
  html += "<table class=\"grid\"><caption class=\"small\">T_M_S (scan → machine; rotation, translation mm)</caption>\n";
  for (int i = 0; i < 4; ++i) {
    html += "<tr>";
    for (int j = 0; j < 4; ++j) {
      const double v = r.T_M_S.matrix()(i, j);
      html += concat("<td class=\"num\">", j == 3 && i < 3 ? report_mm(v) : fixed(v, 6), "</td>");
    }
    html += "</tr>\n";
  }
  html += "</table>\n<table class=\"grid\"><thead><tr><th>Corner</th><th class=\"num\">Residual, mm</th></tr></thead>\n";
  for (const CornerResidual& c : r.corners) {
    html += concat("<tr><td>", std::to_string(c.id), "</td><td class=\"num\">", report_mm(c.residual_mm),
                   "</td></tr>\n");
  }
  html += "</table>\n</div>\n</section>\n";
  return html;
}

std::string counts_row(const char* name, const VerdictCounts& c) {
  return concat("<tr><th>", name, "</th><td class=\"num v-pass\">", std::to_string(c.pass),
                "</td><td class=\"num v-fail\">", std::to_string(c.fail), "</td><td class=\"num v-undecided\">",
                std::to_string(c.undecided), "</td><td class=\"num v-not-measured\">", std::to_string(c.not_measured),
                "</td><td class=\"num v-excluded\">", std::to_string(c.excluded), "</td></tr>\n");
}

std::string placement_text(const NominalPlacement& p) {
  if (p.method == "given") return "given in the scan's frame";
  if (p.method != "icp") return concat("placed by ", escape_html(p.method));
  return concat("best-fitted to the scan by point-to-plane ICP: ", std::to_string(p.iterations), " iterations, ",
                p.converged ? "converged" : "<b>not converged</b>", ", RMS ", report_mm(p.rms_mm), " mm, overlap ",
                fixed(100 * p.overlap, 1), " %");
}

std::string verdict_section(const MeasurementResult& result) {
  const ResultSummary& s = result.summary;
  std::string html = "<section id=\"verdict\">\n<h2>Verdict</h2>\n<div class=\"verdict-box keep\">\n";
  if (const auto& inspection = result.inspection) {
    std::string big = verdict_label(inspection->verdict);
    for (char& c : big) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    html += concat("<div class=\"verdict ", verdict_class(inspection->verdict), "\">", big, "</div>\n");
    html += "<table class=\"grid counts\"><thead><tr><th></th><th class=\"num\">pass</th><th class=\"num\">fail</th>"
            "<th class=\"num\">undecided</th><th class=\"num\">not measured</th><th class=\"num\">excluded</th></tr>"
            "</thead>\n";
    html += counts_row("Edge points", inspection->edge_counts);
    html += counts_row("Holes", inspection->hole_counts);
    html += "</table>\n</div>\n";
    // The verdict is only as good as what it covers: the coverage in words, and why features were left out.
    html += concat("<p class=\"coverage\">", escape_html(coverage_text(*inspection)), ".</p>\n");
    const Tolerances& t = inspection->tolerances;
    html += concat("<p>Against the nominal model ", escape_html(or_none(inspection->nominal.model)), ", ",
                   placement_text(inspection->nominal), ".</p>\n");
    html += concat("<p>Tolerances: edge profile ±", report_mm(t.edge_profile_mm), " mm (",
                   std::to_string(t.edge_point_profile_mm.size()), " edge point and ",
                   std::to_string(t.curve_profile_mm.size()), " curve overrides); hole diameter ",
                   report_zone(t.hole.diameter), " mm, position Ø ", report_mm(t.hole.position_mm), " mm (",
                   std::to_string(t.hole_overrides.size()), " hole overrides).</p>\n");
    html += concat("<p class=\"small\">Decision rule ISO 14253-1: pass when deviation ± U lies inside the "
                   "tolerance, fail when it lies wholly outside, undecided otherwise; U = k·√(σ² + u²) with k = ",
                   fixed(t.coverage_factor, 2), " and the machine's u = ", report_mm(t.machine_uncertainty_mm),
                   " mm. A hole counts once, by its worse characteristic. The part is incomplete, never pass, when a "
                   "feature it was asked to inspect was not measured; one left out on purpose is counted excluded.</p>\n");
  } else {
    html += "<div class=\"verdict v-none\">NO VERDICT</div>\n<p>No nominal: no verdict, deviations are against the "
            "scan.</p>\n</div>\n";
  }
  html += "<table class=\"facts\">\n";
  html += fact("Edge points", concat(std::to_string(s.edges_measured), " measured of ", std::to_string(s.edge_points),
                                     "; ", std::to_string(s.edges_failed), " failed, ",
                                     std::to_string(s.edges_not_planned), " not planned"));
  html += fact("Holes", concat(std::to_string(s.holes_measured), " measured of ", std::to_string(s.holes), "; ",
                               std::to_string(s.holes_failed), " failed, ", std::to_string(s.holes_not_planned),
                               " not planned"));
  if (s.edges_measured > 0) {
    html += fact("Against the scan", concat("edge deviation RMS ", report_mm(s.rms_deviation_mm), " mm, max ",
                                            report_mm(s.max_deviation_mm), " mm (E", std::to_string(s.max_deviation_id),
                                            "); largest σ ", report_mm(s.worst_sigma_mm), " mm (E",
                                            std::to_string(s.worst_sigma_id), ")"));
  }
  if (s.holes_measured > 0) {
    html += fact("Holes against the scan", concat("centre off the axis max ", report_mm(s.max_centre_deviation_mm),
                                                  " mm, diameter max ", report_mm(s.max_diameter_deviation_mm), " mm"));
  }
  html += "</table>\n</section>\n";
  return html;
}

// Colour bar of the map's scale: red ends (outside the tolerance) only against a nominal.
std::string legend_svg(bool inspected) {
  constexpr int kSteps = 40;
  constexpr double kLeft = 110, kWidth = 520, kTop = 8, kHeight = 18;
  std::string svg = "<svg class=\"legend\" xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 800 62\" "
                    "font-family=\"sans-serif\" font-size=\"11\" role=\"img\" aria-label=\"colour legend\">\n";
  auto box = [&](double x, double w, Rgb colour) {
    svg += concat("<rect x=\"", fixed(x, 1), "\" y=\"", fixed(kTop, 1), "\" width=\"", fixed(w + 0.3, 1),
                  "\" height=\"", fixed(kHeight, 1), "\" fill=\"", css_colour(colour), "\"/>\n");
  };
  auto label = [&](double x, const std::string& text) {
    svg += concat("<text x=\"", fixed(x, 1), "\" y=\"", fixed(kTop + kHeight + 14, 1), "\" text-anchor=\"middle\">",
                  text, "</text>\n");
  };
  for (int i = 0; i < kSteps; ++i) {
    box(kLeft + kWidth * i / kSteps, kWidth / kSteps, relative_colour(-1 + 2.0 * (i + 0.5) / kSteps));
  }
  const std::array<double, 5> ticks{-1, -0.5, 0, 0.5, 1};
  for (double t : ticks) {
    const std::string scale = inspected ? (t == 0 ? "0" : concat(t < 0 ? "−" : "+", t == -1 || t == 1 ? "" : "½", "T"))
                                        : (t == 0 ? "0" : report_signed_mm(t * kScanColourScaleMm));
    label(kLeft + kWidth * (t + 1) / 2, scale);
  }
  if (inspected) {
    box(kLeft - 60, 50, outside_colour());
    label(kLeft - 35, "below −T");
    box(kLeft + kWidth + 10, 50, outside_colour());
    label(kLeft + kWidth + 35, "above +T");
  }
  box(720, 50, not_measured_colour());
  label(745, "not measured");
  svg += concat("<text x=\"", fixed(kLeft + kWidth / 2, 1), "\" y=\"58\" text-anchor=\"middle\" fill=\"#555\">",
                inspected ? "deviation from the nominal; T: the point's tolerance limit on that side"
                          : "deviation against the scan, mm (beyond the scale: the end colours)",
                "</text>\n</svg>\n");
  return svg;
}

std::string picture_section(const ReportInputs& in) {
  const std::vector<MapPoint> points = deviation_map_points(in.result);
  const DeviationMap map = render_deviation_map(in.reference_mesh, points);
  const bool inspected = in.result.inspection.has_value();
  std::string html = concat(
      "<section id=\"map\" class=\"page-break\">\n<h2>Deviation colour map</h2>\n"
      "<img class=\"map\" width=\"", std::to_string(map.image.width), "\" height=\"", std::to_string(map.image.height),
      "\" alt=\"the reference model with the edge points coloured by deviation\" src=\"", png_data_uri(map.image),
      "\">\n", legend_svg(inspected));
  html += concat("<p class=\"small\">The reference model (scan frame S) seen from above, front right; ",
                 std::to_string(map.visible), " of ", std::to_string(points.size()),
                 " edge points are in view, the others lie behind the part from this side. ",
                 inspected ? "Colours: each measured point's deviation from the nominal against its own tolerance."
                           : "Colours: each measured point's deviation against the scan, on a fixed scale.",
                 in.reference_mesh ? "" : " No reference mesh was given: the points alone.", "</p>\n</section>\n");
  return html;
}

std::string histogram_section(const MeasurementResult& result) {
  std::vector<double> deviations;
  std::optional<ToleranceZone> limits;
  std::string caption;
  if (const auto& inspection = result.inspection) {
    for (const EdgeInspection& e : inspection->edges) {
      if (judged(e.profile.verdict)) deviations.push_back(e.profile.deviation_mm);
    }
    const double t = inspection->tolerances.edge_profile_mm;
    limits = ToleranceZone{-t, t};
    const std::size_t overrides =
        inspection->tolerances.edge_point_profile_mm.size() + inspection->tolerances.curve_profile_mm.size();
    caption = concat("Edge-point deviations from the nominal; the dashed lines are the edge profile tolerance ±",
                     report_mm(t), " mm", overrides ? " (points and curves with their own tolerance are coloured "
                                                      "by it in the map and the table)" : "",
                     ".");
  } else {
    for (const EdgeResult& e : result.edges) {
      if (e.status == FeatureStatus::measured) deviations.push_back(e.deviation.signed_mm);
    }
    caption = "Edge-point deviations against the scan (no nominal, no tolerance).";
  }
  return concat("<section id=\"histogram\" class=\"keep\">\n<h2>Histogram of deviations</h2>\n",
                deviation_histogram_svg(deviations, limits), "<p class=\"small\">", std::to_string(deviations.size()),
                " points. ", caption, "</p>\n</section>\n");
}

std::string notes_section(const ReportInputs& in) {
  std::string html = "<section id=\"notes\">\n<h2>Notes</h2>\n<ul>\n";
  for (const std::string& note : in.notes) html += concat("<li>", escape_html(note), "</li>\n");
  for (const std::string& note : in.result.notes) html += concat("<li>", escape_html(note), "</li>\n");
  html += concat("<li>Positions are in the scan's frame S, in mm; a positive edge deviation lies outside the "
                 "material. Probe: ball radius ", report_mm(in.result.ball_radius_mm), " mm, trigger σ ",
                 report_mm(in.result.trigger_sigma_mm), " mm.</li>\n");
  html += "</ul>\n</section>\n";
  return html;
}

}  // namespace

std::string render_report(const ReportInputs& in) {
  std::string html = concat("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>",
                            escape_html(concat("Job ", std::to_string(in.job_id), ": ", in.job_name)),
                            " — cmmd report</title>\n<style>", kReportStyle, "</style>\n</head>\n<body>\n");
  html += concat("<header>\n<h1>Measurement report</h1>\n<p class=\"subtitle\">", escape_html(or_none(in.job_name)),
                 " — job ", std::to_string(in.job_id), ", ", escape_html(or_none(in.finished_utc)),
                 "</p>\n</header>\n");
  html += job_section(in);
  html += registration_section(in.registration);
  html += verdict_section(in.result);
  html += picture_section(in);
  html += histogram_section(in.result);
  html += concat("<section id=\"features\" class=\"page-break\">\n<h2>Features</h2>\n", feature_table_html(in.result),
                 "</section>\n");
  html += notes_section(in);
  html += concat("<footer>Written by cmmd ", escape_html(or_none(in.cmmd_version)), ".</footer>\n</body>\n</html>\n");
  return html;
}

}  // namespace cmm::planner
