// The scan front end end to end (mesh_scan) on analytic surfaces of known shape: the mesh it makes
// at a tolerance ε lies within ε of the true surface on noise-free samples, and its 99.7th percentile
// within ε + 3σ on noisy ones, with no opening but the sampled region's border; and every cloud no
// stage can use is refused with an error that names the file and what is wrong.
#include "geometry/scan_front_end.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <tbb/global_control.h>

namespace cmm::geometry {
namespace {

// A surface given by a parametrisation over a rectangle of (s, t) and its exact distance function.
struct AnalyticSurface {
  std::string name;
  std::function<Vec3(double s, double t)> point;
  std::function<Vec3(double s, double t)> normal;  // unit, out of the material
  double s0, s1, t0, t1;
  std::function<double(const Vec3&)> distance;     // from the true surface, mm
  std::size_t loops;                               // boundary loops of the sampled patch
};

// Points area-uniformly (rejection on the parametrisation's area element), `sigma` along the normal.
PointCloud sample(const AnalyticSurface& surface, std::size_t count, double sigma, std::uint64_t seed) {
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<double> s(surface.s0, surface.s1), t(surface.t0, surface.t1), unit(0, 1);
  std::normal_distribution<double> noise(0, sigma > 0 ? sigma : 1);
  const auto area = [&](double a, double b) {
    const double h = 1e-5;
    const Vec3 ds = (surface.point(a + h, b) - surface.point(a - h, b)) / (2 * h);
    const Vec3 dt = (surface.point(a, b + h) - surface.point(a, b - h)) / (2 * h);
    return ds.cross(dt).norm();
  };
  double most = 0;
  for (int i = 0; i <= 64; ++i)
    for (int j = 0; j <= 64; ++j)
      most = std::max(most, area(surface.s0 + (surface.s1 - surface.s0) * i / 64, surface.t0 + (surface.t1 - surface.t0) * j / 64));
  PointCloud cloud;
  cloud.points.resize(static_cast<Eigen::Index>(count), 3);
  cloud.normals.resize(static_cast<Eigen::Index>(count), 3);
  for (Eigen::Index n = 0; n < cloud.points.rows();) {
    const double a = s(random), b = t(random);
    if (unit(random) * most * 1.05 > area(a, b)) continue;
    const Vec3 normal = surface.normal(a, b);
    cloud.points.row(n) = (surface.point(a, b) + (sigma > 0 ? noise(random) : 0.0) * normal).transpose();
    cloud.normals.row(n++) = normal.transpose();
  }
  return cloud;
}

// Each facet's distance from the true surface at a 9 × 9 barycentric grid (eq. 3.1's sup over T).
std::vector<double> facet_distances(const TriangleMesh& mesh, const AnalyticSurface& surface) {
  std::vector<double> d;
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
    const Vec3 a = vertex(mesh, mesh.faces(f, 0)), b = vertex(mesh, mesh.faces(f, 1)), c = vertex(mesh, mesh.faces(f, 2));
    double most = 0;
    for (int i = 0; i <= 8; ++i)
      for (int j = 0; i + j <= 8; ++j) most = std::max(most, surface.distance(a + (b - a) * i / 8.0 + (c - a) * j / 8.0));
    d.push_back(most);
  }
  return d;
}

AnalyticSurface hemisphere() {
  constexpr double R = 10;
  return {"hemisphere R10",
          [](double s, double t) { return Vec3(R * std::cos(t) * std::cos(s), R * std::cos(t) * std::sin(s), R * std::sin(t)); },
          [](double s, double t) { return Vec3(std::cos(t) * std::cos(s), std::cos(t) * std::sin(s), std::sin(t)); },
          0, 2 * M_PI, 0, M_PI / 2 - 1e-9,
          [](const Vec3& p) { return std::abs(p.norm() - R); },
          1};
}

// A cone of half-angle 30° about z (apex at the origin, opening downward), between radii 3 and 8.
AnalyticSurface cone() {
  const double alpha = M_PI / 6, ca = std::cos(alpha), sa = std::sin(alpha);
  return {"cone 30deg",
          [=](double s, double rho) { return Vec3(rho * std::cos(s), rho * std::sin(s), -rho * ca / sa); },
          [=](double s, double) { return Vec3(ca * std::cos(s), ca * std::sin(s), sa); },
          0, 2 * M_PI, 3, 8,
          [=](const Vec3& p) { return std::abs(std::hypot(p.x(), p.y()) * ca + p.z() * sa); },
          2};
}

// Thesis §4.4.1: z = a·sqrt(x² − y² + r²), a = h/r², r = 2 mm, h = 3 mm; |y| ≤ 1.5 keeps the radicand ≥ 1.75.
AnalyticSurface thesis_surface() {
  constexpr double r = 2, h = 3, a = h / (r * r);
  const auto f = [](double x, double y) { return a * std::sqrt(x * x - y * y + r * r); };
  const auto gradient = [](double x, double y) {
    const double root = std::sqrt(x * x - y * y + r * r);
    return Eigen::Vector2d(a * x / root, -a * y / root);
  };
  return {"thesis 4.4.1 surface",
          [=](double x, double y) { return Vec3(x, y, f(x, y)); },
          [=](double x, double y) {
            const Eigen::Vector2d g = gradient(x, y);
            return Vec3(-g.x(), -g.y(), 1).normalized();
          },
          -2, 2, -1.5, 1.5,
          [=](const Vec3& p) {
            const Eigen::Vector2d g = gradient(p.x(), p.y());
            return std::abs(p.z() - f(p.x(), p.y())) / std::sqrt(1 + g.squaredNorm());
          },
          1};
}

// Two 45° cones meeting at a crease of radius 10 at z = 0, between radii 3 and 10 on each side.
AnalyticSurface bicone() {
  const double c = std::sqrt(0.5);
  return {"bicone 45deg",
          [](double s, double t) {  // t in [-7, 7]: below the crease for t < 0
            const double rho = 10 - std::abs(t);
            return Vec3(rho * std::cos(s), rho * std::sin(s), t);
          },
          [=](double s, double t) { return Vec3(c * std::cos(s), c * std::sin(s), t < 0 ? -c : c); },
          0, 2 * M_PI, -7, 7,
          [=](const Vec3& p) { return std::abs(std::hypot(p.x(), p.y()) + std::abs(p.z()) - 10) * c; },
          2};
}

// A flat strip that turns into a parabolic trough of curvature 0.1 /mm at x = 0 (C¹): the adaptive
// bins may coarsen on the flat half only.
AnalyticSurface flat_and_trough() {
  constexpr double a = 0.05;
  const auto f = [](double x) { return x > 0 ? a * x * x : 0.0; };
  const auto slope = [](double x) { return x > 0 ? 2 * a * x : 0.0; };
  return {"flat strip into a trough",
          [=](double x, double y) { return Vec3(x, y, f(x)); },
          [=](double x, double) { return Vec3(-slope(x), 0, 1).normalized(); },
          -12, 6, -6, 6,
          [=](const Vec3& p) { return std::abs(p.z() - f(p.x())) / std::sqrt(1 + slope(p.x()) * slope(p.x())); },
          1};
}

// The distances to the truth meet issue 16's goals (ε noise-free, ε + 3σ at the 99.7th percentile with
// noise) on every surface since creases are smoothed along their length (2026-12-03: the bicone 0.019 mm
// at ε 0.02, was 0.030; noisy 0.027 mm, was 0.052), and every surface keeps its own loops only with
// noise too since a loop no plane sees simple gets the least-folding patch (2026-12-06: the noisy
// bicone's last false loop beside its crease; 14 in 2026-12-02).
struct Case {
  AnalyticSurface surface;
  std::size_t points;
  double tolerance;
};

std::vector<Case> cases() {
  return {{hemisphere(), 40'000, 0.02}, {cone(), 30'000, 0.02}, {thesis_surface(), 8'000, 0.01}, {bicone(), 40'000, 0.02}};
}

TEST(ScanFrontEnd, NoiseFreeMeshWithinTheToleranceAtCreasesToo) {
  for (const Case& c : cases()) {
    ScanOptions options;
    options.tolerance_mm = c.tolerance;
    const ScanMesh m = mesh_scan(sample(c.surface, c.points, 0, 1), c.surface.name, options);
    const std::vector<double> d = facet_distances(m.mesh, c.surface);
    const double worst = *std::max_element(d.begin(), d.end());
    std::printf("%s: %zu points, bin %.4f mm, %zu kept, %zu triangles, %zu loops; mesh within %.4f mm of the truth "
                "(tolerance %.3f)\n",
                c.surface.name.c_str(), c.points, m.report.bin_size_mm, m.report.points_kept, m.report.triangles,
                m.report.outer_loops + m.report.hole_loops, worst, c.tolerance);
    EXPECT_LE(worst, c.tolerance) << c.surface.name;
    EXPECT_EQ(m.report.outer_loops + m.report.hole_loops, c.surface.loops) << c.surface.name;
  }
}

TEST(ScanFrontEnd, NoisyMeshWithinToleranceAndThreeSigmaWithoutFalseHoles) {
  for (const Case& c : cases()) {
    const double sigma = c.tolerance / 2;
    ScanOptions options;
    options.tolerance_mm = c.tolerance;
    const ScanMesh m = mesh_scan(sample(c.surface, c.points, sigma, 2), c.surface.name, options);
    std::vector<double> d = facet_distances(m.mesh, c.surface);
    std::sort(d.begin(), d.end());
    const double p997 = d[static_cast<std::size_t>(0.997 * static_cast<double>(d.size() - 1))];
    std::printf("%s, sigma %.3f: noise estimated %.4f mm, bin %.4f mm, %zu triangles, %zu loops; 99.7th percentile %.4f mm "
                "(bound %.4f)\n",
                c.surface.name.c_str(), sigma, m.report.noise_sigma_mm, m.report.bin_size_mm, m.report.triangles,
                m.report.outer_loops + m.report.hole_loops, p997, c.tolerance + 3 * sigma);
    EXPECT_LE(p997, c.tolerance + 3 * sigma) << c.surface.name;
    EXPECT_EQ(m.report.outer_loops + m.report.hole_loops, c.surface.loops) << c.surface.name;
    EXPECT_NEAR(m.report.noise_sigma_mm, sigma, 0.2 * sigma) << c.surface.name;
  }
}


// The scanner's normals orient each facet (one grown inside out is refused) only where neighbouring
// points' normals agree in sign: a cloud whose tool fitted normals without orienting them, half of them
// flipped, must mesh as well as the same cloud with its scanner's normals.
TEST(ScanFrontEnd, NormalsFlippedAtRandomMeshAsWell) {
  for (const Case& c : cases()) {
    ScanOptions options;
    options.tolerance_mm = c.tolerance;
    PointCloud cloud = sample(c.surface, c.points, 0, 4);
    const ScanMesh scanner = mesh_scan(cloud, c.surface.name, options);
    std::mt19937_64 random(5);
    for (Eigen::Index i = 0; i < cloud.normals.rows(); ++i)
      if (random() % 2) cloud.normals.row(i) *= -1;
    const ScanMesh flipped = mesh_scan(cloud, c.surface.name, options);
    const auto worst = [&](const ScanMesh& m) {
      const std::vector<double> d = facet_distances(m.mesh, c.surface);
      return *std::max_element(d.begin(), d.end());
    };
    std::printf("%s: scanner's normals %zu triangles, %zu loops, within %.4f mm; flipped at random %zu, %zu, %.4f mm\n",
                c.surface.name.c_str(), scanner.report.triangles, scanner.report.outer_loops + scanner.report.hole_loops,
                worst(scanner), flipped.report.triangles, flipped.report.outer_loops + flipped.report.hole_loops,
                worst(flipped));
    EXPECT_EQ(flipped.report.outer_loops + flipped.report.hole_loops, c.surface.loops) << c.surface.name;
    EXPECT_LE(worst(flipped), std::max(c.tolerance, worst(scanner)) + 1e-9) << c.surface.name;
    EXPECT_NEAR(static_cast<double>(flipped.report.triangles), static_cast<double>(scanner.report.triangles),
                0.01 * static_cast<double>(scanner.report.triangles))
        << c.surface.name;
  }
}


// The adaptive bins keep half the points at the same ε: each point's edges are no longer than its own
// bin allows (2026-12-03: 821 of 1780 points, 0.0035 mm at ε 0.01; 0.123 mm when every edge could be
// as long as the coarsest bin's).
void expect_adaptive(double bound_in_tolerances) {
  const Case c{flat_and_trough(), 40'000, 0.01};
  ScanOptions options;
  options.tolerance_mm = c.tolerance;
  const PointCloud cloud = sample(c.surface, c.points, 0, 3);
  const ScanMesh uniform = mesh_scan(cloud, "uniform", options);
  options.adaptive = true;
  const ScanMesh adaptive = mesh_scan(cloud, "adaptive", options);
  const std::vector<double> d = facet_distances(adaptive.mesh, c.surface);
  const double worst = *std::max_element(d.begin(), d.end());
  std::printf("%s at tolerance %.3f: uniform %zu points (bin %.4f), adaptive %zu points, %zu loops, within %.4f mm\n",
              c.surface.name.c_str(), c.tolerance, uniform.report.points_kept, uniform.report.bin_size_mm,
              adaptive.report.points_kept, adaptive.report.outer_loops + adaptive.report.hole_loops, worst);
  EXPECT_LT(adaptive.report.points_kept, uniform.report.points_kept * 3 / 4);
  EXPECT_LE(worst, c.tolerance * bound_in_tolerances);
  EXPECT_EQ(adaptive.report.outer_loops + adaptive.report.hole_loops, 1u);
}

TEST(ScanFrontEnd, AdaptiveKeepsFewerPointsAtTheSameTolerance) { expect_adaptive(1); }

std::string error_of(const PointCloud& cloud, const ScanOptions& options = {}) {
  try {
    mesh_scan(cloud, "scan.xyz", options);
  } catch (const ScanError& e) {
    return e.what();
  }
  return "no error";
}

PointCloud points(std::initializer_list<Vec3> list, std::size_t repeat = 1) {
  PointCloud cloud;
  cloud.points.resize(static_cast<Eigen::Index>(list.size() * repeat), 3);
  Eigen::Index i = 0;
  for (std::size_t r = 0; r < repeat; ++r)
    for (const Vec3& p : list) cloud.points.row(i++) = p.transpose();
  return cloud;
}

TEST(ScanFrontEnd, UnusableCloudsAreRefusedWithTheReason) {
  EXPECT_EQ(error_of(PointCloud{}), "scan.xyz: the scan holds no points");
  PointCloud grid = sample(thesis_surface(), 2'000, 0, 4);
  grid.points(17, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(error_of(grid), "scan.xyz: point 17 has a coordinate that is not a finite number");
  grid.points(17, 1) = std::numeric_limits<double>::infinity();
  EXPECT_EQ(error_of(grid), "scan.xyz: point 17 has a coordinate that is not a finite number");
  EXPECT_NE(error_of(points({Vec3(1, 2, 3)}, 100)).find("all 100 points are equal (1, 2, 3)"), std::string::npos);
  EXPECT_NE(error_of(points({Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)}, 5)).find("15 points, fewer than the 26"),
            std::string::npos);
  PointCloud line;
  line.points.resize(200, 3);
  for (int i = 0; i < 200; ++i) line.points.row(i) = Vec3(i * 0.1, i * 0.2, 1).transpose();
  EXPECT_NE(error_of(line).find("lie on one line"), std::string::npos) << error_of(line);
  // A 2 mm grid of a sphere of radius 10 cannot be meshed within 1 µm: the error names a tolerance that works.
  ScanOptions tight;
  tight.tolerance_mm = 0.001;
  const std::string sparse = error_of(sample(hemisphere(), 200, 0, 5), tight);
  EXPECT_NE(sparse.find("too sparse for a tolerance of 0.001"), std::string::npos) << sparse;
  EXPECT_NE(sparse.find("would work"), std::string::npos) << sparse;
  // A bin so small that the cloud spans more bins than a key can count: a ScanError naming the file.
  ScanOptions tiny_bin;
  tiny_bin.bin_size_mm = 1e-300;
  const std::string tiny = error_of(sample(hemisphere(), 200, 0, 5), tiny_bin);
  EXPECT_EQ(tiny.rfind("scan.xyz: voxel thinning: a bin of 1e-300 mm", 0), 0u) << tiny;
}

TEST(ScanFrontEnd, SameMeshOnOneAndTwoThreads) {
  // oneTBB's arena size is the only difference; the mesh must be byte-identical.
  const PointCloud cloud = sample(bicone(), 20'000, 0.005, 6);
  ScanOptions options;
  options.tolerance_mm = 0.02;
  const ScanMesh twice = mesh_scan(cloud, "bicone", options);
  ScanMesh once;
  {
    const tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
    once = mesh_scan(cloud, "bicone", options);
  }
  EXPECT_TRUE(once.mesh.vertices == twice.mesh.vertices);
  EXPECT_TRUE(once.mesh.faces == twice.mesh.faces);
}

}  // namespace
}  // namespace cmm::geometry

namespace cmm::geometry {
namespace {

PointCloud cloud_of(const std::vector<Vec3>& points) {
  PointCloud cloud;
  cloud.points.resize(static_cast<Eigen::Index>(points.size()), 3);
  for (std::size_t i = 0; i < points.size(); ++i) cloud.points.row(static_cast<Eigen::Index>(i)) = points[i].transpose();
  return cloud;
}

// A speck beside the surface (a dense 1.2 mm cluster 3 mm above a plane, too many points for the outlier
// removal to take) meshes into a few facets: it is dropped, not kept as a component with a loop of its own.
TEST(ScanFrontEnd, ASpeckBesideTheSurfaceIsNoComponentOfIt) {
  std::vector<Vec3> points;
  for (double x = 0; x <= 15; x += 0.1)
    for (double y = 0; y <= 15; y += 0.1) points.emplace_back(x, y, 0);
  for (double x = 0; x <= 1.2; x += 0.05)
    for (double y = 0; y <= 1.2; y += 0.05) points.emplace_back(5 + x, 5 + y, 3);
  const PointCloud cloud = cloud_of(points);
  ScanOptions options;
  options.tolerance_mm = 0.05;
  const ScanMesh m = mesh_scan(cloud, "plane with a speck", options);
  EXPECT_EQ(m.report.components, 1u);
  EXPECT_EQ(m.report.outer_loops + m.report.hole_loops, 1u);
  for (Eigen::Index f = 0; f < m.mesh.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) EXPECT_LT(std::abs(m.mesh.vertices(m.mesh.faces(f, k), 2)), 1e-6) << "facet " << f;
}

double mesh_area(const TriangleMesh& mesh) {
  double area = 0;
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
    area += (vertex(mesh, mesh.faces(f, 1)) - vertex(mesh, mesh.faces(f, 0))).cross(vertex(mesh, mesh.faces(f, 2)) - vertex(mesh, mesh.faces(f, 0))).norm() / 2;
  return area;
}

// A 20 × 20 mm face at 25 points per mm² at random and, beside it, one as large at `sparse` points per mm²,
// meshed at the bin the dense one asks for (0.35 mm).
ScanMesh half_dense_half_sparse(double sparse) {
  std::mt19937_64 random(7);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Vec3> points;
  for (int i = 0; i < 25 * 400; ++i) points.emplace_back(20 * u(random), 20 * u(random), 0);
  for (int i = 0; i < static_cast<int>(sparse * 400); ++i) points.emplace_back(20 + 20 * u(random), 20 * u(random), 0);
  ScanOptions options;
  options.bin_size_mm = 0.35;
  return mesh_scan(cloud_of(points), "half dense, half sparse", options);
}

// At a sixth of the dense face's density (4 points per mm²) edges of √6·B (0.86 mm) cannot join points
// 0.5 mm apart on average with random gaps beyond 1 mm, and the sparse half came out in tatters (8
// components, 4 loops, 506 of the 800 mm² meshed). Its points now reach their own spacing, and only the
// sparse half's points are counted as such: one component, one loop, 776 mm² (701 and two loops while the
// outlier filter, whose bound the dense half sets, took 238 of its points).
TEST(ScanFrontEnd, AFaceSparserThanTheBinNeedsIsMeshedAtItsOwnSpacing) {
  const ScanMesh m = half_dense_half_sparse(4);
  EXPECT_EQ(m.report.components, 1u);
  EXPECT_EQ(m.report.outer_loops + m.report.hole_loops, 1u);
  EXPECT_LT(m.report.outliers_removed, 20u);
  EXPECT_GT(m.report.points_sparse, 900u);   // most of the sparse half's 1,600
  EXPECT_LT(m.report.points_sparse, 1400u);  // and none of the dense half's but at the seam
  EXPECT_GT(mesh_area(m.mesh), 400 + 0.9 * 400);  // the dense half and 90 % of the sparse one (26 % at first)
}

// At 2 points per mm² (a twelfth; 0.7 mm apart, 2 B): the outlier filter took 535 of the sparse half's 800
// points and the rest came out in 3 components, 419 mm² in all. Now one, 761 mm².
TEST(ScanFrontEnd, AFaceATwelfthAsDenseIsMeshedWhole) {
  const ScanMesh m = half_dense_half_sparse(2);
  EXPECT_EQ(m.report.components, 1u);
  EXPECT_EQ(m.report.outer_loops + m.report.hole_loops, 1u);
  EXPECT_LT(m.report.outliers_removed, 20u);
  EXPECT_GT(mesh_area(m.mesh), 400 + 0.85 * 400);
}

// A grid at 0.25 mm and, 1.2 mm past its edge, one at 0.8 mm (a sparse view's face meeting the dense ones
// at B 0.35 mm): the sparse points reach 1.7 mm, the dense ones 0.86. An edge no longer than the smaller
// reach never crossed the seam, and the two grew as two components with two loops (the lower wall of a
// bore seen only by a sparse view grew apart and was dropped as a speck); with the larger, one.
TEST(ScanFrontEnd, ASparseFaceJoinsTheDenseFaceItMeets) {
  std::vector<Vec3> points;
  for (double x = 0; x <= 10 + 1e-9; x += 0.25)
    for (double y = 0; y <= 12 + 1e-9; y += 0.25) points.emplace_back(x, y, 0);
  for (double x = 11.2; x <= 22 + 1e-9; x += 0.8)
    for (double y = 0; y <= 12 + 1e-9; y += 0.8) points.emplace_back(x, y, 0);
  ScanOptions options;
  options.bin_size_mm = 0.35;
  const ScanMesh m = mesh_scan(cloud_of(points), "dense grid beside a sparse one", options);
  EXPECT_EQ(m.report.components, 1u);
  EXPECT_EQ(m.report.outer_loops + m.report.hole_loops, 1u);
  EXPECT_GT(mesh_area(m.mesh), 0.95 * 22 * 12);
}

// A patch apart from the surface smaller than a square 8 bins on a side (a band of wall seen deep in a Ø3
// hole at B 0.7 mm) is dropped however many facets it has; a larger one stays, a component of its own.
TEST(ScanFrontEnd, APatchApartSmallerThanEightBinsSquareIsDropped) {
  const auto patch_above_a_plane = [](double side) {
    std::vector<Vec3> points;
    for (double x = 0; x <= 15; x += 0.1)
      for (double y = 0; y <= 15; y += 0.1) points.emplace_back(x, y, 0);
    for (double x = 0; x <= side + 1e-9; x += 0.1)
      for (double y = 0; y <= side + 1e-9; y += 0.1) points.emplace_back(5 + x, 5 + y, 3);
    ScanOptions options;
    options.bin_size_mm = 0.25;  // 8 bins square: 4 mm²
    return mesh_scan(cloud_of(points), "plane with a patch above", options);
  };
  const ScanMesh small = patch_above_a_plane(1.8);  // 3.2 mm², 18 facets and more once its gaps are filled
  EXPECT_EQ(small.report.components, 1u);
  EXPECT_EQ(small.report.outer_loops + small.report.hole_loops, 1u);
  const ScanMesh large = patch_above_a_plane(2.2);  // 4.8 mm²
  EXPECT_EQ(large.report.components, 2u);
  EXPECT_EQ(large.report.outer_loops + large.report.hole_loops, 2u);
}

}  // namespace
}  // namespace cmm::geometry
