// The scan front end (issue 16) on raw scans of the case-3 block at about 300k and 1M points
// (sim::synthesize_raw_scan, σ 0.05 mm along the beam, 0.2 % strays): thinning with the quadric
// fits, the region-growing triangulation of the thinned cloud, and the whole mesh_scan.
// bench/compare_scan.py runs it beside Open3D and PCL for docs/PERFORMANCE.md.
//
// Besides the benchmarks, two modes that run before Google Benchmark sees the arguments:
//   scan_bench --dump=DIR           writes per size the raw cloud, the thinned cloud (PLY and PCD with
//                                   the fitted normals), our mesh, an info file (bin size, counts, the
//                                   scan's true borders), and the true block's mesh, into DIR;
//   scan_bench --stage=S --cloud=F  reads the raw cloud F, prepares what stage S takes, resets the
//                                   process's peak RSS (/proc/self/clear_refs) and runs S once:
//                                   S = outliers | thin | triangulate | mesh_scan. It prints one JSON
//                                   line: the stage's wall and CPU seconds and the peak RSS before and
//                                   during it.
#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "geometry/analytic_parts.hpp"
#include "geometry/bin_size.hpp"
#include "geometry/cloud_index.hpp"
#include "geometry/local_surface.hpp"
#include "geometry/mesh_io.hpp"
#include "geometry/outlier_removal.hpp"
#include "geometry/point_cloud.hpp"
#include "geometry/region_growing.hpp"
#include "geometry/scan_noise.hpp"
#include "geometry/scan_front_end.hpp"
#include "geometry/voxel_thinning.hpp"
#include "sim/raw_scan.hpp"
#include "sim/scan_borders.hpp"

namespace {

using namespace cmm::geometry;
namespace sim = cmm::sim;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr double kTolerance = 0.05;  // ε, mesh_scan's default
constexpr int kNeighbours = 25;

// The nominal sizes and the sample spacing that gives them: the count goes with 1/spacing²
// (0.5 mm gives 390,549 points; calibrated so that 300k and 1M come out within a few per cent).
double spacing_for(long points) { return 0.5 * std::sqrt(390'549.0 / static_cast<double>(points)); }

sim::RawScanOptions scan_options(long points) {
  sim::RawScanOptions o;
  o.spacing_mm = spacing_for(points);
  o.noise_sigma_mm = 0.05;
  o.stray_fraction = 0.002;
  return o;
}

const AnalyticPart& block() {
  static const AnalyticPart part = make_case3_block(1.0);  // as cmm-scan's default --edge-length
  return part;
}

const PointCloud& raw_scan(long points) {
  static std::map<long, PointCloud> scans;
  auto [it, fresh] = scans.try_emplace(points);
  if (fresh) it->second = sim::synthesize_raw_scan(block().mesh, scan_options(points)).cloud;
  return it->second;
}

PointCloud subset(const PointCloud& cloud, const std::vector<int>& ids) {
  PointCloud out;
  out.points.resize(static_cast<Eigen::Index>(ids.size()), 3);
  const bool normals = cloud.normals.rows() == cloud.points.rows();
  if (normals) out.normals.resize(static_cast<Eigen::Index>(ids.size()), 3);
  for (std::size_t i = 0; i < ids.size(); ++i) {
    out.points.row(static_cast<Eigen::Index>(i)) = cloud.points.row(ids[i]);
    if (normals) out.normals.row(static_cast<Eigen::Index>(i)) = cloud.normals.row(ids[i]);
  }
  return out;
}

// What mesh_scan hands the triangulation: the outlier-free cloud, its index and fits, B and the
// thinned points (uniform bins).
struct Prepared {
  PointCloud clean;
  std::unique_ptr<CloudIndex> index;
  std::vector<LocalSurface> fits;
  BinSize bin;
  double noise_sigma_mm = 0;
  std::vector<int> kept;  // into clean
  Points thinned;
};

std::unique_ptr<Prepared> prepare(const PointCloud& raw) {
  auto p = std::make_unique<Prepared>();
  {
    const CloudIndex all(raw.points);
    p->clean = subset(raw, statistical_inliers(raw.points, all, {kNeighbours, 3, {}}));
  }
  p->index = std::make_unique<CloudIndex>(p->clean.points);
  p->fits = fit_local_surfaces(p->clean.points, *p->index, {kNeighbours, {}});
  p->noise_sigma_mm = estimate_scan_noise(p->fits).sigma_mm;
  BinSizeOptions bin_options;
  bin_options.tolerance_mm = kTolerance;
  p->bin = bin_size_for_tolerance(p->clean.points, p->fits, *p->index, bin_options);
  p->kept = thin_uniform(p->clean.points, p->bin.bin_mm);
  p->thinned.resize(static_cast<Eigen::Index>(p->kept.size()), 3);
  for (std::size_t i = 0; i < p->kept.size(); ++i) p->thinned.row(static_cast<Eigen::Index>(i)) = p->clean.points.row(p->kept[i]);
  return p;
}

const Prepared& prepared(long points) {
  static std::map<long, std::unique_ptr<Prepared>> cache;
  auto [it, fresh] = cache.try_emplace(points);
  if (fresh) it->second = prepare(raw_scan(points));
  return *it->second;
}

// As mesh_scan sets them for uniform bins (the dump checks that both give the same mesh).
RegionGrowingOptions growing_options(const Prepared& p) {
  RegionGrowingOptions o;
  o.bin_mm = p.bin.bin_mm;
  o.max_edge_bins = kMaxEdgeBins;
  o.noise_sigma_mm = p.noise_sigma_mm;
  o.reach_mm = sparse_reach(p.kept, p.fits, p.bin.bin_mm, kNeighbours);
  o.reach_from_bins = false;
  return o;
}

ScanOptions mesh_scan_options() {
  ScanOptions o;
  o.tolerance_mm = kTolerance;
  o.neighbours = kNeighbours;
  return o;
}

// Open3D's voxel_down_sample + estimate_normals(knn 25) on the full cloud, our way: the k-d tree,
// a quadric fit per point (25 neighbours), B from ε, one point per bin.
struct ThinResult {
  double bin_mm = 0;
  std::size_t kept = 0;
};

ThinResult thin_with_fits(const Points& points) {
  const CloudIndex index(points);
  const std::vector<LocalSurface> fits = fit_local_surfaces(points, index, {kNeighbours, {}});
  BinSizeOptions bin_options;
  bin_options.tolerance_mm = kTolerance;
  const BinSize bin = bin_size_for_tolerance(points, fits, index, bin_options);
  const std::vector<int> kept = thin_uniform(points, bin.bin_mm);
  return {bin.bin_mm, kept.size()};
}

void bm_outliers(benchmark::State& state) {
  const PointCloud& raw = raw_scan(state.range(0));
  std::size_t inliers = 0;
  for (auto _ : state) {
    const CloudIndex index(raw.points);
    inliers = statistical_inliers(raw.points, index, {kNeighbours, 3, {}}).size();
  }
  state.counters["points"] = static_cast<double>(raw.points.rows());
  state.counters["inliers"] = static_cast<double>(inliers);
}

void bm_thin(benchmark::State& state) {
  const PointCloud& raw = raw_scan(state.range(0));
  ThinResult result;
  for (auto _ : state) result = thin_with_fits(raw.points);
  state.counters["points"] = static_cast<double>(raw.points.rows());
  state.counters["bin_mm"] = result.bin_mm;
  state.counters["kept"] = static_cast<double>(result.kept);
}

void bm_triangulate(benchmark::State& state) {
  const Prepared& p = prepared(state.range(0));
  std::size_t triangles = 0;
  for (auto _ : state) {
    const Triangulation t = triangulate_scan(p.thinned, p.clean.points, p.fits, *p.index, p.clean.normals,
                                             growing_options(p));
    triangles = static_cast<std::size_t>(t.mesh.faces.rows());
  }
  state.counters["points"] = static_cast<double>(raw_scan(state.range(0)).points.rows());
  state.counters["thinned"] = static_cast<double>(p.thinned.rows());
  state.counters["bin_mm"] = p.bin.bin_mm;
  state.counters["triangles"] = static_cast<double>(triangles);
}

// Its counters hold the last run's stage times as mesh_scan's report gives them (seconds).
void bm_mesh_scan(benchmark::State& state) {
  const PointCloud& raw = raw_scan(state.range(0));
  ScanReport report;
  for (auto _ : state) report = mesh_scan(raw, "bench", mesh_scan_options()).report;
  state.counters["points"] = static_cast<double>(raw.points.rows());
  state.counters["triangles"] = static_cast<double>(report.triangles);
  for (const ScanStageTime& t : report.times) state.counters["s_" + t.stage] = t.seconds;
}

BENCHMARK(bm_outliers)->Arg(300'000)->Arg(1'000'000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(bm_thin)->Arg(300'000)->Arg(1'000'000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(bm_triangulate)->Arg(300'000)->Arg(1'000'000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(bm_mesh_scan)->Arg(300'000)->Arg(1'000'000)->Unit(benchmark::kMillisecond)->UseRealTime();

// --- the modes for compare_scan.py -----------------------------------------------------------

std::string json_number(double v) {
  std::ostringstream out;
  out.precision(17);
  out << v;
  return out.str();
}

// The thinned points with their fitted normals, turned to agree with the scanner's normal of the
// same point (the fits' sign is not oriented), so that ball pivoting and greedy projection get
// consistently oriented normals.
PointCloud thinned_with_normals(const Prepared& p) {
  PointCloud out;
  out.points = p.thinned;
  out.normals.resize(p.thinned.rows(), 3);
  for (std::size_t i = 0; i < p.kept.size(); ++i) {
    Vec3 n = p.fits[p.kept[i]].normal;
    if (p.clean.normals.rows() == p.clean.points.rows() && n.dot(p.clean.normals.row(p.kept[i]).transpose()) < 0) n = -n;
    out.normals.row(static_cast<Eigen::Index>(i)) = n.transpose();
  }
  return out;
}

int dump(const fs::path& dir) {
  fs::create_directories(dir);
  write_mesh(dir / "truth.ply", make_case3_block(0.25).mesh);
  const std::vector<sim::ScanBorder> borders = sim::scan_borders(block().mesh, scan_options(300'000).views);
  for (const long size : {300'000L, 1'000'000L}) {
    const std::string tag = std::to_string(size);
    const PointCloud& raw = raw_scan(size);
    const Prepared& p = prepared(size);
    write_cloud(dir / ("raw_" + tag + ".ply"), raw);
    const PointCloud thinned = thinned_with_normals(p);
    write_cloud(dir / ("thinned_" + tag + ".ply"), thinned);
    write_cloud(dir / ("thinned_" + tag + ".pcd"), thinned);
    // Our mesh is mesh_scan's; bm_triangulate's call must give the same (same cloud, B, options).
    const ScanMesh ours = mesh_scan(raw, "bench", mesh_scan_options());
    const Triangulation t = triangulate_scan(p.thinned, p.clean.points, p.fits, *p.index, p.clean.normals,
                                             growing_options(p));
    const bool same = t.mesh.faces == ours.mesh.faces && t.mesh.vertices == ours.mesh.vertices &&
                      ours.report.bin_size_mm == p.bin.bin_mm && ours.report.points_kept == p.kept.size();
    if (!same)
      std::cerr << "scan_bench: WARNING: bm_triangulate's call gives " << t.mesh.faces.rows() << " triangles, mesh_scan "
                << ours.mesh.faces.rows() << " (B " << p.bin.bin_mm << " / " << ours.report.bin_size_mm
                << "): mesh_scan's triangulation options changed, update growing_options\n";
    write_mesh(dir / ("ours_" + tag + ".ply"), ours.mesh);
    std::size_t outer = 0, holes = 0;
    for (const ScanLoop& loop : t.loops) (loop.kind == LoopKind::hole ? holes : outer)++;
    std::ofstream info(dir / ("info_" + tag + ".json"));
    info << "{\"points\": " << raw.points.rows() << ", \"spacing_mm\": " << json_number(spacing_for(size))
         << ", \"inliers\": " << p.clean.points.rows() << ", \"bin_mm\": " << json_number(p.bin.bin_mm)
         << ", \"bin_source\": \"" << p.bin.source << "\", \"thinned\": " << p.thinned.rows()
         << ", \"triangles\": " << t.mesh.faces.rows() << ", \"vertices\": " << t.mesh.vertices.rows()
         << ", \"loops_outer\": " << outer << ", \"loops_hole\": " << holes << ", \"creases\": " << t.creases
         << ", \"components\": " << t.components << ", \"pinched_vertices\": " << t.pinched_vertices
         << ", \"same_as_mesh_scan\": " << (same ? "true" : "false") << ", \"mesh_scan_triangles\": " << ours.mesh.faces.rows()
         << ", \"noise_sigma_mm\": " << json_number(ours.report.noise_sigma_mm) << ", \"mesh_scan_seconds\": {";
    for (std::size_t k = 0; k < ours.report.times.size(); ++k)
      info << (k ? ", " : "") << '"' << ours.report.times[k].stage << "\": " << json_number(ours.report.times[k].seconds);
    info << "}, \"borders\": [";
    for (std::size_t i = 0; i < borders.size(); ++i) {
      const sim::ScanBorder& b = borders[i];
      info << (i ? ", " : "") << "{\"centre\": [" << json_number(b.centre.x()) << ", " << json_number(b.centre.y()) << ", "
           << json_number(b.centre.z()) << "], \"perimeter_mm\": " << json_number(b.perimeter_mm) << ", \"kind\": \""
           << (b.kind == LoopKind::hole ? "hole" : "outer") << "\"}";
    }
    info << "]}\n";
    if (!info.flush()) throw std::runtime_error("cannot write the info file in " + dir.string());
    std::cerr << tag << ": " << raw.points.rows() << " points, " << p.clean.points.rows() << " inliers, B "
              << p.bin.bin_mm << " mm, " << p.thinned.rows() << " thinned, " << t.mesh.faces.rows() << " triangles\n";
  }
  return 0;
}

long status_kb(const char* field) {
  std::ifstream in("/proc/self/status");
  std::string line;
  const std::size_t length = std::strlen(field);
  while (std::getline(in, line))
    if (line.compare(0, length, field) == 0) return std::atol(line.c_str() + length + 1);
  return -1;
}

// Resets VmHWM to the current RSS (Linux ≥ 4.0), so that VmHWM afterwards is the stage's peak.
bool reset_peak() {
  std::ofstream out("/proc/self/clear_refs");
  out << "5";
  return static_cast<bool>(out.flush());
}

// User + system time of the whole process (all threads).
double cpu_seconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  const auto sec = [](const timeval& t) { return static_cast<double>(t.tv_sec) + static_cast<double>(t.tv_usec) * 1e-6; };
  return sec(usage.ru_utime) + sec(usage.ru_stime);
}

int run_stage(const std::string& stage, const fs::path& cloud_file) {
  const ReadResult read = read_model(cloud_file);
  const PointCloud raw = std::get<PointCloud>(read.model);
  std::unique_ptr<Prepared> p;
  if (stage == "triangulate") p = prepare(raw);
  const long rss_before = status_kb("VmRSS:");
  const bool reset = reset_peak();
  const double cpu_start = cpu_seconds();
  const Clock::time_point start = Clock::now();
  std::size_t result = 0;
  if (stage == "outliers") {
    const CloudIndex index(raw.points);
    result = statistical_inliers(raw.points, index, {kNeighbours, 3, {}}).size();
  } else if (stage == "thin") {
    result = thin_with_fits(raw.points).kept;
  } else if (stage == "triangulate") {
    result = static_cast<std::size_t>(triangulate_scan(p->thinned, p->clean.points, p->fits, *p->index, p->clean.normals,
                                                       growing_options(*p))
                                          .mesh.faces.rows());
  } else if (stage == "mesh_scan") {
    result = mesh_scan(raw, cloud_file.string(), mesh_scan_options()).report.triangles;
  } else {
    std::cerr << "scan_bench: unknown stage " << stage << " (outliers, thin, triangulate, mesh_scan)\n";
    return 2;
  }
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  const double cpu = cpu_seconds() - cpu_start;
  std::cout << "{\"stage\": \"" << stage << "\", \"seconds\": " << json_number(seconds)
            << ", \"cpu_seconds\": " << json_number(cpu) << ", \"result\": " << result
            << ", \"rss_before_kb\": " << rss_before << ", \"peak_kb\": " << status_kb("VmHWM:")
            << ", \"peak_reset\": " << (reset ? "true" : "false") << "}\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::string dump_dir, stage, cloud;
  std::vector<char*> rest{argv[0]};
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg.rfind("--dump=", 0) == 0) dump_dir = arg.substr(7);
    else if (arg.rfind("--stage=", 0) == 0) stage = arg.substr(8);
    else if (arg.rfind("--cloud=", 0) == 0) cloud = arg.substr(8);
    else rest.push_back(argv[i]);
  }
  try {
    if (!dump_dir.empty()) return dump(dump_dir);
    if (!stage.empty()) return run_stage(stage, cloud);
  } catch (const std::exception& e) {
    std::cerr << "scan_bench: " << e.what() << '\n';
    return 1;
  }
  int count = static_cast<int>(rest.size());
  benchmark::Initialize(&count, rest.data());
  if (benchmark::ReportUnrecognizedArguments(count, rest.data())) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
