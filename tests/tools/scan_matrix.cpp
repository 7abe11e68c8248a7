// scan-matrix: the scan front end on one part scanned every way (issue 36). For each part, sampling,
// noise level and seed it synthesizes a raw scan, loads it through the one reference-model loader (as
// cmm-plan and cmmd do), plans it, and holds the result against the truth: boundary loops = the borders
// of the seen region exactly, each loop running along its border (an unseen region narrower than the gap
// rule's reach closed, a seen speck left out), no non-manifold edge, every through hole found with its rim fitted, the
// mesh within ε + 3σ of the true surface (99th percentile), and the probeable share of the plan's points
// on the part's true sharp edges and rims (a border's points never are probeable; points off every true
// edge are folds of noise, counted apart) within 5 points of the same part's grid-scanned plan, where
// both plans have such points, over the stretches of edge both have points on. Prints a Markdown table; exits 1 when a check fails.
// SCAN_MATRIX_KEEP=1 keeps each cloud in the temp folder, for cmm-plan; SCAN_MATRIX_VERBOSE=1 lists each
// run's borders, loops and holes.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "geometry/analytic_parts.hpp"
#include "geometry/ball_sweep.hpp"
#include "geometry/mesh_io.hpp"
#include "geometry/point_grid.hpp"
#include "hal/description/machine_description.hpp"
#include "planner/measurement_plan.hpp"
#include "planner/reference_model.hpp"
#include "sim/raw_scan.hpp"
#include "sim/scan_borders.hpp"

namespace {

using namespace cmm;
using geometry::Vec3;

// A feature point this close to a true edge sample is on that edge (a noisy edge's reference points lie
// up to δ off it).
constexpr double kOnTrueEdgeMm = 0.5;

struct Case {
  std::string part, sampling;
  double sigma = 0;
  std::uint64_t seed = 1;
};

// What a border of the seen region asks of the mesh.
enum class Expect { open, closed, either };
const char* to_string(Expect e) { return e == Expect::open ? "open" : e == Expect::closed ? "a gap" : "either"; }

struct Outcome {
  std::size_t points = 0;
  double bin_mm = 0;
  std::size_t borders = 0, loops = 0, false_loops = 0, missed_borders = 0, non_manifold = 0;
  std::size_t holes_true = 0, holes_found = 0;
  double worst_radius_pct = 0, worst_centre_mm = 0;
  double off_border_pct = 0;  // the largest share of a border's loop more than 3 B off it
  double p99_mm = 0;
  std::size_t features = 0;           // plan points on a true sharp edge or rim (not border points)
  std::size_t spurious_features = 0;  // sharp-edge or rim points off every true edge
  double probeable = 0;               // share of `features`, %
  std::vector<std::pair<Vec3, bool>> on_edges;  // each of `features`: where, and whether probeable
  double seconds = 0;
  std::vector<std::string> failures;
};

sim::RawScanOptions scan_options(const Case& c, double spacing, double offset_mm, double strays) {
  sim::RawScanOptions o;
  o.spacing_mm = spacing;
  o.noise_sigma_mm = c.sigma;
  o.stray_fraction = strays;
  o.seed = c.seed;
  o.views = sim::views_with_offset(5, offset_mm, c.seed);
  if (c.sampling == "grid") {
    o.sampling = sim::ScanSampling::grid;
    o.noise_model = sim::ScanNoise::beam;
  } else if (c.sampling == "poisson") {
    o.sampling = sim::ScanSampling::poisson;
    o.noise_model = sim::ScanNoise::isotropic;
  } else if (c.sampling == "random") {
    o.sampling = sim::ScanSampling::random;
    o.noise_model = sim::ScanNoise::isotropic;
  } else if (c.sampling == "views") {
    // Overlapping partial views of different density, as a merge of several sessions gives.
    o.sampling = sim::ScanSampling::random;
    o.noise_model = sim::ScanNoise::isotropic;
    o.view_coverage = 0.8;
    o.view_density = {1.0, 0.4, 2.0, 0.7, 1.5};
  } else {
    throw std::invalid_argument("unknown sampling " + c.sampling + " (grid, random, poisson, views)");
  }
  return o;
}

// The distances of the mesh's vertices and facet centroids from the true surface.
double p99_distance(const geometry::TriangleMesh& mesh, const geometry::BallSweeper& truth) {
  std::vector<double> d;
  for (Eigen::Index v = 0; v < mesh.vertices.rows(); ++v) d.push_back(truth.closest_to_point(geometry::vertex(mesh, v)).distance);
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
    const Vec3 c = (geometry::vertex(mesh, mesh.faces(f, 0)) + geometry::vertex(mesh, mesh.faces(f, 1)) +
                    geometry::vertex(mesh, mesh.faces(f, 2))) / 3;
    d.push_back(truth.closest_to_point(c).distance);
  }
  if (d.empty()) return 0;
  const auto at = d.begin() + static_cast<std::ptrdiff_t>(0.99 * static_cast<double>(d.size() - 1));
  std::nth_element(d.begin(), at, d.end());
  return *at;
}

// A closed polyline resampled every `step` or closer, corners kept.
geometry::Points densified(const std::vector<Vec3>& corners, double step) {
  std::vector<Vec3> out;
  for (std::size_t i = 0; i < corners.size(); ++i) {
    const Vec3 &a = corners[i], &b = corners[(i + 1) % corners.size()];
    const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / step)));
    for (int k = 0; k < n; ++k) out.push_back(a + (b - a) * (static_cast<double>(k) / n));
  }
  geometry::Points p(static_cast<Eigen::Index>(out.size()), 3);
  for (std::size_t i = 0; i < out.size(); ++i) p.row(static_cast<Eigen::Index>(i)) = out[i].transpose();
  return p;
}

// Points projected down a hole border's axis onto the plane through its centre.
std::vector<Vec3> flattened(const std::vector<Vec3>& points, const sim::ScanBorder& border) {
  std::vector<Vec3> out;
  for (const Vec3& p : points) out.push_back(p - (p - border.centre).dot(border.mouth_axis) * border.mouth_axis);
  return out;
}

// The share of closed polyline a's length that lies within `reach` of closed polyline b.
double share_within(const std::vector<Vec3>& a, const std::vector<Vec3>& b, double reach) {
  if (a.empty() || b.empty()) return 0;
  const geometry::Points along_b = densified(b, reach / 4);
  const geometry::PointGrid grid(along_b, reach);
  double total = 0, near = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const Vec3 &p = a[i], &q = a[(i + 1) % a.size()];
    const double length = (q - p).norm();
    bool found = false;
    grid.for_each_within(0.5 * (p + q), reach, [&](int, double) { found = true; });
    total += length;
    near += found ? length : 0;
  }
  return total > 0 ? near / total : 0;
}

Outcome run(const Case& c, double spacing, double eps, double offset_mm, double strays, std::size_t max_points,
            const std::filesystem::path& dir) {
  const auto start = std::chrono::steady_clock::now();
  Outcome out;
  // Scanned and held against at 0.25 mm: a coarser scene's chords would be in the truth (a Ø3 hole
  // meshed at 1 mm is 10 chords, 0.05 mm inside its circle on average, 3 % of its radius).
  const geometry::AnalyticPart part = geometry::make_analytic_part(c.part, 0.25);
  sim::RawScanOptions options = scan_options(c, spacing, offset_mm, strays);
  sim::RawScan raw = sim::synthesize_raw_scan(part.mesh, options);
  // Fewer points than asked for: a coarser spacing, never a subset (a subset changes the sampling).
  while (max_points > 0 && static_cast<std::size_t>(raw.cloud.points.rows()) > max_points) {
    options.spacing_mm *= std::sqrt(static_cast<double>(raw.cloud.points.rows()) / static_cast<double>(max_points)) * 1.02;
    raw = sim::synthesize_raw_scan(part.mesh, options);
  }
  out.points = static_cast<std::size_t>(raw.cloud.points.rows());
  // A border round less than four sample spacings (an unseen facet or two of the scene's 0.25 mm
  // tessellation at the edge of a view) encloses no gap a scan at that spacing can show.
  std::vector<sim::ScanBorder> borders;
  for (const sim::ScanBorder& b : sim::scan_borders(part.mesh, options.views, sim::kDefaultMaxIncidenceDeg, raw.truth.coverage))
    if (b.perimeter_mm >= 4 * options.spacing_mm) borders.push_back(b);
  const std::filesystem::path file = dir / (c.part + "-" + c.sampling + ".ply");
  geometry::write_cloud(file, raw.cloud);

  const description::MachineDescription machine = description::default_machine();
  planner::ReferenceModelOptions model_options;
  model_options.scan.tolerance_mm = eps;
  const planner::ReferenceModel reference = planner::load_reference_model(file, machine.travel_box, model_options);
  if (!std::getenv("SCAN_MATRIX_KEEP")) std::filesystem::remove(file);
  const geometry::FeatureModel& model = reference.features;
  out.bin_mm = reference.inputs.scan ? reference.inputs.scan->bin_size_mm : 0;

  // What the gap rule (docs/scan.md, "Gap or opening") asks of each border: a void no more than 1.5 B
  // across from its middle to the seen surface is a gap the mesh closes (a loop there is a pinhole); one
  // more than 3 B is an opening that stays open; between, the local density decides (r*) and either is
  // right. A hole's void is its unseen region or its mouth, whichever is narrower (through a Ø3 hole the
  // unseen walls and underside run on, but the scan shows a void 1.5 mm wide). A seen speck less than a
  // bin across is no surface a mesh can keep.
  const double bin = out.bin_mm;
  const auto expected = [&](const sim::ScanBorder& b) {
    if (b.kind == geometry::LoopKind::outer) return b.seen_half_width_mm >= bin ? Expect::open : Expect::either;
    const double void_half_width = b.mouth_half_width_mm > 0 ? std::min(b.unseen_half_width_mm, b.mouth_half_width_mm) : b.unseen_half_width_mm;
    if (void_half_width <= 1.5 * bin) return Expect::closed;
    return void_half_width > 3 * bin ? Expect::open : Expect::either;
  };
  // Loops against the borders, one each, of the same kind: a loop is a border's when it runs along it —
  // 90 % of the border's length within 3 B of the loop (the gap rule's reach: the mesh need not follow
  // the border closer than a void it may leave) and half of the loop's within 3 B of the border (the rest
  // a ragged edge: notches of a sparsely seen face's fringe, reported as "off border"). Seen down its
  // axis when a hole's mouth is no more than 3 B in radius: its wall is a tube a bin-B mesh cannot bend
  // round, so the loop may lie on its rim where the border runs down the unmeshed wall.
  out.borders = static_cast<std::size_t>(std::count_if(borders.begin(), borders.end(), [&](const sim::ScanBorder& b) { return expected(b) == Expect::open; }));
  out.loops = model.loops.size();
  out.non_manifold = model.topology.non_manifold_edges;
  const double reach = 3 * bin;
  // How much of border b runs within reach of the loop, and of the loop within reach of b.
  const auto along = [&](const sim::ScanBorder& b, const std::vector<Vec3>& corners) {
    const bool narrow = b.mouth_half_width_mm > 0 && b.mouth_half_width_mm <= reach;
    const std::vector<Vec3> border = narrow ? flattened(b.points, b) : b.points;
    const std::vector<Vec3> loop = narrow ? flattened(corners, b) : corners;
    return std::make_pair(share_within(border, loop, reach), share_within(loop, border, reach));
  };
  std::vector<bool> matched(borders.size(), false);
  for (const geometry::BoundaryLoop& loop : model.loops) {
    std::vector<Vec3> corners;
    for (int v : loop.vertices) corners.push_back(geometry::vertex(reference.mesh, v));
    int best = -1;
    double best_score = 0, best_own = 0;
    for (std::size_t b = 0; b < borders.size(); ++b) {
      if (matched[b] || borders[b].kind != loop.kind) continue;
      const auto [cover, own] = along(borders[b], corners);
      if (cover >= 0.9 && own >= 0.5 && cover + own > best_score) best = static_cast<int>(b), best_score = cover + own, best_own = own;
    }
    if (best < 0 || expected(borders[static_cast<std::size_t>(best)]) == Expect::closed) {
      ++out.false_loops;
      continue;
    }
    matched[static_cast<std::size_t>(best)] = true;
    out.off_border_pct = std::max(out.off_border_pct, 100 * (1 - best_own));
  }
  for (std::size_t b = 0; b < borders.size(); ++b) out.missed_borders += !matched[b] && expected(borders[b]) == Expect::open;
  if (std::getenv("SCAN_MATRIX_VERBOSE")) {
    const auto kind = [](geometry::LoopKind k) { return k == geometry::LoopKind::hole ? "hole" : "outer"; };
    for (std::size_t b = 0; b < borders.size(); ++b)
      std::printf("border %s %.1f mm, half wide %.2f mm seen, %.2f unseen, mouth %.2f, at (%.2f %.2f %.2f), %s%s\n", kind(borders[b].kind),
                  borders[b].perimeter_mm, borders[b].seen_half_width_mm, borders[b].unseen_half_width_mm, borders[b].mouth_half_width_mm, borders[b].centre.x(),
                  borders[b].centre.y(), borders[b].centre.z(), to_string(expected(borders[b])), matched[b] ? "" : ": no loop");
    for (const geometry::BoundaryLoop& loop : model.loops) {
      const Vec3 centre = geometry::loop_centre(reference.mesh, loop.vertices);
      std::printf("loop %s %.1f mm at (%.2f %.2f %.2f)", kind(loop.kind), loop.perimeter, centre.x(), centre.y(), centre.z());
      std::vector<Vec3> corners;
      for (int v : loop.vertices) corners.push_back(geometry::vertex(reference.mesh, v));
      for (std::size_t b = 0; b < borders.size(); ++b) {
        const auto [cover, own] = along(borders[b], corners);
        if (cover > 0.2 || own > 0.2) std::printf("; along border %zu: %.0f %% of it, %.0f %% of the loop", b, 100 * cover, 100 * own);
      }
      std::printf("\n");
    }
    for (const geometry::Hole& h : model.holes)
      std::printf("hole %s r %.3f at (%.3f %.3f %.3f)\n", geometry::to_string(h.source), h.radius, h.centre.x(), h.centre.y(), h.centre.z());
  }

  // Through holes: a hole of the plan on the same axis line (within 0.2 mm) with the radius within 2 %;
  // not asked of a hole whose borders the gap rule lets the mesh close (a Ø3 hole at B 0.7 mm).
  for (const geometry::TrueHole& truth : part.holes) {
    bool bordered = false, open = false;
    for (const sim::ScanBorder& b : borders) {
      const Vec3 off = b.centre - truth.centre;
      if (b.kind != geometry::LoopKind::hole || (off - off.dot(truth.axis) * truth.axis).norm() > truth.radius) continue;
      bordered = true;
      open = open || expected(b) == Expect::open;
    }
    if (bordered && !open) continue;
    ++out.holes_true;
    double best_centre = 1e300, best_radius = 1e300;
    for (const geometry::Hole& h : model.holes) {
      const Vec3 off = h.centre - truth.centre;
      const double across = (off - off.dot(truth.axis) * truth.axis).norm();
      if (across < best_centre) best_centre = across, best_radius = 100 * std::abs(h.radius - truth.radius) / truth.radius;
    }
    if (best_centre <= 0.2 && best_radius <= 2) ++out.holes_found;
    out.worst_centre_mm = std::max(out.worst_centre_mm, std::min(best_centre, 99.0));
    out.worst_radius_pct = std::max(out.worst_radius_pct, std::min(best_radius, 99.0));
  }

  const geometry::BallSweeper truth(part.mesh);
  out.p99_mm = p99_distance(reference.mesh, truth);

  planner::PlanInputs inputs = reference.inputs;
  planner::settle_delta(inputs, 0.2, "scan-matrix", model);
  planner::MeasurementPlanOptions plan_options;
  plan_options.touch.radius = 1;
  plan_options.touch.delta = inputs.delta;
  const planner::MeasurementPlan plan = planner::plan_measurement(model, reference.mesh, Eigen::Isometry3d::Identity(), machine, plan_options);
  // Over the features on the part's true sharp edges and rims: a border's points are never probeable
  // (partial views have more border by construction), and a feature point off every true edge is a
  // fold of the noise, counted apart (the bicone scanned from above has its rim as its border, and its
  // few "features" are all such folds).
  std::size_t samples = 0;
  for (const geometry::TrueEdge& edge : part.sharp_edges) samples += edge.samples.size();
  geometry::Points on_edges(static_cast<Eigen::Index>(samples), 3);
  Eigen::Index row = 0;
  for (const geometry::TrueEdge& edge : part.sharp_edges)
    for (const geometry::TrueEdgeSample& sample : edge.samples) on_edges.row(row++) = sample.position.transpose();
  const geometry::PointGrid edge_grid(on_edges, kOnTrueEdgeMm);
  std::size_t probeable = 0;
  std::map<std::string, std::size_t> reasons;  // why on-edge points are not probeable (verbose)
  for (const planner::EdgePlan& e : plan.edges) {
    const geometry::EdgePoint& point = model.points[static_cast<std::size_t>(e.edge_point)];
    if (point.kind == geometry::EdgeKind::boundary) continue;
    bool on_edge = false;
    edge_grid.for_each_within(point.position, kOnTrueEdgeMm, [&](int, double) { on_edge = true; });
    if (!on_edge) {
      ++out.spurious_features;
      continue;
    }
    ++out.features;
    probeable += e.method != planner::EdgeMethod::none;
    out.on_edges.emplace_back(point.position, e.method != planner::EdgeMethod::none);
    if (e.method == planner::EdgeMethod::none) ++reasons[e.reason.substr(0, e.reason.find(':'))];
    if (e.method == planner::EdgeMethod::none && std::getenv("SCAN_MATRIX_VERBOSE") && std::string(std::getenv("SCAN_MATRIX_VERBOSE")) == "2")
      std::printf("  at (%.2f %.2f %.2f) %s: %s\n", point.position.x(), point.position.y(), point.position.z(), geometry::to_string(point.kind), e.reason.substr(0, 40).c_str());
  }
  if (std::getenv("SCAN_MATRIX_VERBOSE"))
    for (const auto& [reason, count] : reasons) std::printf("not probeable %zu: %s\n", count, reason.c_str());
  out.probeable = out.features == 0 ? 0 : 100.0 * static_cast<double>(probeable) / static_cast<double>(out.features);

  if (out.false_loops > 0) out.failures.push_back(std::to_string(out.false_loops) + " false loops");
  if (out.missed_borders > 0) out.failures.push_back(std::to_string(out.missed_borders) + " openings closed");
  if (out.non_manifold > 0) out.failures.push_back(std::to_string(out.non_manifold) + " non-manifold edges");
  if (out.holes_found < out.holes_true)
    out.failures.push_back(std::to_string(out.holes_true - out.holes_found) + " of " + std::to_string(out.holes_true) + " holes not found");
  if (out.p99_mm > eps + 3 * c.sigma) out.failures.push_back("p99 distance above eps + 3 sigma");
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

// The probeable shares of two plans over the stretches of true edge both have points on (within
// kCommonMm of one of the other's): where one scan saw an edge the other did not (a bore's lower rim that
// the grid's views saw and the partial views' bands missed), its points, probeable or blocked, say
// nothing of how the scan was sampled. {share of a, share of b}, %; NaN when nothing is common.
constexpr double kCommonMm = 1.0;
std::pair<double, double> common_shares(const std::vector<std::pair<Vec3, bool>>& a, const std::vector<std::pair<Vec3, bool>>& b) {
  const auto share_near = [](const std::vector<std::pair<Vec3, bool>>& of, const std::vector<std::pair<Vec3, bool>>& near) {
    if (near.empty()) return static_cast<double>(NAN);
    geometry::Points at(static_cast<Eigen::Index>(near.size()), 3);
    for (std::size_t i = 0; i < near.size(); ++i) at.row(static_cast<Eigen::Index>(i)) = near[i].first.transpose();
    const geometry::PointGrid grid(at, kCommonMm);
    std::size_t count = 0, probeable = 0;
    for (const auto& [position, ok] : of) {
      bool common = false;
      grid.for_each_within(position, kCommonMm, [&](int, double) { common = true; });
      if (common) ++count, probeable += ok;
    }
    return count == 0 ? static_cast<double>(NAN) : 100.0 * static_cast<double>(probeable) / static_cast<double>(count);
  };
  return {share_near(a, b), share_near(b, a)};
}

std::string format_one(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1f", value);
  return text;
}

std::vector<std::string> split(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("scan-matrix: the scan front end on parts scanned every way, held against the truth");
  std::string parts = "plate_small_openings,case3_block,bicone", samplings = "grid,random,poisson,views";
  std::string sigmas = "0,0.025,0.05", seeds = "1,2,3";
  double eps = 0.1, spacing = 0.25, offset = 0.02, strays = 0.005;
  std::size_t max_points = 0;
  app.add_option("--parts", parts, "analytic parts, comma-separated");
  app.add_option("--samplings", samplings, "grid, random, poisson, views (overlapping partial views of different density)");
  app.add_option("--sigmas", sigmas, "noise levels, mm");
  app.add_option("--seeds", seeds, "seeds");
  app.add_option("--tolerance", eps, "epsilon, mm");
  app.add_option("--spacing", spacing, "raw scan spacing, mm");
  app.add_option("--view-offset", offset, "each view's registration offset, mm");
  app.add_option("--stray-fraction", strays, "share of strays");
  app.add_option("--max-points", max_points, "coarsen the spacing until a scan has at most this many points (0: no limit)");
  CLI11_PARSE(app, argc, argv);

  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("scan-matrix-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::printf("| part | sampling | σ mm | seed | points | B mm | loops (borders) | false | closed | off border %% | non-manifold | holes found | radius err %% | centre mm | p99 mm | features (off true edges) | probeable %% | Δ grid pp | s | verdict |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  int failed = 0, total = 0;
  std::map<std::string, std::vector<std::pair<Vec3, bool>>> grid_points;
  for (const std::string& part : split(parts))
    for (const std::string& sigma : split(sigmas))
      for (const std::string& seed : split(seeds))
        for (const std::string& sampling : split(samplings)) {
          const Case c{part, sampling, std::stod(sigma), std::stoull(seed)};
          Outcome o = run(c, spacing, eps, offset, strays, max_points, dir);
          const std::string key = part + "/" + sigma + "/" + seed;
          if (sampling == "grid") grid_points[key] = o.on_edges;
          // No share to compare where either plan has no point on a true edge (the grid scan saw none).
          double delta = NAN;
          if (const auto it = grid_points.find(key); it != grid_points.end() && o.features > 0) {
            const auto [own, grid] = common_shares(o.on_edges, it->second);
            delta = own - grid;
          }
          if (std::abs(delta) > 5) o.failures.push_back("probeable share off the grid plan's by more than 5 points");
          const std::string delta_text = std::isnan(delta) ? "n/a" : (delta >= 0 ? "+" : "") + format_one(delta);
          std::string verdict = "pass";
          if (!o.failures.empty()) {
            verdict.clear();
            for (const std::string& f : o.failures) verdict += (verdict.empty() ? "" : "; ") + f;
            ++failed;
          }
          ++total;
          std::printf("| %s | %s | %.3g | %llu | %zu | %.3f | %zu (%zu) | %zu | %zu | %.0f | %zu | %zu/%zu | %.2f | %.3f | %.3f | %zu (%zu) | %.1f | %s | %.1f | %s |\n",
                      part.c_str(), sampling.c_str(), c.sigma, static_cast<unsigned long long>(c.seed), o.points, o.bin_mm,
                      o.loops, o.borders, o.false_loops, o.missed_borders, o.off_border_pct, o.non_manifold, o.holes_found, o.holes_true,
                      o.worst_radius_pct, o.worst_centre_mm, o.p99_mm, o.features, o.spurious_features, o.probeable,
                      delta_text.c_str(), o.seconds, verdict.c_str());
          std::fflush(stdout);
        }
  if (!std::getenv("SCAN_MATRIX_KEEP")) std::filesystem::remove_all(dir);
  std::printf("\n%d of %d runs meet every check\n", total - failed, total);
  return failed == 0 ? 0 : 1;
}
