// The scan front end's stages in order, each timed, with the checks that turn a cloud no stage can
// use into one clear error naming the file; see scan_front_end.hpp.
#include "geometry/scan_front_end.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <sstream>
#include <stdexcept>

#include "geometry/bin_size.hpp"
#include "geometry/cloud_index.hpp"
#include "geometry/local_surface.hpp"
#include "geometry/outlier_removal.hpp"
#include "geometry/raw_edge.hpp"
#include "geometry/region_growing.hpp"
#include "geometry/scan_noise.hpp"
#include "geometry/voxel_thinning.hpp"

namespace cmm::geometry {

namespace {

using Clock = std::chrono::steady_clock;

class StageClock {
 public:
  explicit StageClock(ScanReport& report) : report_(report) {}
  void done(const char* stage) {
    const Clock::time_point now = Clock::now();
    report_.times.push_back({stage, std::chrono::duration<double>(now - last_).count()});
    last_ = now;
  }

 private:
  ScanReport& report_;
  Clock::time_point last_ = Clock::now();
};

// Up to 4 significant digits: "0.05", "0.8165", "12.5".
std::string number(double value) {
  std::ostringstream out;
  out.precision(4);
  out << value;
  return out.str();
}

std::string point_text(const Vec3& p) {
  std::ostringstream out;
  out << '(' << p.x() << ", " << p.y() << ", " << p.z() << ')';
  return out.str();
}

// The checks a cloud must pass before any fit: each failure is what an operator must fix in the file.
void check_cloud(const PointCloud& cloud, const std::string& name, const ScanOptions& options) {
  const Points& p = cloud.points;
  const auto n = static_cast<std::size_t>(p.rows());
  if (n == 0) throw ScanError(name + ": the scan holds no points");
  if (n > options.max_points)
    throw ScanError(name + ": " + std::to_string(n) + " points, more than the " + std::to_string(options.max_points) +
                    " a scan may have (thin it first, or raise the limit)");
  for (Eigen::Index i = 0; i < p.rows(); ++i)
    if (!p.row(i).allFinite())
      throw ScanError(name + ": point " + std::to_string(i) + " has a coordinate that is not a finite number");
  const auto needed = static_cast<std::size_t>(options.neighbours) + 1;
  if (n < needed)
    throw ScanError(name + ": " + std::to_string(n) + " points, fewer than the " + std::to_string(needed) +
                    " one local surface fit needs (" + std::to_string(options.neighbours) + " neighbours and the point)");
  const Vec3 mean = p.colwise().mean().transpose();
  const Points centred = p.rowwise() - mean.transpose();
  const Eigen::Matrix3d covariance = centred.transpose() * centred / static_cast<double>(n);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> pca(covariance);
  const Eigen::Vector3d spread = pca.eigenvalues().cwiseMax(0).cwiseSqrt();  // ascending
  if (spread(2) == 0) throw ScanError(name + ": all " + std::to_string(n) + " points are equal " + point_text(mean));
  // Relative to the cloud's extent: a line of points scanned with noise is still a line.
  if (spread(1) < 1e-6 * spread(2))
    throw ScanError(name + ": all " + std::to_string(n) + " points lie on one line through " + point_text(mean) +
                    ": a line is no surface to mesh");
  if (!(options.tolerance_mm > 0) || !std::isfinite(options.tolerance_mm))
    throw ScanError(name + ": the tolerance must be a positive number of mm");
  if (options.bin_size_mm && (!(*options.bin_size_mm > 0) || !std::isfinite(*options.bin_size_mm)))
    throw ScanError(name + ": the bin size must be a positive number of mm");
}

PointCloud subset(const PointCloud& cloud, const std::vector<int>& ids) {
  PointCloud out;
  out.points.resize(static_cast<Eigen::Index>(ids.size()), 3);
  const bool normals = cloud.normals.rows() == cloud.points.rows();
  if (normals) out.normals.resize(static_cast<Eigen::Index>(ids.size()), 3);
  for (std::size_t i = 0; i < ids.size(); ++i) {
    const auto row = static_cast<Eigen::Index>(i);
    out.points.row(row) = cloud.points.row(ids[i]);
    if (normals) out.normals.row(row) = cloud.normals.row(ids[i]);
  }
  return out;
}

}  // namespace

std::vector<double> sparse_reach(const std::vector<int>& kept, const std::vector<LocalSurface>& fits, double bin_mm, int neighbours) {
  const double base = kMaxEdgeBins * bin_mm;
  std::vector<double> reach;
  reach.reserve(kept.size());
  for (int k : kept) {
    const double spacing = fits[static_cast<std::size_t>(k)].radius_mm * std::sqrt(std::numbers::pi / neighbours);
    reach.push_back(std::clamp(2.5 * spacing, base, 2 * base));
  }
  return reach;
}

ScanMesh mesh_scan(const PointCloud& cloud, const std::string& name, const ScanOptions& options) {
  check_cloud(cloud, name, options);
  ScanMesh out;
  ScanReport& report = out.report;
  StageClock clock(report);
  report.points_in = static_cast<std::size_t>(cloud.points.rows());

  // Strays first: each would otherwise become a lone vertex, and its fit a false "most curved region".
  std::vector<int> inliers;
  {
    const CloudIndex all(cloud.points);
    inliers = statistical_inliers(cloud.points, all, {options.neighbours, options.outlier_std_ratio, options.cancel});
  }
  const PointCloud scan = subset(cloud, inliers);
  report.outliers_removed = report.points_in - inliers.size();
  if (inliers.size() < static_cast<std::size_t>(options.neighbours) + 1)
    throw ScanError(name + ": only " + std::to_string(inliers.size()) + " of " + std::to_string(report.points_in) +
                    " points are not outliers, fewer than one local fit needs");
  clock.done("outliers");

  const CloudIndex index(scan.points);
  const std::vector<LocalSurface> fits = fit_local_surfaces(scan.points, index, {options.neighbours, options.cancel});
  report.noise_sigma_mm = estimate_scan_noise(fits).sigma_mm;
  clock.done("fit");

  BinSizeOptions bin_options;
  bin_options.tolerance_mm = options.tolerance_mm;
  const BinSize bin = bin_size_for_tolerance(scan.points, fits, index, bin_options);
  if (options.bin_size_mm) {
    report.bin_size_mm = *options.bin_size_mm;
    report.bin_size_source = "given; the tolerance " + number(options.tolerance_mm) + " mm would give " + number(bin.bin_mm) + " mm";
  } else {
    if (const DensityCheck density = check_density(bin, options.tolerance_mm); density.too_sparse)
      throw ScanError(name + ": the scan is too sparse for a tolerance of " + number(options.tolerance_mm) +
                      " mm: its points lie " + number(bin.median_spacing_mm) + " mm apart, more than the " +
                      number(bin.bin_mm) + " mm bins that tolerance needs where the scan is most curved; a tolerance of " +
                      number(density.tolerance_needed_mm) + " mm would work");
    report.bin_size_mm = bin.bin_mm;
    report.bin_size_source = bin.source;
  }
  clock.done("bin size");

  AdaptiveThinningOptions adaptive;
  adaptive.bin_mm = report.bin_size_mm;
  adaptive.tolerance_mm = options.tolerance_mm;
  adaptive.cancel = options.cancel;
  std::vector<int> kept;
  std::vector<double> reach;  // per kept point, the longest edge its bin (adaptive) or its sampling (sparse) allows
  try {
    if (options.adaptive) {
      AdaptiveThinning thinned = thin_adaptive(scan.points, fits, adaptive);
      kept = std::move(thinned.kept);
      for (int level : thinned.levels) reach.push_back(kMaxEdgeBins * std::ldexp(report.bin_size_mm, level));
    } else {
      kept = thin_uniform(scan.points, report.bin_size_mm, options.cancel);
      reach = sparse_reach(kept, fits, report.bin_size_mm, options.neighbours);
      report.points_sparse = static_cast<std::size_t>(
          std::count_if(reach.begin(), reach.end(), [&](double r) { return r > kMaxEdgeBins * report.bin_size_mm; }));
    }
  } catch (const std::invalid_argument& e) {
    // A bin so small that the cloud's extent overflows the bin keys (--bin-size 1e-300).
    throw ScanError(name + ": " + e.what());
  }
  options.cancel.throw_if_requested("thinning");
  Points thinned(static_cast<Eigen::Index>(kept.size()), 3);
  // A kept point goes onto its fitted surface where the fit can be trusted: the triangulation's facets
  // then turn with the surface, not with the noise (at σ/B ≈ 0.1 raw points fold facets by 15°).
  for (std::size_t i = 0; i < kept.size(); ++i) {
    const LocalSurface& fit = fits[static_cast<std::size_t>(kept[i])];
    const Vec3 p = fit.regular ? fit.on_surface : Vec3(scan.points.row(kept[i]).transpose());
    thinned.row(static_cast<Eigen::Index>(i)) = p.transpose();
  }
  report.points_kept = kept.size();
  clock.done("thinning");

  RegionGrowingOptions growing;
  // Adaptive bins reach B·2^max_level on flat faces, and the growth must join their points too.
  growing.bin_mm = report.bin_size_mm * (options.adaptive ? std::ldexp(1.0, adaptive.max_level) : 1.0);
  growing.max_edge_bins = kMaxEdgeBins;
  // Each point's edges no longer than its own bin allows (adaptive: curved parts keep short edges) or, on a
  // sparse face, than its sampling needs.
  growing.reach_mm = std::move(reach);
  growing.reach_from_bins = options.adaptive;
  growing.noise_sigma_mm = report.noise_sigma_mm;
  growing.cancel = options.cancel;
  Triangulation t = triangulate_scan(thinned, scan.points, fits, index, scan.normals, growing);
  move_borders_to_raw_edge(t, scan.points, index, {report.bin_size_mm, report.noise_sigma_mm, options.tolerance_mm});
  clock.done("triangulation");

  report.triangles = static_cast<std::size_t>(t.mesh.faces.rows());
  for (const ScanLoop& loop : t.loops) (loop.kind == LoopKind::hole ? report.hole_loops : report.outer_loops)++;
  report.creases = t.creases;
  report.crease_points = t.crease_points;
  report.components = t.components;
  out.mesh = std::move(t.mesh);
  if (out.mesh.faces.rows() == 0)
    throw ScanError(name + ": no triangle could be formed from the " + std::to_string(kept.size()) +
                    " thinned points (bin size " + std::to_string(report.bin_size_mm) + " mm)");
  return out;
}

}  // namespace cmm::geometry
