// One engine for the noise and strays of the whole scan, drawn in sample order, so a scan depends on its
// options and nothing else. The random sampler draws from that engine too, interleaved with the noise,
// as it always has: a seed's random scan is the same bit for bit as before grid and poisson existed.
// Faces a view does not face cost no samples: most of a scan's time is the beam tests.
#include "sim/raw_scan.hpp"

#include <cmath>
#include <cstdio>
#include <numeric>
#include <random>
#include <stdexcept>
#include <string>

#include "sim/scan_sampling.hpp"

namespace cmm::sim {

namespace {

using geometry::Vec3;

constexpr double kMaxScanDraws = 2e8;  // about 6 GB of points, normals and truth

void check(const RawScanOptions& o) {
  if (!(o.spacing_mm > 0) || !std::isfinite(o.spacing_mm))
    throw std::invalid_argument("raw scan: spacing_mm must be finite and > 0");
  if (!(o.noise_sigma_mm >= 0) || !std::isfinite(o.noise_sigma_mm))
    throw std::invalid_argument("raw scan: noise_sigma_mm must be finite and >= 0");
  if (!(o.stray_fraction >= 0 && o.stray_fraction < 1))
    throw std::invalid_argument("raw scan: stray_fraction must be in [0, 1)");
  check_views(o.views, "raw scan: views");
  if (o.sampling != ScanSampling::random && o.sampling != ScanSampling::grid && o.sampling != ScanSampling::poisson)
    throw std::invalid_argument("raw scan: sampling is not random, grid or poisson");
  if (o.noise_model != ScanNoise::beam && o.noise_model != ScanNoise::isotropic)
    throw std::invalid_argument("raw scan: noise_model is not beam or isotropic");
  if (!(o.view_coverage > 0 && o.view_coverage <= 1))
    throw std::invalid_argument("raw scan: view_coverage must be in (0, 1]");
  if (!o.view_density.empty() && o.view_density.size() != o.views.size())
    throw std::invalid_argument("raw scan: view_density has " + std::to_string(o.view_density.size()) +
                                " factors for " + std::to_string(o.views.size()) + " views");
  for (double density : o.view_density)
    if (!(density > 0) || !std::isfinite(density))
      throw std::invalid_argument("raw scan: view_density factors must be finite and > 0");
}

// Where the real points came to lie and what the scanner said about them, appended point by point.
struct Collector {
  std::vector<double> points, normals, truth_points;
  RawScanTruth truth;
  void add(const Vec3& point, const Vec3& normal, const Vec3& true_point, int view, int face, bool stray) {
    points.insert(points.end(), point.data(), point.data() + 3);
    normals.insert(normals.end(), normal.data(), normal.data() + 3);
    truth_points.insert(truth_points.end(), true_point.data(), true_point.data() + 3);
    truth.view.push_back(view);
    truth.face.push_back(face);
    truth.stray.push_back(stray);
  }
  RawScan finish() {
    const Eigen::Index n = static_cast<Eigen::Index>(truth.view.size());
    RawScan scan{{geometry::Points::Map(points.data(), n, 3), geometry::Points::Map(normals.data(), n, 3)},
                 std::move(truth)};
    scan.truth.surface_points = geometry::Points::Map(truth_points.data(), n, 3);
    return scan;
  }
};

}  // namespace

const char* to_string(ScanSampling sampling) {
  switch (sampling) {
    case ScanSampling::random: return "random";
    case ScanSampling::grid: return "grid";
    case ScanSampling::poisson: return "poisson";
  }
  return "?";
}

const char* to_string(ScanNoise noise) {
  switch (noise) {
    case ScanNoise::beam: return "beam";
    case ScanNoise::isotropic: return "isotropic";
  }
  return "?";
}

RawScan synthesize_raw_scan(const geometry::TriangleMesh& scene, const RawScanOptions& o) {
  check(o);
  const ScanVisibility visibility(scene, o.max_incidence_deg);
  const geometry::FaceGeometry& faces = visibility.face_geometry();
  Collector out;
  if (scene.faces.rows() == 0) return out.finish();
  {
    // Bounded work: every view on every face is more than any scan draws (Poisson draws 5× that).
    double draws = 0;
    for (std::size_t v = 0; v < o.views.size(); ++v) draws += o.view_density.empty() ? 1 : o.view_density[v];
    draws *= std::accumulate(faces.areas.begin(), faces.areas.end(), 0.0) / (o.spacing_mm * o.spacing_mm) * (o.sampling == ScanSampling::poisson ? 5 : 1);
    if (!(draws <= kMaxScanDraws)) {
      char text[200];
      std::snprintf(text, sizeof text, "raw scan: spacing_mm %g and view_density ask for about %.3g samples, more than the %.0f "
                    "a synthesized scan may draw", o.spacing_mm, draws, kMaxScanDraws);
      throw std::invalid_argument(text);
    }
  }
  out.truth.coverage = coverage_bands(visibility, o.views, o.view_coverage,
                                      o.sampling == ScanSampling::grid ? CoverageMeasure::image_area : CoverageMeasure::surface_area,
                                      o.seed);
  const std::vector<CoverageBand>& coverage = out.truth.coverage;
  const std::vector<double> density = o.view_density.empty() ? std::vector<double>(o.views.size(), 1.0) : o.view_density;

  const Vec3 lo = scene.vertices.colwise().minCoeff(), hi = scene.vertices.colwise().maxCoeff();
  const Vec3 grow = 0.05 * (hi - lo);  // 10 % in all: 5 % on each side
  std::uniform_real_distribution<double> unit(0, 1);
  std::bernoulli_distribution is_stray(o.stray_fraction);
  std::normal_distribution<double> noise(0, o.noise_sigma_mm > 0 ? o.noise_sigma_mm : 1);
  std::mt19937_64 engine(o.seed);

  // A sample the view saw becomes a stray or a noisy point, then goes through the view's registration error.
  const auto report = [&](const SurfaceSample& s) {
    const ScanView& view = o.views[s.view];
    if (is_stray(engine)) {
      const Vec3 stray = (lo - grow) + Vec3(unit(engine), unit(engine), unit(engine)).cwiseProduct(hi - lo + 2 * grow);
      out.add(view.registration_error * stray, view.registration_error.linear() * -view.direction, stray, s.view, -1, true);
      return;
    }
    Vec3 offset = Vec3::Zero();
    if (o.noise_sigma_mm > 0 && o.noise_model == ScanNoise::beam) offset = noise(engine) * view.direction;
    if (o.noise_sigma_mm > 0 && o.noise_model == ScanNoise::isotropic)
      for (int k = 0; k < 3; ++k) offset[k] = noise(engine);  // one coordinate at a time: a fixed draw order
    out.add(view.registration_error * (s.point + offset), view.registration_error.linear() * faces.normals.row(s.face).transpose(),
            s.point, s.view, s.face, false);
  };

  if (o.sampling == ScanSampling::random) {
    const double per_area = 1 / (o.spacing_mm * o.spacing_mm);
    for (int v = 0; v < static_cast<int>(o.views.size()); ++v) {
      const ScanView& view = o.views[v];
      const double view_per_area = per_area * density[v];  // × 1 is exact: unit densities change no draw
      for (int f = 0; f < scene.faces.rows(); ++f) {
        if (!visibility.facing(f, view.direction)) continue;
        // Random rounding keeps the expected count exact on faces much smaller than spacing².
        const double expected = faces.areas[f] * view_per_area;
        const int count = static_cast<int>(expected) + (unit(engine) < expected - std::floor(expected) ? 1 : 0);
        const Vec3 a = geometry::vertex(scene, scene.faces(f, 0)), b = geometry::vertex(scene, scene.faces(f, 1)),
                   c = geometry::vertex(scene, scene.faces(f, 2));
        for (int k = 0; k < count; ++k) {
          const Vec3 p = sample_triangle(engine, a, b, c);
          if (!coverage[v].keeps(p) || visibility.occluded(p, f, view.direction)) continue;
          report({p, f, v});
        }
      }
    }
    return out.finish();
  }
  const SamplerInput input{visibility, o.views, coverage, density, o.spacing_mm, o.seed};
  for (const SurfaceSample& s : o.sampling == ScanSampling::grid ? grid_samples(input) : poisson_samples(input)) report(s);
  return out.finish();
}

}  // namespace cmm::sim
