// SVG histogram of deviations; see deviation_histogram.hpp.
#include "planner/deviation_histogram.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "planner/deviation_colours.hpp"
#include "planner/html_text.hpp"
#include "planner/number_text.hpp"

namespace cmm::planner {

namespace {

constexpr double kWidth = 800, kHeight = 300;
constexpr double kLeft = 50, kRight = 20, kTop = 24, kBottom = 44;  // plot margins

std::string text(double x, double y, const char* anchor, const std::string& content, const std::string& extra = "") {
  return concat("<text x=\"", fixed(x, 1), "\" y=\"", fixed(y, 1), "\" text-anchor=\"", anchor, "\"", extra, ">",
                content, "</text>\n");
}

std::string line(double x0, double y0, double x1, double y1, const std::string& style) {
  return concat("<line x1=\"", fixed(x0, 1), "\" y1=\"", fixed(y0, 1), "\" x2=\"", fixed(x1, 1), "\" y2=\"",
                fixed(y1, 1), "\" ", style, "/>\n");
}

std::string rect(double x, double y, double w, double h, const std::string& style, const std::string& content = "") {
  return concat("<rect x=\"", fixed(x, 1), "\" y=\"", fixed(y, 1), "\" width=\"", fixed(w, 1), "\" height=\"",
                fixed(h, 1), "\" ", style, ">", content, "</rect>\n");
}

}  // namespace

std::string deviation_histogram_svg(const std::vector<double>& deviations_mm,
                                    const std::optional<ToleranceZone>& limits, int bins) {
  bins = std::max(bins, 1);
  std::string svg = concat("<svg class=\"histogram\" xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 ",
                           fixed(kWidth, 0), " ", fixed(kHeight, 0),
                           "\" role=\"img\" aria-label=\"histogram of deviations\" font-family=\"sans-serif\" "
                           "font-size=\"11\">\n");
  const double plot_w = kWidth - kLeft - kRight, plot_h = kHeight - kTop - kBottom;
  const double base_y = kTop + plot_h;
  svg += rect(kLeft, kTop, plot_w, plot_h, "fill=\"none\" stroke=\"#999\"");
  if (deviations_mm.empty()) {
    svg += text(kWidth / 2, kTop + plot_h / 2, "middle", "no measured deviations");
    svg += "</svg>\n";
    return svg;
  }

  double reach = 0;
  for (double d : deviations_mm) {
    if (std::isfinite(d)) reach = std::max(reach, std::abs(d));
  }
  if (limits) reach = std::max({reach, 1.2 * std::abs(limits->lower_mm), 1.2 * std::abs(limits->upper_mm)});
  else reach = std::max(reach, kScanColourScaleMm);
  reach = std::max(reach * 1.05, 1e-4);
  const double bin_width = 2 * reach / bins;
  std::vector<int> counts(bins, 0);
  for (double d : deviations_mm) {
    if (std::isfinite(d)) ++counts[std::clamp(static_cast<int>(std::floor((d + reach) / bin_width)), 0, bins - 1)];
  }
  const int highest = std::max(1, *std::max_element(counts.begin(), counts.end()));
  auto x_of = [&](double mm) { return kLeft + (mm + reach) / (2 * reach) * plot_w; };

  for (int i = 0; i < bins; ++i) {
    if (counts[i] == 0) continue;
    const double from = -reach + i * bin_width, centre = from + bin_width / 2, h = plot_h * counts[i] / highest;
    const Rgb colour = limits ? tolerance_colour(centre, *limits) : scan_colour(centre);
    svg += rect(x_of(from) + 0.5, base_y - h, std::max(plot_w / bins - 1, 0.5), h,
                concat("fill=\"", css_colour(colour), "\""),
                concat("<title>", std::to_string(counts[i]), " between ", fixed(from, 4), " and ",
                       fixed(from + bin_width, 4), " mm</title>"));
  }
  for (int k = -2; k <= 2; ++k) {  // ticks at 0, ±reach/2, ±reach
    const double mm = reach * k / 2, x = x_of(mm);
    svg += line(x, base_y, x, base_y + 5, "stroke=\"#555\"");
    svg += text(x, base_y + 18, "middle", fixed(mm, 4));
  }
  svg += text(kLeft + plot_w / 2, kHeight - 6, "middle",
              limits ? "deviation from the nominal, mm" : "deviation against the scan, mm");
  svg += text(kLeft - 6, kTop + 4, "end", std::to_string(highest));
  svg += text(kLeft - 6, base_y, "end", "0");
  if (limits) {
    const std::string red = css_colour(outside_colour());
    for (const auto& [mm, name] : {std::pair{limits->lower_mm, "lower"}, std::pair{limits->upper_mm, "upper"}}) {
      const double x = x_of(mm);
      svg += line(x, kTop, x, base_y,
                  concat("class=\"limit\" stroke=\"", red, "\" stroke-width=\"2\" stroke-dasharray=\"6 3\""));
      svg += text(x, kTop - 6, "middle", concat(name, " limit ", fixed(mm, 4)), concat(" fill=\"", red, "\""));
    }
  }
  svg += "</svg>\n";
  return svg;
}

}  // namespace cmm::planner
