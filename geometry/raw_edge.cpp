// Border vertices onto the raw edge: the rank-against-distance line of the raw points in a strip across
// the border, followed out to rank 0.
#include "geometry/raw_edge.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <utility>

namespace cmm::geometry {
namespace {

constexpr int kMinStripPoints = 6;
constexpr std::size_t kMinQuadricPoints = 12;  // six terms, twice over
constexpr double kMaxFacetTurnDeg = 30;

Vec3 facet_normal(const TriangleMesh& mesh, int f) {
  const Vec3 a = vertex(mesh, mesh.faces(f, 0)), b = vertex(mesh, mesh.faces(f, 1)), c = vertex(mesh, mesh.faces(f, 2));
  return (b - a).cross(c - a);
}

// κB², the most the surface bends over a bin near `at`: the quadric fitted to the raw points within 3 B (`within_3b`)
// (and B + 3σ of the border's plane, so that a face curving away stays in). Noise hides no curvature here
// as it would a plane's residual (at σ ε the case-3 block's Ø10 bores' walls, κ 0.2 /mm, passed for flat,
// and their borders moved off the surface); over 2 B the quadric's own scatter under noise of ε/4 was as
// large as the bound. Nothing where fewer than 12 points lie there.
std::optional<double> bend_over_a_bin(const Points& raw, const std::vector<int>& within_3b, const Vec3& at,
                                      const Vec3& normal, const Vec3& outward, const RawEdgeOptions& options) {
  const double bin = options.bin_mm;
  const Vec3 along = normal.cross(outward);
  std::vector<Vec3> around;  // (out, along) in bins, up in mm
  for (int id : within_3b) {
    const Vec3 d = raw.row(id).transpose() - at;
    if (std::abs(d.dot(normal)) <= 3 * options.noise_sigma_mm + bin)
      around.emplace_back(d.dot(outward) / bin, d.dot(along) / bin, d.dot(normal));
  }
  if (around.size() < kMinQuadricPoints) return std::nullopt;
  Eigen::MatrixXd terms(static_cast<Eigen::Index>(around.size()), 6);
  Eigen::VectorXd heights(static_cast<Eigen::Index>(around.size()));
  for (std::size_t i = 0; i < around.size(); ++i) {
    const auto r = static_cast<Eigen::Index>(i);
    const double u = around[i].x(), w = around[i].y();  // in bins: a well-conditioned fit
    terms.row(r) << 1, u, w, u * u, u * w, w * w;
    heights(r) = around[i].z();
  }
  const Eigen::VectorXd q = terms.colPivHouseholderQr().solve(heights);
  Eigen::Matrix2d hessian;
  hessian << 2 * q(3), q(4), q(4), 2 * q(5);  // d²h per bin²: κB² directly
  return Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(hessian).eigenvalues().cwiseAbs().maxCoeff();
}

}  // namespace

std::optional<RawEdge> raw_edge(const Points& raw, const CloudIndex& index, const Vec3& at, const Vec3& normal,
                                const Vec3& outward, const RawEdgeOptions& options) {
  const double bin = options.bin_mm;
  const Vec3 along = normal.cross(outward);
  const double height = 3 * options.noise_sigma_mm + 0.25 * bin;
  const std::vector<int> within_3b = index.within(at, 3 * bin);
  std::vector<Vec3> strip;  // (out, along, up)
  for (int id : within_3b) {
    const Vec3 d = raw.row(id).transpose() - at;
    if (std::abs(d.dot(along)) <= bin && std::abs(d.dot(normal)) <= height) strip.emplace_back(d.dot(outward), d.dot(along), d.dot(normal));
  }
  std::sort(strip.begin(), strip.end(), [](const Vec3& a, const Vec3& b) { return a.x() > b.x(); });
  // Ranks down to 2 B inside the outermost: every point above that depth is counted.
  std::size_t n = 0;
  while (n < strip.size() && strip[n].x() >= strip.front().x() - 2 * bin) ++n;
  if (n < kMinStripPoints) return std::nullopt;
  // Least squares s = a + b·k over k = i + 1: on a face sampled at random (a Poisson process) the i-th
  // point lies (i + 1)/(2ρB) inside the edge on average.
  double sk = 0, ss = 0, skk = 0, sks = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double k = static_cast<double>(i) + 1;
    sk += k, ss += strip[i].x(), skk += k * k, sks += k * strip[i].x();
  }
  const double count = static_cast<double>(n);
  const double slope = (count * sks - sk * ss) / (count * skk - sk * sk);
  if (!(slope < 0)) return std::nullopt;
  // No farther than a sample spacing beyond the outermost point (on a grid the edge lies within a row of
  // the last; at random the rank line's own scatter would carry a border off the surface), less twice the
  // noise, which carries the outermost points beyond the edge themselves.
  const double density = 1 / (-slope * 2 * bin);
  const double edge = std::min((ss - slope * sk) / count,
                               strip.front().x() + std::max(0.0, 1 / std::sqrt(density) - 2 * options.noise_sigma_mm));
  // Only where the face is flat at the bin's scale (see the header).
  const std::optional<double> bend = bend_over_a_bin(raw, within_3b, at, normal, outward, options);
  if (!bend || *bend > options.tolerance_mm / 2) return std::nullopt;
  Vec3 centre = Vec3::Zero();
  for (std::size_t i = 0; i < n; ++i) centre += strip[i] / count;
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < n; ++i) scatter += (strip[i] - centre) * (strip[i] - centre).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> plane(scatter);
  const Vec3 m = plane.eigenvectors().col(0);
  if (!(std::abs(m.z()) > 0.5)) return std::nullopt;
  // On the plane at (edge, 0, up).
  return RawEdge{edge, centre.z() - (edge - centre.x()) * m.x() / m.z() + centre.y() * m.y() / m.z()};
}

int move_borders_to_raw_edge(Triangulation& t, const Points& raw, const CloudIndex& index, const RawEdgeOptions& options) {
  TriangleMesh& mesh = t.mesh;
  const auto vertices = static_cast<std::size_t>(mesh.vertices.rows());
  std::vector<std::vector<int>> facets(vertices);
  for (int f = 0; f < mesh.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) facets[static_cast<std::size_t>(mesh.faces(f, k))].push_back(f);
  std::vector<int> on_loops(vertices, 0);
  for (const ScanLoop& loop : t.loops)
    for (int v : loop.vertices) ++on_loops[static_cast<std::size_t>(v)];

  const double min_cos = std::cos(kMaxFacetTurnDeg * std::numbers::pi / 180);
  int moved = 0;
  for (const ScanLoop& loop : t.loops) {
    const std::size_t n = loop.vertices.size();
    // Openings only: a scan's outer border is mostly where a face turns away from every view, seen at a
    // grazing angle, where beam noise spills the points along the face past its edge (0.3 mm below the
    // case-3 block's bottom edges at σ 0.05 mm), and a border moved there leaves the part.
    if (n < 3 || loop.kind != LoopKind::hole) continue;
    for (std::size_t i = 0; i < n; ++i) {
      const int v = loop.vertices[i];
      const auto vi = static_cast<std::size_t>(v);
      // A crease point lies on the edge its faces meet at already; a pinched vertex has two borders.
      if (on_loops[vi] != 1 || vi >= t.thinned_index.size() || t.thinned_index[vi] < 0) continue;
      Vec3 normal = Vec3::Zero(), centroid = Vec3::Zero();
      for (int f : facets[vi]) {
        normal += facet_normal(mesh, f);
        for (int k = 0; k < 3; ++k) centroid += vertex(mesh, mesh.faces(f, k)) / (3.0 * static_cast<double>(facets[vi].size()));
      }
      if (!(normal.norm() > 0)) continue;
      normal.normalize();
      const Vec3 at = vertex(mesh, v);
      Vec3 run = vertex(mesh, loop.vertices[(i + 1) % n]) - vertex(mesh, loop.vertices[(i + n - 1) % n]);
      run -= run.dot(normal) * normal;
      if (!(run.norm() > 0)) continue;
      // The surface lies left of the loop: outward is to its right.
      const Vec3 outward = run.normalized().cross(normal);
      if ((centroid - at).dot(outward) >= 0) continue;
      const std::optional<RawEdge> edge = raw_edge(raw, index, at, normal, outward, options);
      if (!edge || !(edge->out > 0)) continue;
      const Vec3 to = at + std::min(edge->out, options.bin_mm) * outward + edge->up * normal;
      std::vector<Vec3> before;
      for (int f : facets[vi]) before.push_back(facet_normal(mesh, f).normalized());
      mesh.vertices.row(v) = to.transpose();
      bool turned = false;
      for (std::size_t k = 0; k < before.size() && !turned; ++k) {
        const Vec3 after = facet_normal(mesh, facets[vi][k]);
        turned = !(after.norm() > 0) || after.normalized().dot(before[k]) < min_cos;
      }
      if (turned) {
        mesh.vertices.row(v) = at.transpose();
        continue;
      }
      ++moved;
    }
  }
  for (ScanLoop& loop : t.loops) {
    loop.perimeter_mm = 0;
    for (std::size_t i = 0; i < loop.vertices.size(); ++i)
      loop.perimeter_mm += (vertex(mesh, loop.vertices[(i + 1) % loop.vertices.size()]) - vertex(mesh, loop.vertices[i])).norm();
  }
  return moved;
}

}  // namespace cmm::geometry
