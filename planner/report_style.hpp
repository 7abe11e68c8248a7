// The report's stylesheet: screen and print (A4, a page break before each big section, table
// headers repeated on every page, colours kept when printed).
#pragma once

namespace cmm::planner {

inline constexpr const char* kReportStyle = R"css(
* { -webkit-print-color-adjust: exact; print-color-adjust: exact; box-sizing: border-box; }
body { font-family: "DejaVu Sans", "Liberation Sans", Arial, sans-serif; font-size: 10pt; color: #111;
       max-width: 200mm; margin: 0 auto; padding: 8mm; line-height: 1.35; }
h1 { font-size: 18pt; margin: 0 0 2px 0; }
h2 { font-size: 13pt; border-bottom: 1px solid #888; margin: 1.3em 0 0.5em 0; padding-bottom: 2px; }
p.subtitle { margin: 0; color: #444; }
table { border-collapse: collapse; }
th, td { padding: 2px 6px; text-align: left; vertical-align: top; }
table.facts th { font-weight: normal; color: #555; padding-right: 14px; white-space: nowrap; }
td.num, th.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
table.grid td, table.grid th { border: 1px solid #ccc; }
table.grid thead th { background: #eee; }
table.features { width: 100%; font-size: 8pt; }
table.features thead th { background: #eee; border-bottom: 1px solid #888; }
table.features tbody tr { border-bottom: 1px solid #e2e2e2; }
table.features tr.quiet td { color: #777; }
table.features td.kind, table.features td:first-child { white-space: nowrap; }
.small { font-size: 8pt; color: #666; }
.verdict-box { display: flex; align-items: center; gap: 24px; margin: 6px 0 10px 0; }
.verdict { font-size: 40pt; font-weight: bold; letter-spacing: 0.06em; padding: 6px 22px; border-radius: 8px; }
td.verdict-cell { font-weight: bold; white-space: nowrap; }
.v-pass { background: #d4f5dc; color: #0f5c26; }
.v-fail { background: #f9cfd1; color: #a00d18; }
.v-undecided { background: #ffe3a8; color: #7a4a00; }
.v-not-measured { background: #e4e4e4; color: #555; }
.v-incomplete { background: #d9d2f0; color: #3d2a86; }
.v-excluded { background: #f4f4f4; color: #777; font-style: italic; }
.v-none { background: #eef1f5; color: #3b4756; }
img.map { width: 100%; height: auto; border: 1px solid #ccc; display: block; }
svg.legend, svg.histogram { width: 100%; height: auto; display: block; }
footer { margin-top: 2em; color: #777; font-size: 8pt; }
@page { size: A4; margin: 12mm 10mm 14mm 10mm; }
@media print {
  body { max-width: none; padding: 0; font-size: 9pt; }
  .page-break { break-before: page; }
  thead { display: table-header-group; }
  tr, img, svg, .keep { break-inside: avoid; }
  h2 { break-after: avoid; }
}
)css";

}  // namespace cmm::planner
