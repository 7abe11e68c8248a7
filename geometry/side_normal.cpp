// Breadth-first region growth, then a robust weighted least-squares fit of the normal field.
#include "geometry/side_normal.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

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
  int face;
  Eigen::Quaterniond turn = Eigen::Quaterniond::Identity();  // applied to the facet's own normal
};

struct Fit {
  Vec3 normal;
  double spread_squared;
  Eigen::Matrix<double, terms, 3> coefficients;  // rows: the terms; columns: x, y, z
  // The normal at the point is Σ weight_f (uᵀx_f) n_f over the used samples.
  Terms intercept_weights;
  int parameters;
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
  Fit result{Vec3::Zero(), 0, Eigen::Matrix<double, terms, 3>::Zero(), Terms::Zero(), 1};
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
  result.intercept_weights = curved ? Terms(solver.solve(Terms::Unit(0))) : Terms(Terms::Unit(0) / w_sum);
  result.parameters = curved ? terms : 1;
  result.normal = result.coefficients.row(0).transpose();
  return result;
}

// Standard error of the fitted normal's turn about the edge when each vertex carries independent noise.
// Facet normals sharing a vertex are not independent: a raised vertex tilts its facets opposite
// ways, and over a patch these cancel (a patch's mean normal depends on its rim alone). Treating
// facets as independent overstates the error 1.5–3× on the test parts, and a window's margin with it.
// So the vertex noise is estimated from the facets' residuals (E|δn_f|² = σ_v² Σ_v |∂n_f/∂v|²) and
// carried through the fit's linear weights to the normal by the chain rule, vertex by vertex.
double vertex_noise_uncertainty(const TriangleMesh& mesh, const std::vector<Sample>& samples,
                                const std::vector<char>& used, const Fit& fit, const Vec3& tangent) {
  if (fit.normal.squaredNorm() == 0) return 0;
  // Only the normal's turn about the edge moves a probe window: its error along tangent × n.
  const Vec3 turn_direction = tangent.cross(fit.normal.normalized()).normalized();
  double weighted_residual = 0, weighted_gain = 0, w_sum = 0, w2_sum = 0;
  std::vector<std::pair<int, Vec3>> to_turn;  // per vertex and facet: ∂(that turn)/∂(vertex), summed below
  to_turn.reserve(3 * samples.size());
  for (std::size_t i = 0; i < samples.size(); ++i) {
    if (!used[i]) continue;
    const Sample& a = samples[i];
    const Vec3 corner[3] = {vertex(mesh, mesh.faces(a.face, 0)), vertex(mesh, mesh.faces(a.face, 1)),
                            vertex(mesh, mesh.faces(a.face, 2))};
    const double double_area = (corner[1] - corner[0]).cross(corner[2] - corner[0]).norm();
    if (!(double_area > 0)) continue;
    // The facet's normal enters the fit turned by a.turn, and its unit normal drops N's own direction:
    // d·(a.turn (I − nnᵀ) δN / |N|), with δN = [v_{k+2} − v_{k+1}]× δv_k for N = (v1 − v0) × (v2 − v0).
    const Vec3 u = a.turn.conjugate() * Vec3(turn_direction - turn_direction.dot(a.normal) * a.normal);
    const double c = a.weight * fit.intercept_weights.dot(a.x) / double_area;
    double gain = 0;
    for (int k = 0; k < 3; ++k) {
      const Vec3 opposite = corner[(k + 2) % 3] - corner[(k + 1) % 3];
      gain += opposite.squaredNorm();
      to_turn.emplace_back(mesh.faces(a.face, k), c * u.cross(opposite));
    }
    weighted_residual += a.weight * (a.normal - fit.coefficients.transpose() * a.x).squaredNorm();
    weighted_gain += a.weight * gain / (double_area * double_area);
    w_sum += a.weight, w2_sum += a.weight * a.weight;
  }
  if (!(weighted_gain > 0)) return 0;
  const double effective_count = w_sum * w_sum / w2_sum;
  const double vertex_variance =
      weighted_residual / weighted_gain * effective_count / std::max(1.0, effective_count - fit.parameters);
  std::sort(to_turn.begin(), to_turn.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
  double sum = 0;
  for (std::size_t i = 0; i < to_turn.size();) {
    Vec3 gradient = Vec3::Zero();
    const int v = to_turn[i].first;
    for (; i < to_turn.size() && to_turn[i].first == v; ++i) gradient += to_turn[i].second;
    sum += gradient.squaredNorm();
  }
  return std::sqrt(vertex_variance * sum) / fit.normal.norm();
}

// The fit with one robust refit: facets folded by noise where two sides meet are outliers with
// leverage on the value at the edge, so those far outside the spread are dropped and the field
// fitted again. `used` says which facets the returned fit rests on.
Fit robust_fit(const std::vector<Sample>& samples, std::vector<char>& used) {
  used.assign(samples.size(), 1);
  const Fit first = fit(samples, used);
  const double limit_squared = std::max(9 * first.spread_squared, 1e-12);
  for (std::size_t i = 0; i < samples.size(); ++i)
    used[i] = (samples[i].normal - first.coefficients.transpose() * samples[i].x).squaredNorm() <= limit_squared;
  const Fit second = fit(samples, used);
  if (second.normal.squaredNorm() > 0) return second;
  used.assign(samples.size(), 1);
  return first;
}

}  // namespace

SideNormal side_normal(const TriangleMesh& mesh, const FaceGeometry& faces, const std::vector<int>& region,
                       const Vec3& point, const Vec3& tangent, const Vec3& turn) {
  SideNormal result;
  std::vector<Sample> samples;
  samples.reserve(region.size());
  for (int f : region) {
    const Vec3 offset = face_centroid(mesh, f) - point;
    const double s = offset.dot(tangent);
    samples.push_back({faces.areas[f], terms_at(s, (offset - s * tangent).norm()), faces.normals.row(f).transpose(), f,
                       Eigen::Quaterniond::Identity()});
  }
  std::vector<char> used;
  const Fit plain = robust_fit(samples, used);
  result.face_count = static_cast<int>(std::count(used.begin(), used.end(), 1));
  result.normal = plain.normal.normalized();
  result.facet_spread_rad = std::sqrt(plain.spread_squared);
  const double curvature = turn.norm();
  if (!(curvature > 1e-6) || plain.normal.squaredNorm() == 0) {
    result.uncertainty_rad = vertex_noise_uncertainty(mesh, samples, used, plain, tangent);
    return result;
  }

  // A rim is taken as a circle of radius 1/|turn| about `axis`: both sides turn about it, exactly so
  // on a surface of revolution, so each facet is turned back by its angle about that axis and the
  // field fitted again. That removes the lean across the edge; along the edge (where the tangent
  // comes from) the turned facets are noisier than the plain fit's slope, so that part is kept.
  const Vec3 axis = turn / curvature;
  const Vec3 to_point = -axis.cross(tangent).normalized() / curvature;  // centre of curvature → point
  std::vector<Sample> turned = samples;
  for (Sample& a : turned) {
    const Vec3 from_axis = face_centroid(mesh, a.face) - point + to_point;
    const Vec3 across_axis = from_axis - from_axis.dot(axis) * axis;
    const double angle = std::atan2(axis.dot(to_point.cross(across_axis)), to_point.dot(across_axis));
    a.turn = Eigen::AngleAxisd(-angle, axis);
    a.normal = a.turn * a.normal;
  }
  std::vector<char> turned_used;
  const Fit fitted = robust_fit(turned, turned_used);
  if (fitted.normal.squaredNorm() == 0) {
    result.uncertainty_rad = vertex_noise_uncertainty(mesh, samples, used, plain, tangent);
    return result;
  }
  const Vec3 across = fitted.normal.normalized();
  result.normal = (across - across.dot(tangent) * tangent + result.normal.dot(tangent) * tangent).normalized();
  result.uncertainty_rad = vertex_noise_uncertainty(mesh, turned, turned_used, fitted, tangent);
  result.face_count = static_cast<int>(std::count(turned_used.begin(), turned_used.end(), 1));
  result.facet_spread_rad = std::sqrt(fitted.spread_squared);  // about the field the turn left
  return result;
}

}  // namespace cmm::geometry
