// Each irregular raw point (one per half-bin cell) looks at the regular points around it: when their
// normals fall into two groups more than the crease angle apart, the planes fitted to the two groups
// meet in a line through the crease (three groups: a corner, where three planes meet in a point).
// The local lines are walked into polylines, joined to the corners they run into, and resampled
// every ≈ B with each point put back on its nearest local line, so a straight crease stays exact.
#include "geometry/crease_points.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <unordered_map>

#include "geometry/point_grid.hpp"

namespace cmm::geometry {
namespace {

struct Plane {
  Vec3 normal = Vec3::UnitZ();
  double offset = 0;  // normal · x = offset
  double rms = 0;
  double inliers = 1;  // fraction of the group the trimmed fit kept
};

// What one irregular raw point sees: a crease line through it, a corner near it, or nothing.
struct LocalCrease {
  int sides = 0;  // 0 nothing, 2 crease, 3 corner
  Vec3 position = Vec3::Zero();
  Vec3 direction = Vec3::Zero();
  std::array<Vec3, 3> normals{Vec3::UnitZ(), Vec3::UnitZ(), Vec3::UnitZ()};
};

double cos_deg(double deg) { return std::cos(deg * std::numbers::pi / 180); }

Vec3 point(const Points& p, int i) { return p.row(i).transpose(); }

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

double scan_noise(const std::vector<LocalSurface>& fits) {
  std::vector<double> r;
  for (const LocalSurface& f : fits)
    if (f.regular) r.push_back(f.residual_rms_mm);
  return median(std::move(r));
}

Plane fit_plane(const Points& raw, const std::vector<int>& ids) {
  Vec3 centroid = Vec3::Zero();
  for (int i : ids) centroid += point(raw, i);
  centroid /= static_cast<double>(ids.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (int i : ids) {
    const Vec3 d = point(raw, i) - centroid;
    cov += d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  Plane plane;
  plane.normal = eig.eigenvectors().col(0).normalized();
  plane.offset = plane.normal.dot(centroid);
  plane.rms = std::sqrt(std::max(0.0, eig.eigenvalues()(0)) / static_cast<double>(ids.size()));
  return plane;
}

// Trims the points a neighbouring face lent the group (their normals were blended) before the
// final fit: on exact data the plane comes out exact.
Plane robust_plane(const Points& raw, std::vector<int> ids, double floor) {
  const double total = static_cast<double>(ids.size());
  Plane plane = fit_plane(raw, ids);
  for (int round = 0; round < 3; ++round) {
    std::vector<double> residual;
    for (int i : ids) residual.push_back(std::abs(plane.normal.dot(point(raw, i)) - plane.offset));
    const double threshold = std::max(floor, 3 * 1.4826 * median(residual));
    std::vector<int> kept;
    for (std::size_t k = 0; k < ids.size(); ++k)
      if (residual[k] <= threshold) kept.push_back(ids[k]);
    if (kept.size() == ids.size() || kept.size() < 6) break;
    ids = std::move(kept);
    plane = fit_plane(raw, ids);
  }
  plane.inliers = static_cast<double>(ids.size()) / total;
  return plane;
}

// k-means on unoriented normals from the given seeds; returns the group of each normal.
std::vector<int> group_normals(const std::vector<Vec3>& normals, std::vector<Vec3>& seeds) {
  std::vector<int> group(normals.size(), 0);
  for (int iteration = 0; iteration < 6; ++iteration) {
    std::vector<Vec3> sums(seeds.size(), Vec3::Zero());
    for (std::size_t i = 0; i < normals.size(); ++i) {
      int best = 0;
      for (std::size_t k = 1; k < seeds.size(); ++k)
        if (std::abs(normals[i].dot(seeds[k])) > std::abs(normals[i].dot(seeds[best]))) best = static_cast<int>(k);
      group[i] = best;
      sums[best] += normals[i].dot(seeds[best]) < 0 ? -normals[i] : normals[i];
    }
    for (std::size_t k = 0; k < seeds.size(); ++k)
      if (sums[k].norm() > 0) seeds[k] = sums[k].normalized();
  }
  return group;
}

// The normal farthest (unoriented) from all of `seeds`, and its |cos| to the nearest of them.
std::pair<Vec3, double> farthest_normal(const std::vector<Vec3>& normals, const std::vector<Vec3>& seeds) {
  Vec3 best = normals.front();
  double best_cos = 2;
  for (const Vec3& n : normals) {
    double c = 0;
    for (const Vec3& s : seeds) c = std::max(c, std::abs(n.dot(s)));
    if (c < best_cos) best_cos = c, best = n;
  }
  return {best, best_cos};
}

// A face's trace in a section square to a crease: a line through `centre` along `along`. Its offset is
// known to offset_variance + slope_variance·u² at u along it from the centre (both 0 for a plane's trace,
// which is not fitted here).
struct TraceLine {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero(), along = Eigen::Vector2d::UnitX();
  double offset_variance = 0, slope_variance = 0;
};

struct Analysis {
  const Points& raw;
  const std::vector<LocalSurface>& fits;
  const CloudIndex& index;
  double bin, cos_crease, half_crease_angle, plane_floor, plane_tolerance;

  // Splits the regular neighbours into `sides` groups of distinct normals; empty when they do not split.
  std::vector<std::vector<int>> split(const std::vector<int>& members, const std::vector<Vec3>& normals, int sides,
                                      std::size_t share) const {
    std::vector<Vec3> seeds{normals.front()};
    while (static_cast<int>(seeds.size()) < sides) {
      const auto [far, c] = farthest_normal(normals, seeds);
      if (c > cos_crease) return {};
      seeds.push_back(far);
    }
    const std::vector<int> group = group_normals(normals, seeds);
    for (std::size_t i = 0; i < seeds.size(); ++i)
      for (std::size_t j = i + 1; j < seeds.size(); ++j)
        if (std::abs(seeds[i].dot(seeds[j])) > cos_crease) return {};
    if (share > 10 && (!separate(normals, group, seeds) || !flat(normals, group, seeds))) return {};
    std::vector<std::vector<int>> groups(seeds.size());
    for (std::size_t i = 0; i < members.size(); ++i) groups[group[i]].push_back(members[i]);
    const std::size_t min_size = std::max<std::size_t>(6, members.size() / share);
    for (const auto& g : groups)
      if (g.size() < min_size) return {};
    return groups;
  }

  // Faces that meet at a crease leave a gap between their normals; a face curving through a wide
  // neighbourhood (a bore's wall) fills it, and splitting it into planes puts a crease on the wall. So of
  // any two groups at most a tenth of their normals may lie nearer than half the crease angle to the
  // bisector between them.
  bool separate(const std::vector<Vec3>& normals, const std::vector<int>& group, const std::vector<Vec3>& seeds) const {
    const std::size_t n = seeds.size();
    std::vector<std::size_t> size(n, 0), between(n * n, 0);
    for (std::size_t i = 0; i < normals.size(); ++i) {
      const std::size_t g = static_cast<std::size_t>(group[i]);
      ++size[g];
      const double own = std::acos(std::min(1.0, std::abs(normals[i].dot(seeds[g]))));
      for (std::size_t k = 0; k < n; ++k)
        if (k != g && std::acos(std::min(1.0, std::abs(normals[i].dot(seeds[k])))) - own < half_crease_angle)
          ++between[std::min(g, k) * n + std::max(g, k)];
    }
    for (std::size_t g = 0; g < n; ++g)
      for (std::size_t k = g + 1; k < n; ++k)
        if (10 * between[g * n + k] > size[g] + size[k]) return false;
    return true;
  }

  // Over a wide neighbourhood a bore's wall turns: its normals spread about its group's, where a flat
  // face's scatter by the noise only (a few degrees). 90 % of each group within a third of the crease
  // angle of its seed, or it is no plane.
  bool flat(const std::vector<Vec3>& normals, const std::vector<int>& group, const std::vector<Vec3>& seeds) const {
    std::vector<std::size_t> size(seeds.size(), 0), wide(seeds.size(), 0);
    const double limit = std::cos(2 * half_crease_angle / 3);
    for (std::size_t i = 0; i < normals.size(); ++i) {
      const std::size_t g = static_cast<std::size_t>(group[i]);
      ++size[g];
      wide[g] += std::abs(normals[i].dot(seeds[g])) < limit;
    }
    for (std::size_t g = 0; g < seeds.size(); ++g)
      if (10 * wide[g] > size[g]) return false;
    return true;
  }

  // The group's points lie on one side of the crease line, as a face ends at its crease.
  bool one_sided(const std::vector<int>& group, const Vec3& normal, const Vec3& on_line, const Vec3& direction) const {
    const Vec3 across = normal.cross(direction);
    int positive = 0, negative = 0;
    for (int i : group) {
      const double s = (point(raw, i) - on_line).dot(across);
      if (s > 0.05 * bin) ++positive;
      if (s < -0.05 * bin) ++negative;
    }
    return std::min(positive, negative) <= (positive + negative) / 10;
  }

  // The line found is at most `reach` from the irregular point that looked for it.
  LocalCrease crease(const Vec3& x0, const std::vector<std::vector<int>>& groups, double reach) const {
    Plane p[2];
    for (int k = 0; k < 2; ++k) {
      p[k] = robust_plane(raw, groups[k], plane_floor);
      if (p[k].rms > plane_tolerance || p[k].inliers < 0.8) return {};
    }
    const double c = p[0].normal.dot(p[1].normal);
    if (std::abs(c) > cos_crease) return {};
    // The point of the line nearest x0: x0 + α n0 + β n1 on both planes.
    const double r0 = p[0].offset - p[0].normal.dot(x0), r1 = p[1].offset - p[1].normal.dot(x0);
    const double det = 1 - c * c;
    const double alpha = (r0 - c * r1) / det, beta = (r1 - c * r0) / det;
    LocalCrease out;
    out.position = x0 + alpha * p[0].normal + beta * p[1].normal;
    if ((out.position - x0).norm() > reach) return {};
    out.direction = p[0].normal.cross(p[1].normal).normalized();
    for (int k = 0; k < 2; ++k)
      if (!one_sided(groups[k], p[k].normal, out.position, out.direction)) return {};
    out.sides = 2;
    out.normals = {p[0].normal, p[1].normal, p[1].normal};
    refine_in_profile(out, face_points(out.position, p, 2 * reach));
    return out;
  }

  // The raw points of each of the two faces near a crease point, regular or not: within the face's band
  // about its plane, nearer to it than to the other plane and clear of the other plane's band (the points
  // along the crease itself belong to neither). Near a crease most fits are irregular, and on a face
  // scanned at a tenth of its neighbour's density all of them are: the regular points alone leave its
  // profile too few points, and its secant plane stands.
  std::array<std::vector<int>, 2> face_points(const Vec3& at, const Plane (&p)[2], double radius) const {
    std::array<std::vector<int>, 2> out;
    double clear[2];
    for (int k = 0; k < 2; ++k) clear[k] = std::max(3 * p[k].rms, plane_floor) + 0.1 * bin;
    for (int j : index.within(at, radius)) {
      const Vec3 x = point(raw, j);
      const double d[2] = {std::abs(p[0].normal.dot(x) - p[0].offset), std::abs(p[1].normal.dot(x) - p[1].offset)};
      for (int k = 0; k < 2; ++k)
        if (d[k] < d[1 - k] && d[1 - k] > clear[1 - k] && d[k] <= 2 * plane_tolerance) out[static_cast<std::size_t>(k)].push_back(j);
    }
    return out;
  }

  // Planes fitted over 2 B of a curved face are secants that meet off the crease; in the cross-section
  // square to the crease each face is a nearly straight profile (a cone's generator exactly), so the
  // two profiles' lines meet on it. Each side's points are its raw points near the crease (face_points). A
  // side with too few of them in the section band (a face scanned sparsely) is fitted bent along the
  // crease instead, and one too sparse even for that keeps its plane's trace there, while the other side's
  // profile still takes out its own secant's offset. The move is made only where it is more than twice
  // the profiles' own standard error there: on flat faces under noise it is the noise (the case-3 block at
  // σ 0.065 mm: a median of 0.05 mm), and the planes, fitted over more points, are the better estimate.
  void refine_in_profile(LocalCrease& c, const std::array<std::vector<int>, 2>& groups) const {
    const Vec3 b1 = c.normals[0], b2 = c.direction.cross(b1);
    TraceLine line[2];
    int profiles = 0;
    for (int k = 0; k < 2; ++k) {
      std::vector<Eigen::Vector2d> profile;
      for (int i : groups[k]) {
        const Vec3 d = point(raw, i) - c.position;
        if (std::abs(d.dot(c.direction)) <= 0.25 * bin) profile.emplace_back(d.dot(b1), d.dot(b2));
      }
      if (profile.size() < 5) {
        if (const std::optional<TraceLine> bent = bent_trace(c, groups[k], c.normals[k], b1, b2)) {
          line[k] = *bent;
          ++profiles;
          continue;
        }
        // The plane passes through the crease point; its trace runs square to its normal's projection.
        const Eigen::Vector2d n(c.normals[k].dot(b1), c.normals[k].dot(b2));
        line[k].along = Eigen::Vector2d(-n.y(), n.x()).normalized();
        continue;
      }
      ++profiles;
      const double count = static_cast<double>(profile.size());
      Eigen::Vector2d mean = Eigen::Vector2d::Zero();
      for (const auto& q : profile) mean += q / count;
      Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
      for (const auto& q : profile) cov += (q - mean) * (q - mean).transpose();
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(cov);
      const double residual_variance = std::max(0.0, eig.eigenvalues()(0)) / (count - 2);
      line[k] = {mean, eig.eigenvectors().col(1), residual_variance / count, residual_variance / std::max(eig.eigenvalues()(1), 1e-300)};
    }
    // centre0 + s·along0 = centre1 + t·along1
    Eigen::Matrix2d m;
    m << line[0].along, -line[1].along;
    const double sine = std::abs(m.determinant());
    if (profiles == 0 || sine < 0.2) return;
    const Eigen::Vector2d st = m.partialPivLu().solve(line[1].centre - line[0].centre);
    const Eigen::Vector2d hit = line[0].centre + st(0) * line[0].along;
    // Each line's offset error where it meets the other (a fitted line's, at u from its centroid), carried
    // along the other line by 1/sin of their angle.
    double variance = 0;
    for (const TraceLine& l : line) {
      const double u = (hit - l.centre).dot(l.along);
      variance += (l.offset_variance + l.slope_variance * u * u) / (sine * sine);
    }
    if (hit.norm() < 0.5 * bin && hit.norm() > 2 * std::sqrt(variance)) c.position += hit(0) * b1 + hit(1) * b2;
  }

  // A side too sparse for a profile in the section band (a bore's wall seen at a grazing angle) still
  // has its points along the crease: fitted as its plane bent along the crease, w = a + e·t + b·s + c·s²
  // (w off the plane, t across it from the points' mean, s along the crease), its trace in the section
  // (s = 0) is the line w = a + e·t. A plane through an arc of a wall is a secant, off by r θ²/6 (0.17 mm
  // on a Ø10 bore's wall over 3 B at B 0.74 mm) and leaning, as the arc's shallow points reach farther
  // along it; the bent fit has neither. Needs 8 points on both sides of the section; nothing when the
  // trace turns more than 15° from the plane's (then it is no gentle bend). Its variances are the fit's.
  std::optional<TraceLine> bent_trace(const LocalCrease& c, const std::vector<int>& group, const Vec3& normal,
                                      const Vec3& b1, const Vec3& b2) const {
    if (group.size() < 8) return std::nullopt;
    const Vec3 across = c.direction.cross(normal).normalized();
    const auto n = static_cast<Eigen::Index>(group.size());
    Eigen::MatrixXd a(n, 4);
    Eigen::VectorXd w(n);
    double t_mean = 0;
    int before = 0, after = 0;
    for (Eigen::Index i = 0; i < n; ++i) {
      const Vec3 d = point(raw, group[static_cast<std::size_t>(i)]) - c.position;
      const double along = d.dot(c.direction);
      a.row(i) << 1, d.dot(across), along, along * along;
      w(i) = d.dot(normal);
      t_mean += d.dot(across) / static_cast<double>(n);
      before += along < -0.5 * bin, after += along > 0.5 * bin;
    }
    if (before < 2 || after < 2) return std::nullopt;
    a.col(1).array() -= t_mean;
    const Eigen::Matrix4d normal_matrix = a.transpose() * a;
    const Eigen::FullPivLU<Eigen::Matrix4d> lu(normal_matrix);
    if (!lu.isInvertible()) return std::nullopt;
    const Eigen::Vector4d x = lu.solve(a.transpose() * w);
    if (std::abs(x(1)) > std::tan(15 * std::numbers::pi / 180)) return std::nullopt;
    const Eigen::Matrix4d covariance = (a * x - w).squaredNorm() / static_cast<double>(n - 4) * lu.inverse();
    const Eigen::Vector2d n2(normal.dot(b1), normal.dot(b2)), t2(across.dot(b1), across.dot(b2));
    const double length = std::sqrt(1 + x(1) * x(1));
    // Offsets measured along n2; the line's own normal is 1/length of that, and u along it is t·length.
    return TraceLine{x(0) * n2 + t_mean * (t2 + x(1) * n2), (t2 + x(1) * n2) / length, covariance(0, 0) / (length * length),
                     covariance(1, 1) / std::pow(length, 4)};
  }

  LocalCrease corner(const Vec3& x0, const std::vector<std::vector<int>>& groups) const {
    Eigen::Matrix3d n;
    Vec3 offsets;
    LocalCrease out;
    for (int k = 0; k < 3; ++k) {
      const Plane p = robust_plane(raw, groups[k], plane_floor);
      if (p.rms > plane_tolerance || p.inliers < 0.8) return {};
      n.row(k) = p.normal.transpose();
      offsets(k) = p.offset;
      out.normals[k] = p.normal;
    }
    if (std::abs(n.determinant()) < 0.1) return {};
    out.position = n.partialPivLu().solve(offsets);
    if ((out.position - x0).norm() > 2.5 * bin) return {};
    out.sides = 3;
    return out;
  }

  // Within 2 B first; where the regular points there are too few or lie on one face (under noise the
  // fits near a crease are irregular out to about the fit's own radius, and on a sparse row of a view
  // farther), within 3 B: on the case-3 block's vertical edges that finds the crease along 99–100 % of
  // each edge instead of 33–61 %. A Ø10 rim's wall is still a plane within the tolerance there, and the
  // profile refinement puts the line back on the rim.
  LocalCrease operator()(int candidate) const {
    const Vec3 x0 = point(raw, candidate);
    LocalCrease c;
    for (double reach : {2.0, 3.0}) {
      c = look(x0, reach * bin);
      if (c.sides != 0) return c;
    }
    // A face scanned far more sparsely than its neighbour (seen by one view of five at a grazing angle)
    // has fits wider than 3 B, irregular out to their own radius: look as far as they reach, where that
    // face holds fewer of the regular points (on the plate's back face in partial views 3–7 %; a face may
    // hold as few as 2.5 % here).
    double widest = 0;
    for (int j : index.within(x0, 3 * bin)) widest = std::max(widest, fits[j].radius_mm);
    const double reach = std::min(1.5 * widest, 6 * bin);
    if (reach > 3 * bin && (c = look(x0, reach, 40)).sides != 0) return c;
    // Out to 6 B: a face at a twentieth of its neighbour's density (2 points per mm² beside 40, at B
    // 0.31 mm) has too few points within 3 B of the crease to be a plane, and the crease was found
    // along 0–8 % of it (crease_points_test.cpp).
    for (double r : {2.0, 3.0, 4.5, 6.0}) {
      c = look_beside_a_flat_face(x0, r * bin);
      if (c.sides != 0) return c;
    }
    return c;
  }

  // A face sampled far more sparsely than the face it meets (a bore's wall seen at a grazing angle
  // from the scanner's rows, a tenth of the top's density) has no regular fits near the crease: its
  // points' neighbourhoods reach onto the dense face, and within 3 B too few of them are regular to be a
  // group, while wider looks take in the wall's turn. Its raw points are there all the same: where the
  // regular points around are one flat face, the raw points that lie well off that face, all to one side
  // of it, are the other face if they are a plane themselves.
  LocalCrease look_beside_a_flat_face(const Vec3& x0, double radius) const {
    std::vector<int> regular;
    const std::vector<int> near = index.within(x0, radius);
    for (int j : near)
      if (fits[j].regular) regular.push_back(j);
    if (regular.size() < 12) return {};
    const Plane face = robust_plane(raw, regular, plane_floor);
    if (face.rms > plane_tolerance || face.inliers < 0.8) return {};
    const double off = std::max(3 * face.rms, plane_floor) + 0.1 * bin;
    std::vector<int> above, below, on;
    for (int j : near) {
      const double d = face.normal.dot(point(raw, j)) - face.offset;
      (d > off ? above : d < -off ? below : on).push_back(j);
    }
    std::vector<int>& other = above.size() >= below.size() ? above : below;
    const std::size_t stray = std::min(above.size(), below.size());
    if (other.size() < 6 || 10 * stray > other.size()) return {};
    std::erase_if(on, [&](int j) { return !fits[j].regular; });
    return crease(x0, {on, other}, std::max(1.5 * bin, radius / 2));
  }

  // `share`: each face holds at least 1/share of the regular points there.
  LocalCrease look(const Vec3& x0, double radius, std::size_t share = 10) const {
    std::vector<int> members;
    std::vector<Vec3> normals;
    for (int j : index.within(x0, radius)) {
      if (!fits[j].regular) continue;
      members.push_back(j);
      normals.push_back(fits[j].normal);
    }
    if (members.size() < 12) return {};
    const auto three = split(members, normals, 3, share);
    if (!three.empty()) {
      const LocalCrease c = corner(x0, three);
      if (c.sides == 3) return c;
    }
    const auto two = split(members, normals, 2, share);
    // The irregular points beside a crease reach out about as far as the fits do, half the look's radius.
    return two.empty() ? LocalCrease{} : crease(x0, two, std::max(1.5 * bin, radius / 2));
  }
};

// One irregular raw point per half-bin cell, the one nearest the cell's centre.
std::vector<int> candidates(const Points& raw, const std::vector<LocalSurface>& fits, double bin) {
  const double cell = bin / 2;
  std::unordered_map<std::uint64_t, std::pair<double, int>> best;
  for (Eigen::Index i = 0; i < raw.rows(); ++i) {
    if (fits[i].regular) continue;
    const Vec3 p = raw.row(i).transpose() / cell;
    const Vec3 c = p.array().floor();
    const double d = (p - c - Vec3::Constant(0.5)).squaredNorm();
    const auto k = [](double v) { return std::uint64_t(std::int64_t(v) & 0x1fffff); };
    const std::uint64_t key = (k(c.x()) << 42) | (k(c.y()) << 21) | k(c.z());
    auto [it, inserted] = best.try_emplace(key, d, static_cast<int>(i));
    if (!inserted && d < it->second.first) it->second = {d, static_cast<int>(i)};
  }
  std::vector<int> out;
  out.reserve(best.size());
  for (const auto& [key, v] : best) out.push_back(v.second);
  std::sort(out.begin(), out.end());
  return out;
}

bool same_crease(const LocalCrease& a, const LocalCrease& b, double cos_tol) {
  if (std::abs(a.direction.dot(b.direction)) < cos_tol) return false;
  const auto match = [&](const Vec3& x, const Vec3& y) { return std::abs(x.dot(y)) >= cos_tol; };
  return (match(a.normals[0], b.normals[0]) && match(a.normals[1], b.normals[1])) ||
         (match(a.normals[0], b.normals[1]) && match(a.normals[1], b.normals[0]));
}

struct Chain {
  std::vector<int> samples;  // into the local creases, in order along the crease
  int corner_front = -1, corner_back = -1;
  bool closed = false;
};

class ChainWalker {
 public:
  ChainWalker(const std::vector<LocalCrease>& local, double bin)
      : local_(local), bin_(bin), positions_(static_cast<Eigen::Index>(local.size()), 3), taken_(local.size(), 0) {
    for (std::size_t i = 0; i < local.size(); ++i) positions_.row(static_cast<Eigen::Index>(i)) = local[i].position.transpose();
    grid_ = std::make_unique<PointGrid>(positions_, 2 * bin);
  }

  std::vector<Chain> chains() {
    std::vector<Chain> out;
    for (std::size_t i = 0; i < local_.size(); ++i) {
      if (taken_[i]) continue;
      Chain chain;
      chain.samples.push_back(static_cast<int>(i));
      taken_[i] = 1;
      absorb(static_cast<int>(i), local_[i].direction, -0.5 * bin_, 0.5 * bin_);
      std::vector<int> forward = walk(static_cast<int>(i), local_[i].direction, &chain.closed);
      std::vector<int> backward;
      if (!chain.closed) backward = walk(static_cast<int>(i), -local_[i].direction, nullptr);
      chain.samples.clear();
      chain.samples.insert(chain.samples.end(), backward.rbegin(), backward.rend());
      chain.samples.push_back(static_cast<int>(i));
      chain.samples.insert(chain.samples.end(), forward.begin(), forward.end());
      out.push_back(std::move(chain));
    }
    return out;
  }

 private:
  // Marks the unwalked samples of this crease between `from` and `to` along t as walked over.
  void absorb(int at, const Vec3& t, double from, double to) {
    const Vec3 x = local_[at].position;
    grid_->for_each_within(x, std::max(std::abs(from), std::abs(to)) + bin_, [&](int q, double) {
      if (taken_[q] || !same_crease(local_[at], local_[q], cos_deg(30))) return;
      const Vec3 d = local_[q].position - x;
      const double along = d.dot(t);
      if (along >= from && along <= to && (d - along * t).norm() <= 0.5 * bin_) taken_[q] = 1;
    });
  }

  std::vector<int> walk(int start, Vec3 t, bool* closed) {
    std::vector<int> steps;
    int at = start;
    for (;;) {
      const Vec3 x = local_[at].position;
      int next = -1;
      double next_along = 0;
      grid_->for_each_within(x, 1.6 * bin_, [&](int q, double) {
        if (taken_[q] || !same_crease(local_[at], local_[q], cos_deg(30))) return;
        const Vec3 d = local_[q].position - x;
        const double along = d.dot(t);
        if (along < 0.25 * bin_ || (d - along * t).norm() > 0.5 * bin_) return;
        // Steps of about B/2: the resampled points then lie close to a sample's own tangent line.
        const double miss = std::abs(along - 0.5 * bin_), best_miss = std::abs(next_along - 0.5 * bin_);
        if (next < 0 || miss < best_miss || (miss == best_miss && q < next)) next = q, next_along = along;
      });
      if (next < 0) {
        if (closed && steps.size() >= 3) {
          const Vec3 d = local_[start].position - x;
          if (d.norm() <= 1.8 * bin_ && d.dot(t) > 0) *closed = true;
        }
        return steps;
      }
      taken_[next] = 1;
      absorb(at, t, 0, next_along + 0.3 * bin_);
      steps.push_back(next);
      const Vec3 d = local_[next].direction;
      t = d.dot(t) < 0 ? -d : d;
      at = next;
    }
  }

  const std::vector<LocalCrease>& local_;
  double bin_;
  Points positions_;
  std::unique_ptr<PointGrid> grid_;
  std::vector<char> taken_;
};

// A chain's end and the direction it runs out in there (away from the chain).
struct ChainEnd {
  Vec3 position, outward;
};

ChainEnd chain_end(const Chain& chain, const std::vector<LocalCrease>& local, bool back) {
  const std::vector<int>& s = chain.samples;
  const LocalCrease& end = local[back ? s.back() : s.front()];
  if (s.size() < 2) return {end.position, back ? end.direction : Vec3(-end.direction)};
  // Over up to three samples: one step's direction carries the noise of both its points.
  const std::size_t reach = std::min<std::size_t>(3, s.size() - 1);
  const Vec3 inner = local[back ? s[s.size() - 1 - reach] : s[reach]].position;
  return {end.position, (end.position - inner).normalized()};
}

// The walk breaks a crease where a stretch of it found no local line (noise, a sparse row of one
// view) or where it turns faster than its lateral reach: the pieces are joined end to end where one
// runs on into the other across a gap of at most 2.5 B (or overlaps it by up to B; its samples behind
// the join are dropped), and a chain whose two ends meet is closed (a bore's rim).
// A straight crease along a sparsely scanned face (a side one sparse view saw) is found in pieces, the
// candidates between them seeing too few of that face's points; pieces on one line are joined across up
// to kBridgeBins where one face has under a quarter of the other's raw points within 3 B of the gap's
// middle and the raw points run all along the bridge (one within B of it every B), as they would not
// across a true gap in the surface. Where both faces are scanned alike a gap in the crease is no want of
// points (on the plate's Poisson scan at σ ε/2 bridging there put 14 more points on the top's front edge,
// most of them concave or without a window).
constexpr double kBridgeBins = 8;

bool bridged(const Vec3& a, const Vec3& b, const LocalCrease& crease, const Points& raw, const CloudIndex& index, double bin) {
  int face[2] = {0, 0};
  for (int j : index.within(0.5 * (a + b), 3 * bin)) {
    const Vec3 d = point(raw, j) - crease.position;
    ++face[std::abs(d.dot(crease.normals[0])) < std::abs(d.dot(crease.normals[1])) ? 0 : 1];
  }
  if (4 * std::min(face[0], face[1]) >= std::max(face[0], face[1])) return false;
  const int steps = static_cast<int>(std::ceil((b - a).norm() / bin));
  for (int k = 1; k < steps; ++k)
    if (index.within(a + (b - a) * k / steps, bin).empty()) return false;
  return true;
}

void join_chains(std::vector<Chain>& chains, const std::vector<LocalCrease>& local, const Points& raw, const CloudIndex& index,
                 double bin) {
  const auto joins = [&](const ChainEnd& a, const LocalCrease& la, const ChainEnd& b, const LocalCrease& lb, double& gap) {
    const Vec3 d = b.position - a.position;
    const double along = d.dot(a.outward), lateral = (d - along * a.outward).norm();
    gap = d.norm();
    if (!same_crease(la, lb, cos_deg(30))) return false;
    if (gap <= 2.5 * bin)
      return along >= -bin && lateral <= 0.75 * bin + 0.3 * std::max(0.0, along) && b.outward.dot(-a.outward) >= std::cos(std::numbers::pi / 4);
    return gap <= kBridgeBins * bin && lateral <= 0.25 * bin + 0.1 * along && b.outward.dot(-a.outward) >= cos_deg(10) &&
           bridged(a.position, b.position, la, raw, index, bin);
  };
  for (;;) {
    // The closest pair of fitting ends: chain i's back onto chain j's front (j may be reversed). The
    // ends are found through a grid, so a scan with thousands of short chains costs O(chains) a join.
    Points ends(static_cast<Eigen::Index>(2 * chains.size()), 3);  // row 2j: j's front, 2j + 1: its back
    for (std::size_t j = 0; j < chains.size(); ++j)
      for (int back : {0, 1}) ends.row(static_cast<Eigen::Index>(2 * j + back)) = chain_end(chains[j], local, back != 0).position.transpose();
    const PointGrid grid(ends, 2.5 * bin);
    int best_i = -1, best_j = -1;
    bool reverse_j = false;
    double best_gap = 1e300;
    for (std::size_t i = 0; i < chains.size(); ++i) {
      if (chains[i].closed) continue;
      const ChainEnd back = chain_end(chains[i], local, true);
      const LocalCrease& lb = local[chains[i].samples.back()];
      grid.for_each_within(back.position, kBridgeBins * bin, [&](int row, double) {
        const std::size_t j = static_cast<std::size_t>(row / 2);
        const bool rev = row % 2 == 1;
        if (chains[j].closed || (j == i && (rev || chains[i].samples.size() < 6))) return;
        const ChainEnd front = chain_end(chains[j], local, rev);
        double gap = 0;
        if (joins(back, lb, front, local[rev ? chains[j].samples.back() : chains[j].samples.front()], gap) &&
            (gap < best_gap || (gap == best_gap && (static_cast<int>(i) < best_i || (static_cast<int>(i) == best_i && row < 2 * best_j + reverse_j)))))
          best_gap = gap, best_i = static_cast<int>(i), best_j = static_cast<int>(j), reverse_j = rev;
      });
    }
    if (best_i < 0) return;
    Chain& a = chains[static_cast<std::size_t>(best_i)];
    if (best_i == best_j) {
      // Samples of the back that ran past the front would fold the ring back on itself.
      while (a.samples.size() > 6) {
        const ChainEnd back = chain_end(a, local, true);
        if ((local[a.samples.front()].position - back.position).dot(back.outward) >= 0.25 * bin) break;
        a.samples.pop_back();
      }
      a.closed = true;
      continue;
    }
    Chain b = chains[static_cast<std::size_t>(best_j)];
    if (reverse_j) std::reverse(b.samples.begin(), b.samples.end());
    const ChainEnd end = chain_end(a, local, true);
    std::size_t skip = 0;
    while (skip < b.samples.size() && (local[b.samples[skip]].position - end.position).dot(end.outward) < 0.25 * bin) ++skip;
    a.samples.insert(a.samples.end(), b.samples.begin() + static_cast<std::ptrdiff_t>(skip), b.samples.end());
    chains.erase(chains.begin() + best_j);
  }
}

// The corner a chain's end runs into, if any: within reach and ahead of the end, inside a cone of 45°
// about its direction (the last samples before a corner see the third face and turn).
int corner_ahead(const std::vector<CreasePoint>& corners, const Vec3& end, const Vec3& t, double bin) {
  int best = -1;
  double best_d = 3.5 * bin;
  for (std::size_t k = 0; k < corners.size(); ++k) {
    const Vec3 d = corners[k].position - end;
    const double along = d.dot(t);
    if (along < -0.2 * bin || (d - along * t).norm() > 0.5 * bin + std::max(0.0, along)) continue;
    if (d.norm() < best_d) best_d = d.norm(), best = static_cast<int>(k);
  }
  return best;
}

// Each local line comes from planes fitted over a few bins, and the scan's noise moves it by a good
// part of σ; the crease runs smoothly over many bins. Each point (not a corner, which is fixed by three
// planes) is moved onto a quadratic fitted, by arc length, to the points within ±4 of it: on a straight
// edge that averages nine points; on a Ø10 rim the quadratic's own error stays under 0.01 mm.
void smooth_along(const CreasePolyline& line, std::vector<CreasePoint>& points) {
  constexpr int reach = 4;
  const int m = static_cast<int>(line.points.size());
  if (m < 5) return;
  std::vector<Vec3> x(static_cast<std::size_t>(m));
  for (int i = 0; i < m; ++i) x[i] = points[line.points[i]].position;
  std::vector<double> arc(static_cast<std::size_t>(m), 0);
  for (int i = 1; i < m; ++i) arc[i] = arc[i - 1] + (x[i] - x[i - 1]).norm();
  const double length = arc.back() + (line.closed ? (x.front() - x.back()).norm() : 0);
  std::vector<Vec3> smoothed = x;
  std::vector<std::array<Vec3, 3>> normals(static_cast<std::size_t>(m));
  for (int i = 0; i < m; ++i) normals[i] = points[line.points[i]].normals;
  for (int i = 0; i < m; ++i) {
    if (points[line.points[i]].sides != 2) continue;
    Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
    Eigen::Matrix3d atb = Eigen::Matrix3d::Zero();  // columns: x, y, z
    int used = 0;
    for (int k = -reach; k <= reach; ++k) {
      int j = i + k;
      double s = 0;
      if (line.closed) {
        j = ((j % m) + m) % m;
        s = arc[j] - arc[i];
        if (k > 0 && s < 0) s += length;
        if (k < 0 && s > 0) s -= length;
      } else {
        if (j < 0 || j >= m) continue;
        s = arc[j] - arc[i];
      }
      const Vec3 t(1, s, s * s);
      ata += t * t.transpose();
      atb += t * x[j].transpose();
      ++used;
    }
    if (used < 5) continue;
    const Eigen::FullPivLU<Eigen::Matrix3d> lu(ata);
    if (!lu.isInvertible()) continue;
    smoothed[i] = lu.solve(atb).row(0).transpose();
    // The side normals likewise, each matched to this point's sides by sign and by face.
    const std::array<Vec3, 3>& own = points[line.points[i]].normals;
    Vec3 sum[2] = {Vec3::Zero(), Vec3::Zero()};
    for (int k = -reach; k <= reach; ++k) {
      const int j = line.closed ? (((i + k) % m) + m) % m : i + k;
      if (j < 0 || j >= m || points[line.points[j]].sides != 2) continue;
      const std::array<Vec3, 3>& other = points[line.points[j]].normals;
      const bool swap = std::abs(own[0].dot(other[1])) > std::abs(own[0].dot(other[0]));
      for (int side = 0; side < 2; ++side) {
        const Vec3& n = other[swap ? 1 - side : side];
        sum[side] += n.dot(own[side]) < 0 ? Vec3(-n) : n;
      }
    }
    normals[i] = {sum[0].normalized(), sum[1].normalized(), sum[1].normalized()};
  }
  for (int i = 0; i < m; ++i) {
    if (points[line.points[i]].sides != 2) continue;
    points[line.points[i]].position = smoothed[i];
    points[line.points[i]].normals = normals[i];
  }
}

// Resamples a chain every ≈ B, each new point moved onto the local line of the sample nearest it.
void emit_polyline(const Chain& chain, const std::vector<LocalCrease>& local, double bin, Creases& out) {
  struct Node {
    Vec3 x;
    int sample;  // −1: a corner
    int corner;
  };
  std::vector<Node> nodes;
  if (chain.corner_front >= 0) nodes.push_back({out.points[chain.corner_front].position, -1, chain.corner_front});
  for (int s : chain.samples) nodes.push_back({local[s].position, s, -1});
  if (chain.corner_back >= 0) nodes.push_back({out.points[chain.corner_back].position, -1, chain.corner_back});
  if (chain.closed) nodes.push_back(nodes.front());
  std::vector<double> arc{0};
  for (std::size_t i = 1; i < nodes.size(); ++i) arc.push_back(arc.back() + (nodes[i].x - nodes[i - 1].x).norm());
  const double length = arc.back();
  const bool has_corner = chain.corner_front >= 0 || chain.corner_back >= 0;
  if (length < (has_corner ? 0.5 : 1.5) * bin) return;
  const int segments = std::max(chain.closed ? 3 : 1, static_cast<int>(std::lround(length / bin)));
  CreasePolyline line;
  line.closed = chain.closed;
  const LocalCrease& middle = local[chain.samples[chain.samples.size() / 2]];
  line.normal_a = middle.normals[0];
  line.normal_b = middle.normals[1];
  const int count = chain.closed ? segments : segments + 1;
  std::size_t node = 0;
  for (int k = 0; k < count; ++k) {
    const double s = length * k / segments;
    while (node + 2 < nodes.size() && arc[node + 1] <= s) ++node;
    const bool at_first = k == 0, at_last = !chain.closed && k == segments;
    const Node& end_node = at_first ? nodes.front() : nodes.back();
    if ((at_first || at_last) && end_node.corner >= 0) {
      line.points.push_back(end_node.corner);
      continue;
    }
    const double span = arc[node + 1] - arc[node];
    const double w = span > 0 ? std::clamp((s - arc[node]) / span, 0.0, 1.0) : 0.0;
    Vec3 x = (1 - w) * nodes[node].x + w * nodes[node + 1].x;
    // Onto the tangent lines of the walked samples on either side, blended (a corner has none).
    const int s0 = nodes[node].sample, s1 = nodes[node + 1].sample;
    const auto onto = [&](int sample) {
      const LocalCrease& l = local[sample];
      return Vec3(l.position + (x - l.position).dot(l.direction) * l.direction);
    };
    CreasePoint p;
    if (s0 >= 0 || s1 >= 0) {
      x = s0 >= 0 && s1 >= 0 ? Vec3((1 - w) * onto(s0) + w * onto(s1)) : onto(s0 >= 0 ? s0 : s1);
      p.normals = local[(s0 >= 0 && (w < 0.5 || s1 < 0)) ? s0 : s1].normals;
    } else {
      p.normals = {line.normal_a, line.normal_b, line.normal_b};
    }
    p.position = x;
    p.sides = 2;
    line.points.push_back(static_cast<int>(out.points.size()));
    out.points.push_back(p);
  }
  smooth_along(line, out.points);
  if (line.points.size() >= 2) out.polylines.push_back(std::move(line));
}

}  // namespace

Creases find_creases(const Points& raw, const std::vector<LocalSurface>& fits, const CloudIndex& index,
                     const CreaseOptions& options) {
  Creases out;
  const double bin = options.bin_mm;
  if (raw.rows() < 12 || static_cast<Eigen::Index>(fits.size()) != raw.rows() || !(bin > 0)) return out;
  const double sigma = scan_noise(fits);
  const Analysis analysis{raw, fits, index, bin, cos_deg(options.crease_angle_deg), options.crease_angle_deg * std::numbers::pi / 360,
                          std::max(3 * sigma, 1e-9 * bin), std::max(4 * sigma, 0.1 * bin)};

  const std::vector<int> seeds = candidates(raw, fits, bin);
  std::vector<LocalCrease> local(seeds.size());
  for (std::size_t begin = 0; begin < seeds.size(); begin += 4096) {
    options.cancel.throw_if_requested("crease detection");
    const std::size_t end = std::min(seeds.size(), begin + 4096);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(begin, end, 64), [&](const tbb::blocked_range<std::size_t>& r) {
      for (std::size_t i = r.begin(); i < r.end(); ++i) local[i] = analysis(seeds[i]);
    });
  }

  // Corners: the three-plane points of neighbouring candidates agree; average them.
  std::vector<int> corner_votes;
  std::vector<Vec3> corner_sums;
  for (const LocalCrease& l : local) {
    if (l.sides != 3) continue;
    std::size_t k = 0;
    while (k < out.points.size() && (out.points[k].position - l.position).norm() > 1.5 * bin) ++k;
    if (k == out.points.size()) {
      out.points.push_back({l.position, l.normals, 3});
      corner_sums.push_back(Vec3::Zero());
      corner_votes.push_back(0);
    }
    corner_sums[k] += l.position;
    ++corner_votes[k];
  }
  for (std::size_t k = 0; k < out.points.size(); ++k) out.points[k].position = corner_sums[k] / corner_votes[k];
  out.corners = out.points.size();

  // Crease lines; those near a corner saw part of the third face and are left to the corner.
  std::vector<LocalCrease> lines;
  for (const LocalCrease& l : local) {
    if (l.sides != 2) continue;
    bool near_corner = false;
    for (std::size_t k = 0; k < out.corners; ++k) near_corner |= (out.points[k].position - l.position).norm() < 1.5 * bin;
    if (!near_corner) lines.push_back(l);
  }
  if (lines.empty()) return out;
  std::vector<Chain> chains = ChainWalker(lines, bin).chains();
  join_chains(chains, lines, raw, index, bin);
  const std::vector<CreasePoint> corners(out.points.begin(), out.points.end());
  for (Chain& chain : chains) {
    if (chain.closed) {
      emit_polyline(chain, lines, bin, out);
      continue;
    }
    const ChainEnd front = chain_end(chain, lines, false), back = chain_end(chain, lines, true);
    chain.corner_front = corner_ahead(corners, front.position, front.outward, bin);
    chain.corner_back = corner_ahead(corners, back.position, back.outward, bin);
    if (chain.corner_back == chain.corner_front) chain.corner_back = -1;
    emit_polyline(chain, lines, bin, out);
  }
  return out;
}

}  // namespace cmm::geometry
