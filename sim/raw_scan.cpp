// One engine for the whole scan, drawn in view, face, sample order, so a scan depends on its options
// and nothing else. Faces a view does not face cost no samples: most of a scan's time is the beam tests.
#include "sim/raw_scan.hpp"

#include <cmath>
#include <random>
#include <stdexcept>
#include <string>

namespace cmm::sim {

namespace {

using geometry::Vec3;

void check(const RawScanOptions& o) {
  if (!(o.spacing_mm > 0) || !std::isfinite(o.spacing_mm))
    throw std::invalid_argument("raw scan: spacing_mm must be finite and > 0");
  if (!(o.noise_sigma_mm >= 0) || !std::isfinite(o.noise_sigma_mm))
    throw std::invalid_argument("raw scan: noise_sigma_mm must be finite and >= 0");
  if (!(o.stray_fraction >= 0 && o.stray_fraction < 1))
    throw std::invalid_argument("raw scan: stray_fraction must be in [0, 1)");
  check_views(o.views, "raw scan: views");
}

// A point uniform over the triangle's area (the square-root map of two uniform numbers).
Vec3 sample_triangle(std::mt19937_64& engine, const Vec3& a, const Vec3& b, const Vec3& c) {
  std::uniform_real_distribution<double> unit(0, 1);
  const double r = std::sqrt(unit(engine)), s = unit(engine);
  return (1 - r) * a + r * (1 - s) * b + r * s * c;
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

RawScan synthesize_raw_scan(const geometry::TriangleMesh& scene, const RawScanOptions& o) {
  check(o);
  const ScanVisibility visibility(scene, o.max_incidence_deg);
  const geometry::FaceGeometry& faces = visibility.face_geometry();
  Collector out;
  if (scene.faces.rows() == 0) return out.finish();

  const Vec3 lo = scene.vertices.colwise().minCoeff(), hi = scene.vertices.colwise().maxCoeff();
  const Vec3 grow = 0.05 * (hi - lo);  // 10 % in all: 5 % on each side
  std::uniform_real_distribution<double> unit(0, 1);
  std::bernoulli_distribution is_stray(o.stray_fraction);
  std::normal_distribution<double> noise(0, o.noise_sigma_mm > 0 ? o.noise_sigma_mm : 1);
  std::mt19937_64 engine(o.seed);
  const double per_area = 1 / (o.spacing_mm * o.spacing_mm);

  for (int v = 0; v < static_cast<int>(o.views.size()); ++v) {
    const ScanView& view = o.views[v];
    for (int f = 0; f < scene.faces.rows(); ++f) {
      if (!visibility.facing(f, view.direction)) continue;
      // Random rounding keeps the expected count exact on faces much smaller than spacing².
      const double expected = faces.areas[f] * per_area;
      const int count = static_cast<int>(expected) + (unit(engine) < expected - std::floor(expected) ? 1 : 0);
      const Vec3 a = geometry::vertex(scene, scene.faces(f, 0)), b = geometry::vertex(scene, scene.faces(f, 1)),
                 c = geometry::vertex(scene, scene.faces(f, 2));
      const Vec3 normal = faces.normals.row(f).transpose();
      for (int k = 0; k < count; ++k) {
        const Vec3 p = sample_triangle(engine, a, b, c);
        if (visibility.occluded(p, f, view.direction)) continue;
        if (is_stray(engine)) {
          const Vec3 stray = (lo - grow) + Vec3(unit(engine), unit(engine), unit(engine)).cwiseProduct(hi - lo + 2 * grow);
          out.add(view.registration_error * stray, view.registration_error.linear() * -view.direction, stray, v, -1,
                  true);
          continue;
        }
        const double along_beam = o.noise_sigma_mm > 0 ? noise(engine) : 0;
        out.add(view.registration_error * (p + along_beam * view.direction), view.registration_error.linear() * normal,
                p, v, f, false);
      }
    }
  }
  return out.finish();
}

}  // namespace cmm::sim
