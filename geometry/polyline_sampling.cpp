// Arc-length bookkeeping for smoothing and resampling polylines.
#include "geometry/polyline_sampling.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>
#include <numbers>

namespace cmm::geometry {
namespace {

constexpr double max_arc_turn = std::numbers::pi / 3;  // a hexagon still samples a circle; a box corner does not

}  // namespace

namespace {

// One local quadratic fit per vertex over ±half_window neighbours (open curves keep the window inside the
// curve; closed ones wrap), in the parameter `step(a, b)` puts between consecutive vertices a and b. Returns
// the fits' constant terms, a row per row of `values`.
Eigen::MatrixXd local_quadratic(const Eigen::MatrixXd& values, bool closed, int half_window,
                                const std::function<double(int, int)>& step, std::vector<double>* noise_gain) {
  const auto n = static_cast<int>(values.rows());
  const int window = 2 * half_window + 1;
  if (noise_gain) noise_gain->assign(static_cast<std::size_t>(n), 1.0);
  if (half_window <= 0 || n < window) return values;
  Eigen::MatrixXd smoothed(n, values.cols());
  for (int i = 0; i < n; ++i) {
    int first = i - half_window;
    if (!closed) first = std::clamp(first, 0, n - window);
    Eigen::MatrixXd design(window, 3);
    Eigen::MatrixXd local(window, values.cols());
    double t = 0, t_at_i = 0;
    for (int j = 0; j < window; ++j) {
      const int index = ((first + j) % n + n) % n;
      if (j > 0) t += step(((first + j - 1) % n + n) % n, index);
      if (index == i) t_at_i = t;
      design(j, 1) = t;
      local.row(j) = values.row(index);
    }
    for (int j = 0; j < window; ++j) {  // centre the parameter for conditioning
      const double u = design(j, 1) - t_at_i;
      design.row(j) << 1.0, u, u * u;
    }
    // Vertices that coincide in the parameter leave no quadratic to fit: the vertex stays as it is.
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(design);
    if (qr.rank() < 3) {
      smoothed.row(i) = values.row(i);
      continue;
    }
    smoothed.row(i) = qr.solve(local).row(0);
    // The smoothed vertex is the fit's constant term: its variance over a raw vertex's is ((XᵀX)⁻¹)₀₀.
    if (noise_gain) (*noise_gain)[static_cast<std::size_t>(i)] = (design.transpose() * design).inverse()(0, 0);
  }
  return smoothed;
}

}  // namespace

std::vector<Vec3> smooth_polyline(const std::vector<Vec3>& points, bool closed, int half_window,
                                  std::vector<double>* noise_gain) {
  Eigen::MatrixXd values(points.size(), 3);
  for (std::size_t i = 0; i < points.size(); ++i) values.row(static_cast<Eigen::Index>(i)) = points[i].transpose();
  const auto distance = [&](int a, int b) { return (points[static_cast<std::size_t>(b)] - points[static_cast<std::size_t>(a)]).norm(); };
  const Eigen::MatrixXd smoothed = local_quadratic(values, closed, half_window, distance, noise_gain);
  std::vector<Vec3> result(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) result[i] = smoothed.row(static_cast<Eigen::Index>(i)).transpose();
  return result;
}

std::vector<Vec3> smooth_rim(const std::vector<Vec3>& points, const Circle3& circle, int half_window,
                             std::vector<double>* noise_gain) {
  const Vec3 axis = circle.normal.normalized();
  const Vec3 u = axis.unitOrthogonal(), v = axis.cross(u);
  Eigen::MatrixXd values(points.size(), 2);  // radius and height about the circle
  std::vector<double> angle(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Vec3 offset = points[i] - circle.centre;
    const double z = offset.dot(axis);
    const Vec3 radial = offset - z * axis;
    angle[i] = std::atan2(radial.dot(v), radial.dot(u));
    values.row(static_cast<Eigen::Index>(i)) << radial.norm(), z;
  }
  const auto turn = [&](int a, int b) {
    return std::abs(std::remainder(angle[static_cast<std::size_t>(b)] - angle[static_cast<std::size_t>(a)], 2 * std::numbers::pi));
  };
  const Eigen::MatrixXd smoothed = local_quadratic(values, true, half_window, turn, noise_gain);
  std::vector<Vec3> result(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto row = static_cast<Eigen::Index>(i);
    result[i] = circle.centre + smoothed(row, 0) * (std::cos(angle[i]) * u + std::sin(angle[i]) * v) + smoothed(row, 1) * axis;
  }
  return result;
}

std::vector<PolylineSample> sample_polyline(const std::vector<Vec3>& points, bool closed, double spacing) {
  const int n = static_cast<int>(points.size());
  const int segments = closed ? n : n - 1;
  std::vector<PolylineSample> samples;
  if (segments < 1) return samples;
  std::vector<double> start(segments + 1, 0);
  for (int i = 0; i < segments; ++i) start[i + 1] = start[i] + (points[(i + 1) % n] - points[i]).norm();
  const double length = start.back();
  if (length <= 0) return samples;
  const int count = std::max(1, static_cast<int>(std::ceil(length / spacing - 1e-9)));
  int segment = 0;
  for (int k = 0; k < count; ++k) {
    const double s = (k + 0.5) * length / count;
    while (segment < segments - 1 && start[segment + 1] < s) ++segment;
    const Vec3 a = points[segment], b = points[(segment + 1) % n];
    const double along = start[segment + 1] - start[segment];
    const double t = along > 0 ? (s - start[segment]) / along : 0;
    samples.push_back({a + t * (b - a), along > 0 ? Vec3((b - a) / along) : Vec3::UnitX(), segment});
  }
  return samples;
}

namespace {

// The turn between the chords to the points `half_length` back and ahead of the sample.
Vec3 chord_turn(const std::vector<Vec3>& points, bool closed, const PolylineSample& sample, double half_length) {
  const int n = static_cast<int>(points.size());
  const int segments = closed ? n : n - 1;
  if (segments < 1) return Vec3::Zero();
  // Walks from the sample `half_length` along the polyline (less at an open end), one way: where
  // it ends and how far along the polyline it got.
  auto walk = [&](int step) {
    Vec3 at = sample.position;
    double left = half_length;
    int vertex = step > 0 ? (sample.segment + 1) % n : sample.segment;
    for (int visited = 0; visited < (closed ? segments / 2 : segments) && left > 0; ++visited) {
      const double gap = (points[vertex] - at).norm();
      if (gap >= left) return std::pair{Vec3(at + (points[vertex] - at) * (left / gap)), half_length};
      left -= gap, at = points[vertex];
      if (!closed && (vertex == 0 || vertex == n - 1)) break;
      vertex = ((vertex + step) % n + n) % n;
    }
    return std::pair{at, half_length - left};
  };
  const auto [behind, back_length] = walk(-1);
  const auto [beyond, ahead_length] = walk(+1);
  const Vec3 back = sample.position - behind, ahead = beyond - sample.position;
  if (back.norm() < 1e-9 || ahead.norm() < 1e-9) return Vec3::Zero();
  // The chords of a circle run along the tangents at their arcs' middles, half the two arcs apart.
  const Vec3 cross = back.normalized().cross(ahead.normalized());
  if (cross.norm() < 1e-12) return Vec3::Zero();
  const double angle = std::atan2(cross.norm(), back.normalized().dot(ahead.normalized()));
  // Past ~120° the chords' angle no longer grows with the arc (atan2 tops out at 180°): too far
  // round a small loop to tell its rate.
  if (angle > 2 * std::numbers::pi / 3) return Vec3::Zero();
  return cross.normalized() * (angle / ((back_length + ahead_length) / 2));
}

}  // namespace

Vec3 polyline_turn(const std::vector<Vec3>& points, bool closed, const PolylineSample& sample, double half_length) {
  // A circle turns at one rate over every span; a corner within reach turns the full and the half
  // span by about the same angle over lengths 2:1 (or the half span not at all), and then the edge
  // is taken as straight. 15 % leaves room for a noisy scan's rim, whose rates differ by up to ~10 %.
  const Vec3 full = chord_turn(points, closed, sample, half_length);
  const Vec3 half = chord_turn(points, closed, sample, half_length / 2);
  if ((full - half).norm() > 0.15 * std::max(full.norm(), half.norm()) + 1e-3 / half_length) return Vec3::Zero();
  return full;
}

ChordDeviation chord_deviation(const std::vector<Vec3>& points, bool closed, int segment) {
  const int n = static_cast<int>(points.size());
  const int segments = closed ? n : n - 1;
  auto direction = [&](int i) -> std::optional<Vec3> {  // of segment i, when there is one
    if (closed) i = (i % n + n) % n;
    else if (i < 0 || i >= segments) return std::nullopt;
    const Vec3 d = points[(i + 1) % n] - points[i];
    if (!(d.norm() > 0)) return std::nullopt;
    return Vec3(d.normalized());
  };
  const auto before = direction(segment - 1), here = direction(segment), after = direction(segment + 1);
  if (!before || !here || !after) return {};  // an open end: nothing says the curve bends there
  // An arc turns the same way at both ends, by about the same angle and by less than a corner does.
  const Vec3 turn_in = before->cross(*here), turn_out = here->cross(*after);
  if (turn_in.dot(turn_out) <= 0) return {};
  const double in = std::atan2(turn_in.norm(), before->dot(*here)), out = std::atan2(turn_out.norm(), here->dot(*after));
  if (std::max(in, out) > max_arc_turn || std::max(in, out) > 2 * std::min(in, out)) return {};
  const double turn = std::min(in, out);
  return {turn, (points[(segment + 1) % n] - points[segment]).norm() * turn / 8};
}

}  // namespace cmm::geometry
