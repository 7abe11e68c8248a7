// Breadth-first region growth, then a robust weighted least-squares fit of the normal field.
#include "geometry/side_normal.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

namespace cmm::geometry {

SideRegionFinder::SideRegionFinder(const TriangleMesh& mesh, const EdgeAdjacency& adjacency, const FaceGeometry& faces,
                                   const std::vector<char>& is_feature, const Points& similarity_normals,
                                   double max_turn_rad)
    : mesh_(mesh),
      adjacency_(adjacency),
      faces_(faces),
      is_feature_(is_feature),
      similarity_normals_(similarity_normals),
      min_cos_(std::cos(max_turn_rad)),
      stamp_(faces.areas.size(), 0) {}

const std::vector<int>& SideRegionFinder::region(int seed_face, const Vec3& centre, const Vec3& tangent, double radius,
                                                 double along) {
  // The similarity reference is the side next to the seed, not the seed alone: on a noisy mesh the
  // face at the crease may be a fold whose normal belongs to neither side.
  const double near = std::min(radius, 2.5 * std::sqrt(faces_.areas[seed_face] * 4 / std::sqrt(3.0)));
  Vec3 reference = Vec3::Zero();
  for (int f : grow(seed_face, centre, tangent, near, near, -2.0, similarity_normals_.row(seed_face).transpose()))
    reference += faces_.areas[f] * similarity_normals_.row(f).transpose();
  return grow(seed_face, centre, tangent, radius, along, min_cos_, reference.normalized());
}

const std::vector<int>& SideRegionFinder::patch(int seed_face) {
  const double everywhere = std::numeric_limits<double>::infinity();
  return grow(seed_face, Vec3::Zero(), Vec3::UnitX(), everywhere, everywhere, -2.0, Vec3::UnitZ());
}

const std::vector<int>& SideRegionFinder::grow(int seed_face, const Vec3& centre, const Vec3& tangent, double radius,
                                               double along, double min_cos, const Vec3& reference) {
  ++current_;
  region_.clear();
  region_.push_back(seed_face);
  stamp_[seed_face] = current_;
  const double radius_squared = radius * radius;
  for (std::size_t i = 0; i < region_.size(); ++i) {
    const int f = region_[i];
    for (int k = 0; k < 3; ++k) {
      const int e = adjacency_.face_edges(f, k);
      if (is_feature_[e]) continue;
      const int g = adjacency_.other_face(e, f);
      if (g < 0 || stamp_[g] == current_) continue;
      stamp_[g] = current_;
      const Vec3 offset = face_centroid(mesh_, g) - centre;
      if (offset.squaredNorm() > radius_squared || std::abs(offset.dot(tangent)) > along) continue;
      if (similarity_normals_.row(g).dot(reference.transpose()) < min_cos) continue;
      region_.push_back(g);
    }
  }
  return region_;
}

namespace {

// The normal field is modelled as linear in s (along the edge) and d (away from it): a side that
// turns along or across the edge. Squares were tried: they fit noise-free parts better but double
// the error on noisy ones.
constexpr int terms = 3;
using Terms = Eigen::Matrix<double, terms, 1>;

Terms terms_at(double s, double d) { return (Terms() << 1.0, s, d).finished(); }

struct Sample {
  double weight;
  Terms x;
  Vec3 normal;
};

struct Fit {
  Vec3 normal;
  double variance;  // of the normal at the point
  double spread_squared;
  Eigen::Matrix<double, terms, 3> coefficients;  // rows: the terms; columns: x, y, z
};

Fit fit(const std::vector<Sample>& samples, const std::vector<char>& used) {
  Eigen::Matrix<double, terms, terms> xtwx = Eigen::Matrix<double, terms, terms>::Zero();
  Eigen::Matrix<double, terms, 3> xtwn = Eigen::Matrix<double, terms, 3>::Zero();
  double w_sum = 0, w2_sum = 0;
  Vec3 mean = Vec3::Zero();
  for (std::size_t i = 0; i < samples.size(); ++i) {
    if (!used[i]) continue;
    const Sample& a = samples[i];
    xtwx += a.weight * a.x * a.x.transpose();
    xtwn += a.weight * a.x * a.normal.transpose();
    w_sum += a.weight, w2_sum += a.weight * a.weight, mean += a.weight * a.normal;
  }
  Fit result{Vec3::Zero(), 0, 0, Eigen::Matrix<double, terms, 3>::Zero()};
  if (w_sum <= 0) return result;
  mean /= w_sum;
  const double effective_count = w_sum * w_sum / w2_sum;
  Eigen::Matrix<double, terms, 3> linear = Eigen::Matrix<double, terms, 3>::Zero();
  linear.row(0) = mean.transpose();
  const Eigen::LDLT<Eigen::Matrix<double, terms, terms>> solver(xtwx);
  const bool solvable = effective_count >= 4 * terms && solver.info() == Eigen::Success && solver.rcond() > 1e-12;
  if (solvable) linear = solver.solve(xtwn);
  double rss_mean = 0, rss_linear = 0;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    if (!used[i]) continue;
    rss_mean += samples[i].weight * (samples[i].normal - mean).squaredNorm();
    rss_linear += samples[i].weight * (samples[i].normal - linear.transpose() * samples[i].x).squaredNorm();
  }
  // Keep the slopes only when they explain far more than noise would (an F-test at a wide margin).
  const double noise_per_dof = rss_linear / std::max(1.0, effective_count - terms);
  const bool curved = solvable && rss_mean - rss_linear > 10 * (terms - 1) * noise_per_dof + 1e-30;
  result.coefficients = curved ? linear : Eigen::Matrix<double, terms, 3>::Zero();
  if (!curved) result.coefficients.row(0) = mean.transpose();
  result.spread_squared = (curved ? rss_linear : rss_mean) / w_sum;
  result.variance = result.spread_squared / effective_count;
  if (curved) result.variance *= w_sum * solver.solve(Terms::Unit(0))(0);  // (XᵀWX)⁻¹₀₀ relative to 1/Σw
  result.normal = result.coefficients.row(0).transpose();
  return result;
}

}  // namespace

SideNormal side_normal(const TriangleMesh& mesh, const FaceGeometry& faces, const std::vector<int>& region,
                       const Vec3& point, const Vec3& tangent) {
  SideNormal result;
  std::vector<Sample> samples;
  samples.reserve(region.size());
  for (int f : region) {
    const Vec3 offset = face_centroid(mesh, f) - point;
    const double s = offset.dot(tangent);
    samples.push_back({faces.areas[f], terms_at(s, (offset - s * tangent).norm()), faces.normals.row(f).transpose()});
  }
  std::vector<char> used(samples.size(), 1);
  Fit first = fit(samples, used);
  // Facets folded by noise where two sides meet are outliers with leverage on the value at the
  // edge: drop those far outside the spread and fit again.
  const double limit_squared = std::max(9 * first.spread_squared, 1e-12);
  for (std::size_t i = 0; i < samples.size(); ++i)
    used[i] = (samples[i].normal - first.coefficients.transpose() * samples[i].x).squaredNorm() <= limit_squared;
  const Fit second = fit(samples, used);
  const Fit& best = second.normal.squaredNorm() > 0 ? second : first;
  result.face_count = static_cast<int>(std::count(used.begin(), used.end(), 1));
  result.normal = best.normal.normalized();
  result.uncertainty_rad = std::sqrt(std::max(0.0, best.variance));
  result.facet_spread_rad = std::sqrt(best.spread_squared);
  return result;
}

}  // namespace cmm::geometry
