// A band's limit from random samples of what its view sees, by the same area-uniform draw as a random
// scan, each weighted as the view's sampling would count it.
#include "sim/view_coverage.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <utility>

#include "sim/scan_sampling.hpp"
#include "sim/seed_streams.hpp"

namespace cmm::sim {

std::vector<CoverageBand> coverage_bands(const ScanVisibility& visibility, const std::vector<ScanView>& views,
                                         double coverage, CoverageMeasure measure, std::uint64_t seed) {
  if (!(coverage > 0 && coverage <= 1)) throw std::invalid_argument("raw scan: view_coverage must be in (0, 1]");
  std::vector<CoverageBand> bands(views.size());
  if (coverage == 1) return bands;
  const geometry::TriangleMesh& scene = visibility.scene();
  const geometry::FaceGeometry& faces = visibility.face_geometry();
  std::mt19937_64 engine = seed_stream(seed, SeedStream::coverage_bands);
  std::uniform_real_distribution<double> unit(0, 1);
  for (std::size_t v = 0; v < views.size(); ++v) {
    const geometry::Vec3& direction = views[v].direction;
    const auto [across, up] = image_axes(direction);
    const double angle = 2 * std::numbers::pi * unit(engine);
    bands[v].direction = std::cos(angle) * across + std::sin(angle) * up;

    double faced_area = 0;
    for (int f = 0; f < scene.faces.rows(); ++f)
      if (visibility.facing(f, direction)) faced_area += faces.areas[f];
    if (!(faced_area > 0)) continue;  // the view sees nothing: nothing to cut
    const double per_area = kCoverageEstimateSamples / faced_area;
    std::vector<std::pair<double, double>> along;  // (direction · p, weight) over the samples the view sees
    for (int f = 0; f < scene.faces.rows(); ++f) {
      if (!visibility.facing(f, direction)) continue;
      const double weight = measure == CoverageMeasure::image_area ? -direction.dot(faces.normals.row(f).transpose()) : 1.0;
      const double expected = faces.areas[f] * per_area;
      const int count = static_cast<int>(expected) + (unit(engine) < expected - std::floor(expected) ? 1 : 0);
      const geometry::Vec3 a = geometry::vertex(scene, scene.faces(f, 0)), b = geometry::vertex(scene, scene.faces(f, 1)),
                           c = geometry::vertex(scene, scene.faces(f, 2));
      for (int k = 0; k < count; ++k) {
        const geometry::Vec3 p = sample_triangle(engine, a, b, c);
        if (!visibility.occluded(p, f, direction)) along.emplace_back(bands[v].direction.dot(p), weight);
      }
    }
    if (along.empty()) continue;
    // The weighted quantile: the first position along the band's direction with `coverage` of the weight below.
    std::sort(along.begin(), along.end());
    double total = 0;
    for (const auto& [position, weight] : along) total += weight;
    double below = 0;
    bands[v].limit_mm = along.back().first;
    for (const auto& [position, weight] : along)
      if ((below += weight) >= coverage * total) {
        bands[v].limit_mm = position;
        break;
      }
  }
  return bands;
}

}  // namespace cmm::sim
