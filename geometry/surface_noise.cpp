// Leave-one-out quadric fits on each sampled vertex's own side; the median of the scaled
// residuals gives the noise.
#include "geometry/surface_noise.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <optional>

namespace cmm::geometry {
namespace {

constexpr int max_samples = 8'000;  // a median of 8,000 is good to ~2 %
constexpr std::size_t min_support = 10;  // points for a 6-term quadric with some to spare
constexpr std::size_t max_support_faces = 400;
constexpr double max_support_turn = 0.35;  // rad
constexpr int max_valence = 64;

using Quadric = Eigen::Matrix<double, 6, 1>;

struct VertexFaces {
  std::vector<int> start, faces;
};

VertexFaces vertex_faces(const TriangleMesh& mesh) {
  VertexFaces vf;
  const auto n = static_cast<std::size_t>(mesh.vertices.rows());
  vf.start.assign(n + 1, 0);
  for (int f = 0; f < mesh.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) ++vf.start[mesh.faces(f, k) + 1];
  std::partial_sum(vf.start.begin(), vf.start.end(), vf.start.begin());
  vf.faces.resize(vf.start.back());
  std::vector<int> fill(vf.start.begin(), vf.start.end() - 1);
  for (int f = 0; f < mesh.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) vf.faces[fill[mesh.faces(f, k)]++] = f;
  return vf;
}

struct Local {
  double x, y, z;
};

// Leave-one-out residual of the origin against the quadric height field through `points`, divided by
// √(1 + leverage) so that it has the vertices' own spread; none when the fit cannot place the origin.
// A quadric leaves a circle's fourth-order term, k³s⁴/8 along a normal section of curvature k: on a
// coarse exact sphere that alone reads as a micrometre of noise (r₁²r₂²/8R³ from two rings of
// vertices). So the term the first fit's curvatures predict is taken off the heights and the quadric
// fitted again, and kept when it fits the neighbours better: spheres and cylinders are then exact to
// higher order, while a fan's far apex (where the predicted term is no circle's) keeps the first fit.
std::optional<double> origin_residual(const std::vector<Local>& points, double scale) {
  if (points.size() < min_support) return std::nullopt;
  // Normal equations on 6 terms in coordinates scaled to the support (|u|, |v| ≤ 1): fixed-size and
  // well conditioned, and a rank-deficient support (points on one circle) shows as a tiny pivot.
  Eigen::Matrix<double, 6, 6> xtx = Eigen::Matrix<double, 6, 6>::Zero();
  Quadric xtz = Quadric::Zero();
  std::vector<Quadric> rows;
  rows.reserve(points.size());
  for (const Local& p : points) {
    const double u = p.x / scale, v = p.y / scale;
    rows.push_back((Quadric() << 1, u, v, u * u, u * v, v * v).finished());
    xtx += rows.back() * rows.back().transpose();
    xtz += rows.back() * p.z;
  }
  const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> solver(xtx);
  if (solver.info() != Eigen::Success || !(solver.rcond() > 1e-9)) return std::nullopt;
  const Quadric first = solver.solve(xtz);
  Eigen::Matrix2d hessian;
  hessian << 2 * first(3), first(4), first(4), 2 * first(5);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> curvature(hessian / (scale * scale));
  // Neighbours that turn by more than 20° across the support sample the shape too coarsely for a
  // quadric to tell it from noise (a sphere cut in 20° steps): such a vertex says nothing of the noise.
  if (curvature.eigenvalues().cwiseAbs().maxCoeff() * scale > max_support_turn) return std::nullopt;
  Quadric corrected_xtz = Quadric::Zero();
  std::vector<double> corrected(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector2d along = curvature.eigenvectors().transpose() * Eigen::Vector2d(points[i].x, points[i].y);
    corrected[i] = points[i].z;
    for (int k = 0; k < 2; ++k) corrected[i] -= std::pow(curvature.eigenvalues()(k), 3) * std::pow(along(k), 4) / 8;
    corrected_xtz += rows[i] * corrected[i];
  }
  const Quadric second = solver.solve(corrected_xtz);
  double rss_first = 0, rss_second = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    rss_first += std::pow(rows[i].dot(first) - points[i].z, 2);
    rss_second += std::pow(rows[i].dot(second) - corrected[i], 2);
  }
  const Quadric& c = rss_second < rss_first ? second : first;
  // Leverage of the origin: e0ᵀ (XᵀX)⁻¹ e0.
  const double leverage = solver.solve(Quadric::Unit(0))(0);
  if (!(leverage < 1)) return std::nullopt;  // the vertex lies outside what its neighbours determine
  return std::abs(c(0)) / std::sqrt(1 + leverage);
}

}  // namespace

SurfaceNoise surface_noise(const TriangleMesh& mesh, const EdgeAdjacency& adjacency, const FaceGeometry& faces,
                           double crease_angle_rad) {
  SurfaceNoise result;
  const int vertex_count = static_cast<int>(mesh.vertices.rows());
  if (vertex_count == 0) return result;
  const VertexFaces vf = vertex_faces(mesh);
  result.vertex_residual_mm.assign(static_cast<std::size_t>(vertex_count), std::numeric_limits<float>::quiet_NaN());
  const double crease_cos = std::cos(crease_angle_rad);
  const int stride = std::max(1, vertex_count / max_samples);
  std::vector<unsigned> stamp(faces.areas.size(), 0), vertex_stamp(vertex_count, 0);
  unsigned current = 0;
  std::vector<double> residuals;
  std::vector<int> ring, side, support;
  std::vector<Local> points;
  for (int v = 0; v < vertex_count; v += stride) {
    ++result.sampled;
    // A vertex in hundreds of faces (a fan's apex, or a hostile file's one vertex in a million) has no
    // quadric neighbourhood worth fitting, and grouping its faces costs its valence squared: skipped.
    if (vf.start[v + 1] - vf.start[v] > max_valence) continue;
    ring.assign(vf.faces.begin() + vf.start[v], vf.faces.begin() + vf.start[v + 1]);
    std::erase_if(ring, [&](int f) { return !(faces.areas[f] > 0); });
    if (ring.empty()) continue;
    // The sides around v: faces joined across smooth edges. Grown from each unclaimed face in turn.
    ++current;
    std::vector<int> best;
    double best_area = 0;
    for (int seed : ring) {
      if (stamp[seed] == current) continue;
      side.assign(1, seed);
      stamp[seed] = current;
      double area = 0;
      for (std::size_t i = 0; i < side.size(); ++i) {
        const int f = side[i];
        area += faces.areas[f];
        for (int k = 0; k < 3; ++k) {
          const int e = adjacency.face_edges(f, k);
          if (adjacency.edges(e, 0) != v && adjacency.edges(e, 1) != v) continue;
          const int g = adjacency.other_face(e, f);
          if (g < 0 || stamp[g] == current || !(faces.areas[g] > 0)) continue;
          if (std::find(ring.begin(), ring.end(), g) == ring.end()) continue;
          if (faces.normals.row(f).dot(faces.normals.row(g)) < crease_cos) continue;
          stamp[g] = current;
          side.push_back(g);
        }
      }
      if (area > best_area) best_area = area, best = side;
    }
    Vec3 normal = Vec3::Zero();
    for (int f : best) normal += faces.areas[f] * faces.normals.row(f).transpose();
    if (!(normal.norm() > 0)) continue;
    normal.normalize();
    // Its two rings: faces reached across smooth edges that touch a vertex of the first ring.
    ++current;
    for (int f : best)
      for (int k = 0; k < 3; ++k) vertex_stamp[mesh.faces(f, k)] = current;
    support = best;
    for (int f : best) stamp[f] = current;
    for (std::size_t i = 0; i < support.size() && support.size() < max_support_faces; ++i) {
      const int f = support[i];
      for (int k = 0; k < 3; ++k) {
        const int g = adjacency.other_face(adjacency.face_edges(f, k), f);
        if (g < 0 || stamp[g] == current || !(faces.areas[g] > 0)) continue;
        stamp[g] = current;
        if (faces.normals.row(f).dot(faces.normals.row(g)) < crease_cos) continue;
        if (faces.normals.row(g).dot(normal) < 0.5) continue;  // no longer a height field over the plane
        bool touches = false;
        for (int c = 0; c < 3; ++c) touches = touches || vertex_stamp[mesh.faces(g, c)] == current;
        if (touches) support.push_back(g);
      }
    }
    // The support's vertices in v's frame.
    const Vec3 origin = vertex(mesh, v);
    const Vec3 u = normal.unitOrthogonal(), w = normal.cross(u);
    points.clear();
    ++current;
    vertex_stamp[v] = current;
    double scale = 0;
    for (int f : support)
      for (int c = 0; c < 3; ++c) {
        const int q = mesh.faces(f, c);
        if (vertex_stamp[q] == current) continue;
        vertex_stamp[q] = current;
        const Vec3 d = vertex(mesh, q) - origin;
        points.push_back({d.dot(u), d.dot(w), d.dot(normal)});
        scale = std::max(scale, std::hypot(d.dot(u), d.dot(w)));
      }
    if (!(scale > 0)) continue;
    auto r = origin_residual(points, scale);
    if (!r) continue;
    ++result.measured;
    residuals.push_back(*r);
    result.vertex_residual_mm[static_cast<std::size_t>(v)] = static_cast<float>(*r);
  }
  if (!residuals.empty()) {
    auto middle = residuals.begin() + static_cast<std::ptrdiff_t>(residuals.size() / 2);
    std::nth_element(residuals.begin(), middle, residuals.end());
    result.sigma_mm = 1.4826 * *middle;  // the median absolute value of a normal variable is 0.6745 σ
  }
  return result;
}

}  // namespace cmm::geometry
