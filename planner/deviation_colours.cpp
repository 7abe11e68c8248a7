// Colour scales of the deviation map and histogram; see deviation_colours.hpp.
#include "planner/deviation_colours.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <utility>

namespace cmm::planner {

namespace {

Rgb mix(Rgb a, Rgb b, double t) {
  auto channel = [t](std::uint8_t x, std::uint8_t y) {
    return static_cast<std::uint8_t>(std::lround(x + (static_cast<double>(y) - x) * t));
  };
  return {channel(a.r, b.r), channel(a.g, b.g), channel(a.b, b.b)};
}

constexpr double kMeasuredRadiusPx = 4.5, kNotMeasuredRadiusPx = 2.5;

}  // namespace

double relative_deviation(double deviation_mm, const ToleranceZone& zone) {
  const double limit = deviation_mm >= 0 ? zone.upper_mm : -zone.lower_mm;
  if (limit > 0) return deviation_mm / limit;
  if (deviation_mm == 0 && (zone.upper_mm == 0 || zone.lower_mm == 0)) return 0;
  return deviation_mm >= 0 ? std::numeric_limits<double>::infinity() : -std::numeric_limits<double>::infinity();
}

Rgb relative_colour(double relative) {
  // Stops at −1, −½, 0, +½, +1: green stays green to half the limit.
  static constexpr std::array<Rgb, 5> kStops{{{40, 80, 210}, {0, 170, 205}, {40, 170, 70}, {235, 200, 0}, {245, 120, 0}}};
  if (std::isnan(relative)) return not_measured_colour();
  const double t = (std::clamp(relative, -1.0, 1.0) + 1) * 2;  // 0 … 4
  const int i = std::min(3, static_cast<int>(t));
  return mix(kStops[i], kStops[i + 1], t - i);
}

Rgb outside_colour() { return {215, 25, 35}; }
Rgb not_measured_colour() { return {150, 150, 150}; }

Rgb tolerance_colour(double deviation_mm, const ToleranceZone& zone) {
  if (deviation_mm > zone.upper_mm || deviation_mm < zone.lower_mm) return outside_colour();
  return relative_colour(relative_deviation(deviation_mm, zone));
}

Rgb scan_colour(double deviation_mm, double scale_mm) {
  return relative_colour(scale_mm > 0 ? deviation_mm / scale_mm : 0);
}

std::string css_colour(Rgb colour) {
  char text[8];
  std::snprintf(text, sizeof text, "#%02x%02x%02x", colour.r, colour.g, colour.b);
  return text;
}

std::vector<MapPoint> deviation_map_points(const MeasurementResult& result) {
  std::map<int, const EdgeInspection*> nominal;
  if (result.inspection) {
    for (const EdgeInspection& e : result.inspection->edges) nominal[e.id] = &e;
  }
  std::vector<std::pair<double, MapPoint>> keyed;  // (drawing order, point)
  keyed.reserve(result.edges.size());
  for (const EdgeResult& e : result.edges) {
    const bool measured = e.status == FeatureStatus::measured && e.scan;
    const EdgeInspection* inspected = nullptr;
    if (result.inspection) {
      const auto it = nominal.find(e.id);
      if (it != nominal.end() && judged(it->second->profile.verdict)) inspected = it->second;
    }
    if (!measured || (result.inspection && !inspected)) {
      keyed.push_back({-1, {measured ? e.scan->position : e.reference, not_measured_colour(), kNotMeasuredRadiusPx}});
      continue;
    }
    double order = 0;
    Rgb colour;
    if (inspected) {
      const Characteristic& c = inspected->profile;
      order = std::abs(relative_deviation(c.deviation_mm, c.zone));
      colour = tolerance_colour(c.deviation_mm, c.zone);
    } else {
      order = std::abs(e.deviation.signed_mm);
      colour = scan_colour(e.deviation.signed_mm);
    }
    keyed.push_back({order, {e.scan->position, colour, kMeasuredRadiusPx}});
  }
  std::stable_sort(keyed.begin(), keyed.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<MapPoint> points;
  points.reserve(keyed.size());
  for (auto& [order, point] : keyed) points.push_back(point);
  return points;
}

}  // namespace cmm::planner
