// Breadth-first region growth, then a robust weighted least-squares fit of the normal field.
#include "geometry/side_normal.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <numbers>
#include <unordered_set>
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
  std::vector<int> faces;  // the facet, or the facets of the plane piece it stands for
  Eigen::Quaterniond turn = Eigen::Quaterniond::Identity();  // applied to the facet's own normal
  Vec3 centroid = Vec3::Zero();  // of the facet, or of the plane piece it stands for
};

struct Fit {
  Vec3 normal;
  double spread_squared;
  Eigen::Matrix<double, terms, 3> coefficients;  // rows: the terms; columns: x, y, z
  // The normal at the point is Σ weight_f (uᵀx_f) n_f over the used samples.
  Terms intercept_weights;
  int parameters;
};

// `min_count`: the effective number of samples the slopes need; a noisy side needs several per term
// to tell a slope from noise, an exact one only one more than the terms.
Fit fit(const std::vector<Sample>& samples, const std::vector<char>& used, double min_count) {
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
  // A slope is only fitted along a coordinate the samples spread over: where they all sit at one
  // distance from the edge (the merged columns of a bore's wall, all at mid-height), taking the field
  // to the edge would extrapolate along a direction with no data. Such a term is left out.
  int active = 1;
  for (int k = 1; k < terms; ++k) {
    const double m = xtwx(0, k) / w_sum, spread = std::sqrt(std::max(0.0, xtwx(k, k) / w_sum - m * m));
    if (spread > 1e-9 && spread >= 0.2 * std::abs(m)) {
      ++active;
      continue;
    }
    xtwx.row(k).setZero(), xtwx.col(k).setZero(), xtwn.row(k).setZero();
    xtwx(k, k) = 1;
  }
  const double effective_count = w_sum * w_sum / w2_sum;
  Eigen::Matrix<double, terms, 3> linear = Eigen::Matrix<double, terms, 3>::Zero();
  linear.row(0) = mean.transpose();
  const Eigen::LDLT<Eigen::Matrix<double, terms, terms>> solver(xtwx);
  const bool solvable = active > 1 && effective_count >= min_count && solver.info() == Eigen::Success && solver.rcond() > 1e-12;
  if (solvable) linear = solver.solve(xtwn);
  double rss_mean = 0, rss_linear = 0;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    if (!used[i]) continue;
    rss_mean += samples[i].weight * (samples[i].normal - mean).squaredNorm();
    rss_linear += samples[i].weight * (samples[i].normal - linear.transpose() * samples[i].x).squaredNorm();
  }
  // Keep the slopes only when they explain far more than noise would (an F-test at a wide margin).
  const double noise_per_dof = rss_linear / std::max(1.0, effective_count - active);
  const bool curved = solvable && rss_mean - rss_linear > 10 * (active - 1) * noise_per_dof + 1e-30;
  result.coefficients = curved ? linear : Eigen::Matrix<double, terms, 3>::Zero();
  if (!curved) result.coefficients.row(0) = mean.transpose();
  result.spread_squared = (curved ? rss_linear : rss_mean) / w_sum;
  result.intercept_weights = curved ? Terms(solver.solve(Terms::Unit(0))) : Terms(Terms::Unit(0) / w_sum);
  result.parameters = curved ? active : 1;
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
                                const std::vector<char>& used, const Fit& fit, const Vec3& tangent,
                                std::optional<double> given_sigma_mm) {
  if (fit.normal.squaredNorm() == 0) return 0;
  // Only the normal's turn about the edge moves a probe window: its error along tangent × n.
  const Vec3 turn_direction = tangent.cross(fit.normal.normalized()).normalized();
  double weighted_residual = 0, weighted_gain = 0, w_sum = 0, w2_sum = 0;
  std::vector<std::pair<int, Vec3>> to_turn;  // per vertex and facet: ∂(that turn)/∂(vertex), summed below
  to_turn.reserve(3 * samples.size());
  for (std::size_t i = 0; i < samples.size(); ++i) {
    if (!used[i]) continue;
    const Sample& a = samples[i];
    // Facets that share one normal to 1e-9 have their vertices on one plane: whatever the mesh's figure
    // says of its vertices elsewhere, these carry no noise (a CAD plane cut into slivers would otherwise
    // state degrees from micrometres on facets a few micrometres wide).
    if (a.faces.size() > 1) continue;
    // The facet's normal enters the fit turned by a.turn, and its unit normal drops N's own direction:
    // d·(a.turn (I − nnᵀ) δN / |N|), with δN = [v_{k+2} − v_{k+1}]× δv_k for N = (v1 − v0) × (v2 − v0).
    const int face = a.faces.front();
    const Vec3 corner[3] = {vertex(mesh, mesh.faces(face, 0)), vertex(mesh, mesh.faces(face, 1)), vertex(mesh, mesh.faces(face, 2))};
    const double double_area = (corner[1] - corner[0]).cross(corner[2] - corner[0]).norm();
    if (!(double_area > 0)) continue;
    const Vec3 u = a.turn.conjugate() * Vec3(turn_direction - turn_direction.dot(a.normal) * a.normal);
    const double c = a.weight * fit.intercept_weights.dot(a.x) / double_area;
    double gain = 0;
    for (int k = 0; k < 3; ++k) {
      const Vec3 opposite = corner[(k + 2) % 3] - corner[(k + 1) % 3];
      gain += opposite.squaredNorm();
      to_turn.emplace_back(mesh.faces(face, k), c * u.cross(opposite));
    }
    weighted_residual += a.weight * (a.normal - fit.coefficients.transpose() * a.x).squaredNorm();
    weighted_gain += a.weight * gain / (double_area * double_area);
    w_sum += a.weight, w2_sum += a.weight * a.weight;
  }
  if (!(w_sum > 0) || (!(weighted_gain > 0) && !given_sigma_mm)) return 0;  // no facet here carries noise
  const double effective_count = w_sum * w_sum / w2_sum;
  const double dof = effective_count - fit.parameters;
  const double from_residuals = weighted_gain > 0 ? weighted_residual / weighted_gain * effective_count / std::max(1.0, dof) : 0;
  // A clean mesh's figure is the whole mesh's; where its facets here misfit the field by more (a
  // decimated patch whose vertices were moved), that local figure counts, once there are enough facets
  // to tell (three more than the field's terms).
  const double vertex_variance = !given_sigma_mm ? from_residuals
                                 : std::max(*given_sigma_mm * *given_sigma_mm, dof >= 3 ? from_residuals : 0.0);
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
Fit robust_fit(const std::vector<Sample>& samples, std::vector<char>& used, double min_count) {
  used.assign(samples.size(), 1);
  const Fit first = fit(samples, used, min_count);
  const double limit_squared = std::max(9 * first.spread_squared, 1e-12);
  for (std::size_t i = 0; i < samples.size(); ++i)
    used[i] = (samples[i].normal - first.coefficients.transpose() * samples[i].x).squaredNorm() <= limit_squared;
  const Fit second = fit(samples, used, min_count);
  if (second.normal.squaredNorm() > 0) return second;
  used.assign(samples.size(), 1);
  return first;
}

}  // namespace

namespace {

// Jackknife standard error of the fitted normal's turn about the edge: the fit repeated without each of
// up to 32 groups of facets in turn (a delete-a-group jackknife, so that a big region costs 32 fits).
// On a clean mesh the propagated vertex noise says nothing of facets that lie together (a decimated
// patch whose vertices the collapse moved, a few large facets taken to the edge): how much the answer
// hangs on single facets does. Nothing on an exact plane or a regular fan.
double jackknife_uncertainty(const std::vector<Sample>& samples, const std::vector<char>& used, const Fit& full,
                             const Vec3& tangent, double min_count) {
  const Vec3 reference = full.normal.normalized();
  const Vec3 in_plane = tangent.cross(reference);
  const auto count = static_cast<std::size_t>(std::count(used.begin(), used.end(), 1));
  const std::size_t groups = std::min<std::size_t>(count, 32);
  if (groups < 2) return 0;
  std::vector<std::size_t> group_of(samples.size(), 0);
  for (std::size_t i = 0, k = 0; i < samples.size(); ++i)
    if (used[i]) group_of[i] = k++ % groups;
  std::vector<double> turns;
  std::vector<char> without(samples.size());
  for (std::size_t g = 0; g < groups; ++g) {
    for (std::size_t i = 0; i < samples.size(); ++i) without[i] = used[i] && group_of[i] != g;
    const Fit partial = fit(samples, without, min_count);
    if (partial.normal.squaredNorm() == 0) continue;
    turns.push_back(std::asin(std::clamp(partial.normal.normalized().dot(in_plane), -1.0, 1.0)));
  }
  const auto n = static_cast<double>(turns.size());
  if (n < 2) return 0;
  double mean = 0;
  for (double t : turns) mean += t / n;
  double sum = 0;
  for (double t : turns) sum += (t - mean) * (t - mean);
  return std::sqrt((n - 1) / n * sum);
}

// The clean mesh's share, sized for a window's margin (3.5 of it): 5/8 of the fit's correction of the
// seed facet in the cross-section plane (the facet is exact half a row from the edge, and what the linear
// fit leaves of that is second order: on the test parts' CAD rows of 5° and 18°, at most 0.58 of it), or,
// where the facets lie at enough distances from the edge to tell, 5/4 of what a square term across the
// edge would move it (`square_shift`, NaN when it cannot be told) when that is less; and the
// second-order part (1 − cos β ≈ β²/2) of its turn β along the edge.
double tessellation_uncertainty(const SideNormal& fitted, const Vec3& seed_normal, const Vec3& tangent, double square_shift) {
  const Vec3 in_plane = tangent.cross(fitted.normal);
  const double across = std::asin(std::clamp((seed_normal - fitted.normal).dot(in_plane), -1.0, 1.0));
  const double along = std::asin(std::clamp((seed_normal - fitted.normal).dot(tangent), -1.0, 1.0));
  const double left = std::isnan(square_shift) ? 0.625 * std::abs(across) : std::min(0.625 * std::abs(across), 1.25 * std::abs(square_shift));
  return (left + along * along / 2) / 3.5;
}

// The fitted normal, and how far the fitted field turns, at the edge facet's own place, from that facet
// about the edge: a field that misses the very facet touching the edge does not describe the side there.
struct FittedSide {
  SideNormal side;
  double edge_facet_misfit_rad = 0;
  double square_term_shift_rad = std::numeric_limits<double>::quiet_NaN();  // see square_term_shift
};

FittedSide fitted_side_normal(const TriangleMesh& mesh, const FaceGeometry& faces, const std::vector<int>& region,
                              const Vec3& point, const Vec3& tangent, const Vec3& turn,
                              std::optional<double> clean_sigma_mm);

// The turn about the edge from the facet touching it (region.front()) to the facets of the next two rows:
// whether the side is a plane at the edge.
double chord_angle(const TriangleMesh& mesh, const FaceGeometry& faces, const std::vector<int>& region,
                   const Vec3& point, const Vec3& tangent) {
  const int seed = region.front();
  const Vec3 in_plane = tangent.cross(Vec3(faces.normals.row(seed).transpose()));
  auto across = [&](const Vec3& p) {
    const Vec3 offset = p - point;
    return (offset - offset.dot(tangent) * tangent).norm();
  };
  double height = 0;
  for (int k = 0; k < 3; ++k) height = std::max(height, across(vertex(mesh, mesh.faces(seed, k))));
  const double depth = across(face_centroid(mesh, seed));
  double chord = 0;
  for (int f : region) {
    const double d = across(face_centroid(mesh, f));
    if (d > 1.01 * depth && d <= depth + 2 * height)
      chord = std::max(chord, std::abs(std::asin(std::clamp(faces.normals.row(f).dot(in_plane), -1.0, 1.0))));
  }
  return chord;
}

// The plane piece touching the edge (the facets joined to region.front() across shared
// edges with its very normal: a CAD quad, a chamfer strip) to the facets bordering that piece, whole (a
// uniform mesh's neighbours sit beside the facet as often as beyond it, and turn about the edge little):
// the facet's chord angle. The piece is exact somewhere inside it, so at the edge its normal is off by
// less than that; a fit that corrects it by more follows the side beyond the next row.
struct EdgePiece {
  std::size_t facets = 1;
  double chord_rad = 0;
};

EdgePiece edge_piece(const TriangleMesh& mesh, const FaceGeometry& faces, const std::vector<int>& region,
                     const Vec3& point, const Vec3& tangent) {
  const int seed = region.front();
  const Vec3 normal = faces.normals.row(seed).transpose();
  // Only the piece beside the point: a strip along a curved edge turns with it farther along.
  double reach = 0;
  for (int k = 0; k < 3; ++k) reach = std::max(reach, std::abs((vertex(mesh, mesh.faces(seed, k)) - point).dot(tangent)));
  const auto vertices = static_cast<std::int64_t>(mesh.vertices.rows());
  std::vector<std::pair<std::int64_t, int>> edge_faces;  // (edge, face), sorted by edge
  edge_faces.reserve(3 * region.size());
  auto edge_of = [&](int f, int k) {
    const int a = mesh.faces(f, k), b = mesh.faces(f, (k + 1) % 3);
    return std::min(a, b) * vertices + std::max(a, b);
  };
  for (int f : region)
    for (int k = 0; k < 3; ++k) edge_faces.emplace_back(edge_of(f, k), f);
  std::sort(edge_faces.begin(), edge_faces.end());
  std::vector<int> piece = {seed}, border;
  std::unordered_set<int> seen = {seed};
  for (std::size_t i = 0; i < piece.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      const std::int64_t edge = edge_of(piece[i], k);
      for (auto it = std::lower_bound(edge_faces.begin(), edge_faces.end(), std::pair{edge, -1});
           it != edge_faces.end() && it->first == edge; ++it) {
        if (!seen.insert(it->second).second) continue;
        const bool coplanar = faces.normals.row(it->second).dot(normal.transpose()) > 1 - 1e-12 &&
                              std::abs((face_centroid(mesh, it->second) - point).dot(tangent)) <= reach;
        (coplanar ? piece : border).push_back(it->second);
      }
    }
  EdgePiece result{piece.size(), 0.0};
  for (int g : border)
    result.chord_rad = std::max(result.chord_rad, std::acos(std::clamp(faces.normals.row(g).dot(normal.transpose()), -1.0, 1.0)));
  return result;
}

// Standard error of one facet's normal turn about the edge when each of its vertices carries noise σ:
// the turn is u·δN/|N| with u = tangent × n, and δN = [v_{k+2} − v_{k+1}]× δv_k.
double facet_turn_noise(const TriangleMesh& mesh, int face, const Vec3& normal, const Vec3& tangent, double sigma_mm) {
  const Vec3 corner[3] = {vertex(mesh, mesh.faces(face, 0)), vertex(mesh, mesh.faces(face, 1)), vertex(mesh, mesh.faces(face, 2))};
  const double double_area = (corner[1] - corner[0]).cross(corner[2] - corner[0]).norm();
  if (!(double_area > 0)) return 0;
  const Vec3 u = tangent.cross(normal);
  double sum = 0;
  for (int k = 0; k < 3; ++k) sum += u.cross(Vec3(corner[(k + 2) % 3] - corner[(k + 1) % 3])).squaredNorm();
  return sigma_mm * std::sqrt(sum) / double_area;
}

}  // namespace

SideNormal side_normal(const TriangleMesh& mesh, const FaceGeometry& faces, const std::vector<int>& region,
                       const Vec3& point, const Vec3& tangent, const Vec3& turn, std::optional<CleanNoise> clean) {
  std::optional<double> clean_sigma_mm;
  if (clean) clean_sigma_mm = clean->region_sigma_mm;
  const FittedSide fitted = fitted_side_normal(mesh, faces, region, point, tangent, turn, clean_sigma_mm);
  SideNormal result = fitted.side;
  if (!clean_sigma_mm || region.empty() || result.normal.squaredNorm() == 0) return result;
  // Where the mesh's vertices lie on its surface (within 5 µm: a facet of 1 mm is then exact to 0.3°),
  // the plane piece touching the edge carries the side to within its chord angle: the turn to the facets
  // bordering it (and no more than the turn over the next two rows). A fit that moves the normal farther
  // than that, or whose field misses the very facet at the edge by over half what it moves, follows
  // something the facets at the edge do not show (a blend beyond them, a blade's rounded nose): the facet
  // is kept then, with half that chord angle and its own vertex noise as its error. A decimated mesh's
  // facets are not exact (its vertices were moved), and there the fit stands.
  const Vec3 seed = faces.normals.row(region.front()).transpose();
  const double chord = chord_angle(mesh, faces, region, point, tangent);
  const double correction = std::abs(std::asin(std::clamp(result.normal.dot(tangent.cross(seed)), -1.0, 1.0)));
  constexpr double slack = 0.1 * std::numbers::pi / 180;
  // Facets coplanar with the seed for two rows: the side is a plane at the edge, and the facet is exact
  // there whatever a wider fit says of the blend beyond.
  const bool planar = chord < 1e-6;
  const bool exact_facets = planar || clean->mesh_sigma_mm < 0.005;
  const bool misses_edge_facet = fitted.edge_facet_misfit_rad > std::max(slack, correction / 2);
  // The piece only matters where the fit moved the facet at all (on a plane it did not).
  const bool check = exact_facets && (correction > slack || misses_edge_facet);
  const EdgePiece piece = check ? edge_piece(mesh, faces, region, point, tangent) : EdgePiece{1, chord};
  const double bound = std::min(chord, piece.chord_rad);
  if (check && (correction > bound + slack || misses_edge_facet)) {
    // The facet's own error, not the fit's: none on a plane piece of several facets (its vertices lie on
    // one plane), the vertex noise through its corners on a lone facet.
    const double own = piece.facets > 1 ? 0.0 : facet_turn_noise(mesh, region.front(), seed, tangent, clean->mesh_sigma_mm);
    result.normal = seed;
    result.uncertainty_rad = std::hypot(own, (bound / 2 + slack) / 3.5);
    return result;
  }
  result.uncertainty_rad = std::hypot(result.uncertainty_rad, tessellation_uncertainty(result, seed, tangent, fitted.square_term_shift_rad));
  return result;
}

namespace {

// How far a square term across the edge moves the fitted field's turn about the edge at the edge: what
// the linear field, taken to the edge, leaves of a side whose normal turns unevenly across it (exactly
// so where the turn is quadratic). NaN unless the samples sit at five or more distances from the edge:
// a square needs three, and two more to tell it from the tessellation.
double square_term_shift(const std::vector<Sample>& samples, const std::vector<char>& used, const Fit& fit,
                         const Vec3& tangent) {
  constexpr double none = std::numeric_limits<double>::quiet_NaN();
  if (fit.normal.squaredNorm() == 0) return none;
  const Vec3 in_plane = tangent.cross(fit.normal.normalized());
  Eigen::Matrix4d square = Eigen::Matrix4d::Zero();
  Eigen::Vector4d square_y = Eigen::Vector4d::Zero();
  std::vector<double> depths;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    if (!used[i]) continue;
    const Sample& a = samples[i];
    const double y = std::asin(std::clamp(a.normal.dot(in_plane), -1.0, 1.0)), d = a.x(2);
    const Eigen::Vector4d q(1.0, a.x(1), d, d * d);
    square += a.weight * q * q.transpose();
    square_y += a.weight * y * q;
    depths.push_back(d);
  }
  std::sort(depths.begin(), depths.end());
  const double scale = depths.empty() ? 0 : depths.back();
  int distinct = depths.empty() ? 0 : 1;
  for (std::size_t i = 1; i < depths.size(); ++i) distinct += depths[i] - depths[i - 1] > 1e-3 * scale;
  if (distinct < 5) return none;
  const Eigen::Matrix3d linear = square.topLeftCorner<3, 3>();
  const Eigen::LDLT<Eigen::Matrix4d> with_square(square);
  const Eigen::LDLT<Eigen::Matrix3d> without(linear);
  if (with_square.info() != Eigen::Success || without.info() != Eigen::Success || !(with_square.rcond() > 1e-12) ||
      !(without.rcond() > 1e-12))
    return none;
  const Eigen::Vector3d linear_y = square_y.head<3>();
  return with_square.solve(square_y)(0) - without.solve(linear_y)(0);
}

double misfit_at(const Fit& fit, const Sample& sample, const Vec3& tangent) {
  const Vec3 predicted = fit.coefficients.transpose() * sample.x;
  if (predicted.squaredNorm() == 0) return 0;
  const Vec3 in_plane = tangent.cross(predicted.normalized());
  return std::abs(std::asin(std::clamp(sample.normal.dot(in_plane), -1.0, 1.0)));
}

FittedSide fitted_side_normal(const TriangleMesh& mesh, const FaceGeometry& faces, const std::vector<int>& region,
                              const Vec3& point, const Vec3& tangent, const Vec3& turn,
                              std::optional<double> clean_sigma_mm) {
  SideNormal result;
  std::vector<Sample> samples;
  samples.reserve(region.size());
  // On a clean mesh, facets with one normal are one plane piece (a CAD quad cut in two, a planar face cut
  // in many): their normal is exact at the piece's centroid, not at each triangle's, which would put one
  // normal at two distances from the edge and flatten the fitted slope.
  std::map<std::array<double, 3>, std::size_t> piece_of;
  std::vector<Vec3> moments;  // area × centroid, per sample
  for (int f : region) {
    const Vec3 n = faces.normals.row(f).transpose();
    const std::array<double, 3> key{std::round(n.x() * 1e9), std::round(n.y() * 1e9), std::round(n.z() * 1e9)};
    const auto [it, added] = clean_sigma_mm ? piece_of.try_emplace(key, samples.size()) : std::pair{piece_of.end(), true};
    if (!added) {
      samples[it->second].weight += faces.areas[f];
      samples[it->second].faces.push_back(f);
      moments[it->second] += faces.areas[f] * face_centroid(mesh, f);
      continue;
    }
    samples.push_back({faces.areas[f], Terms::Zero(), n, {f}, Eigen::Quaterniond::Identity()});
    moments.push_back(faces.areas[f] * face_centroid(mesh, f));
  }
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const Vec3 centroid = samples[i].weight > 0 ? Vec3(moments[i] / samples[i].weight) : face_centroid(mesh, samples[i].faces.front());
    const Vec3 offset = centroid - point;
    const double s = offset.dot(tangent);
    samples[i].x = terms_at(s, (offset - s * tangent).norm());
    samples[i].centroid = centroid;
  }
  std::vector<char> used;
  const double min_count = clean_sigma_mm ? terms + 1 : 4 * terms;
  const Fit plain = robust_fit(samples, used, min_count);
  result.face_count = static_cast<int>(std::count(used.begin(), used.end(), 1));
  result.normal = plain.normal.normalized();
  result.facet_spread_rad = std::sqrt(plain.spread_squared);
  const double curvature = turn.norm();
  if (!(curvature > 1e-6) || plain.normal.squaredNorm() == 0) {
    result.uncertainty_rad = vertex_noise_uncertainty(mesh, samples, used, plain, tangent, clean_sigma_mm);
    if (clean_sigma_mm && plain.normal.squaredNorm() > 0)
      result.uncertainty_rad = std::max(result.uncertainty_rad, jackknife_uncertainty(samples, used, plain, tangent, min_count));
    if (samples.empty()) return {result};
    return {result, misfit_at(plain, samples.front(), tangent), square_term_shift(samples, used, plain, tangent)};
  }

  // A rim is taken as a circle of radius 1/|turn| about `axis`: both sides turn about it, exactly so
  // on a surface of revolution, so each facet is turned back by its angle about that axis and the
  // field fitted again. That removes the lean across the edge; along the edge (where the tangent
  // comes from) the turned facets are noisier than the plain fit's slope, so that part is kept.
  const Vec3 axis = turn / curvature;
  const Vec3 to_point = -axis.cross(tangent).normalized() / curvature;  // centre of curvature → point
  std::vector<Sample> turned = samples;
  for (Sample& a : turned) {
    const Vec3 from_axis = a.centroid - point + to_point;
    const Vec3 across_axis = from_axis - from_axis.dot(axis) * axis;
    const double angle = std::atan2(axis.dot(to_point.cross(across_axis)), to_point.dot(across_axis));
    a.turn = Eigen::AngleAxisd(-angle, axis);
    a.normal = a.turn * a.normal;
  }
  std::vector<char> turned_used;
  const Fit fitted = robust_fit(turned, turned_used, min_count);
  if (fitted.normal.squaredNorm() == 0) {
    result.uncertainty_rad = vertex_noise_uncertainty(mesh, samples, used, plain, tangent, clean_sigma_mm);
    return {result, misfit_at(plain, samples.front(), tangent), square_term_shift(samples, used, plain, tangent)};
  }
  const Vec3 across = fitted.normal.normalized();
  result.normal = (across - across.dot(tangent) * tangent + result.normal.dot(tangent) * tangent).normalized();
  result.uncertainty_rad = vertex_noise_uncertainty(mesh, turned, turned_used, fitted, tangent, clean_sigma_mm);
  if (clean_sigma_mm)
    result.uncertainty_rad = std::max(result.uncertainty_rad, jackknife_uncertainty(turned, turned_used, fitted, tangent, min_count));
  result.face_count = static_cast<int>(std::count(turned_used.begin(), turned_used.end(), 1));
  result.facet_spread_rad = std::sqrt(fitted.spread_squared);  // about the field the turn left
  return {result, misfit_at(fitted, turned.front(), tangent), square_term_shift(turned, turned_used, fitted, tangent)};
}

}  // namespace

}  // namespace cmm::geometry
