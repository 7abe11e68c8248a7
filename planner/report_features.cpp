// The feature table of the job report; see report_features.hpp.
#include "planner/report_features.hpp"

#include <map>
#include <optional>

#include "planner/html_text.hpp"
#include "planner/report_text.hpp"

namespace cmm::planner {

namespace {

const std::string kNone = "—";

std::string words(const char* identifier) {  // "sharp_edge" → "sharp edge"
  std::string text = identifier;
  for (char& c : text) c = c == '_' ? ' ' : c;
  return text;
}

struct Row {
  std::string feature, kind, nominal, measured, deviation, tolerance, uncertainty;
  std::string verdict_text, verdict_css;
  bool quiet = false;  // not measured: greyed

  std::string html() const {
    return concat("<tr", quiet ? " class=\"quiet\"" : "", "><td>", escape_html(feature), "</td><td class=\"kind\">",
                  escape_html(kind), "</td><td class=\"num\">", escape_html(nominal), "</td><td",
                  quiet ? ">" : " class=\"num\">", escape_html(measured), "</td><td class=\"num\">",
                  escape_html(deviation), "</td><td class=\"num\">", escape_html(tolerance), "</td><td class=\"num\">",
                  escape_html(uncertainty), "</td><td class=\"verdict-cell ", verdict_css, "\">",
                  escape_html(verdict_text), "</td></tr>\n");
  }
};

void set_characteristic(Row& row, const Characteristic& c, const std::string& tolerance) {
  if (c.zone != ToleranceZone{}) row.tolerance = tolerance;  // an empty zone: none was decided on
  row.verdict_text = verdict_label(c.verdict);
  row.verdict_css = verdict_class(c.verdict);
  if (!judged(c.verdict)) return;
  row.deviation = report_signed_mm(c.deviation_mm);
  row.uncertainty = report_mm(c.uncertainty_mm);
}

Row edge_row(const EdgeResult& e, const EdgeInspection* nominal, bool inspected) {
  Row row{.feature = concat("E", std::to_string(e.id)),
          .kind = concat(words(geometry::to_string(e.kind)), e.method == EdgeMethod::two_touch ? ", 2 touches"
                                                             : e.method == EdgeMethod::faces   ? ", faces"
                                                                                               : ""),
          .nominal = report_point(e.reference),
          .measured = e.scan ? report_point(e.scan->position) : e.reason,
          .deviation = kNone, .tolerance = kNone, .uncertainty = kNone,
          .verdict_text = words(to_string(e.status)), .verdict_css = "v-none"};
  row.quiet = !e.scan;
  if (!inspected) {
    if (e.scan) row.deviation = report_signed_mm(e.deviation.signed_mm);
    if (e.status != FeatureStatus::measured) row.verdict_css = "v-not-measured";
    return row;
  }
  row.nominal = nominal && nominal->nominal_S ? report_point(*nominal->nominal_S) : kNone;
  if (!nominal) {
    row.verdict_text = verdict_label(Verdict::not_measured);
    row.verdict_css = verdict_class(Verdict::not_measured);
    return row;
  }
  set_characteristic(row, nominal->profile, report_zone(nominal->profile.zone));
  if (!judged(nominal->profile.verdict) && !nominal->reason.empty() && e.scan) {
    row.measured = concat(row.measured, " (", nominal->reason, ")");
  }
  return row;
}

void hole_rows(const HoleResult& h, const HoleInspection* nominal, bool inspected, std::string& out) {
  const std::string id = concat("H", std::to_string(h.id));
  const std::optional<BoreMeasurement>& bore = h.scan;
  Row diameter{.feature = concat(id, " Ø"), .kind = "hole diameter",
               .nominal = concat("Ø ", report_mm(h.nominal_diameter_mm)),
               .measured = bore ? concat("Ø ", report_mm(bore->diameter_mm)) : h.reason,
               .deviation = kNone, .tolerance = kNone, .uncertainty = kNone,
               .verdict_text = words(to_string(h.status)), .verdict_css = "v-none", .quiet = !bore};
  Row position{.feature = concat(id, " position"), .kind = inspected ? "hole position (zone Ø)" : "hole centre offset",
               .nominal = report_point(h.nominal_centre),
               .measured = bore ? report_point(bore->centre) : std::string(kNone),
               .deviation = kNone, .tolerance = kNone, .uncertainty = kNone,
               .verdict_text = diameter.verdict_text, .verdict_css = "v-none", .quiet = !bore};
  if (!inspected) {
    if (bore) {
      diameter.deviation = report_signed_mm(h.diameter_deviation_mm);
      position.deviation = report_mm(h.centre_deviation_mm);
    }
    if (h.status != FeatureStatus::measured) diameter.verdict_css = position.verdict_css = "v-not-measured";
  } else if (!nominal) {
    diameter.verdict_text = position.verdict_text = verdict_label(Verdict::not_measured);
    diameter.verdict_css = position.verdict_css = verdict_class(Verdict::not_measured);
  } else {
    diameter.nominal = concat("Ø ", report_mm(nominal->nominal_diameter_mm));
    position.nominal = nominal->nominal_centre_S ? report_point(*nominal->nominal_centre_S) : kNone;
    set_characteristic(diameter, nominal->diameter, report_zone(nominal->diameter.zone));
    set_characteristic(position, nominal->position, concat("Ø ", report_mm(nominal->position.zone.upper_mm)));
  }
  out += diameter.html();
  out += position.html();
}

}  // namespace

std::string feature_table_html(const MeasurementResult& result) {
  const bool inspected = result.inspection.has_value();
  std::map<int, const EdgeInspection*> edge_nominal;
  std::map<int, const HoleInspection*> hole_nominal;
  if (inspected) {
    for (const EdgeInspection& e : result.inspection->edges) edge_nominal[e.id] = &e;
    for (const HoleInspection& h : result.inspection->holes) hole_nominal[h.id] = &h;
  }
  std::string html = concat(
      "<table class=\"features\">\n<thead><tr><th>Feature</th><th>Kind</th><th class=\"num\">",
      inspected ? "Nominal" : "Reference (scan)", " x, y, z / Ø</th><th class=\"num\">Measured x, y, z / Ø</th>",
      "<th class=\"num\">", inspected ? "Deviation" : "Deviation vs scan",
      "</th><th class=\"num\">Tolerance</th><th class=\"num\">U</th><th>", inspected ? "Verdict" : "Status",
      "</th></tr></thead>\n<tbody>\n");
  for (const EdgeResult& e : result.edges) {
    const auto it = edge_nominal.find(e.id);
    html += edge_row(e, it == edge_nominal.end() ? nullptr : it->second, inspected).html();
  }
  for (const HoleResult& h : result.holes) {
    const auto it = hole_nominal.find(h.id);
    hole_rows(h, it == hole_nominal.end() ? nullptr : it->second, inspected, html);
  }
  html += "</tbody>\n</table>\n";
  return html;
}

}  // namespace cmm::planner
