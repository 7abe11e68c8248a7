// Seen faces by centroid visibility, then their boundary loops and how wide the region beyond or within
// each is; see scan_borders.hpp.
#include "sim/scan_borders.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>

#include <Eigen/Eigenvalues>

#include "geometry/cloud_index.hpp"
#include "geometry/edge_adjacency.hpp"

namespace cmm::sim {
namespace {

// The connected regions of the faces on one side (seen or unseen), each with its half width: the largest
// distance from one of its faces' centroids to the nearest centroid of a face on the other side.
class RegionWidths {
 public:
  RegionWidths(const geometry::EdgeAdjacency& adjacency, const geometry::Points& centroids, std::vector<bool> inside)
      : adjacency_(adjacency), centroids_(centroids), inside_(std::move(inside)), region_(inside_.size(), -1) {
    for (std::size_t f = 0; f < inside_.size(); ++f)
      if (!inside_[f]) others_.push_back(static_cast<int>(f));
    other_centroids_.resize(static_cast<Eigen::Index>(others_.size()), 3);
    for (std::size_t i = 0; i < others_.size(); ++i) other_centroids_.row(static_cast<Eigen::Index>(i)) = centroids_.row(others_[i]);
    if (!others_.empty()) others_index_ = std::make_unique<geometry::CloudIndex>(other_centroids_);
  }

  // The half width of the region holding face f (0 for a face on the other side).
  double of(int f) {
    if (!inside_[static_cast<std::size_t>(f)]) return 0;
    if (region_[static_cast<std::size_t>(f)] < 0) flood(f);
    return widths_[static_cast<std::size_t>(region_[static_cast<std::size_t>(f)])];
  }

 private:
  void flood(int start) {
    const int id = static_cast<int>(widths_.size());
    double width = 0;
    std::vector<int> stack{start};
    region_[static_cast<std::size_t>(start)] = id;
    while (!stack.empty()) {
      const int f = stack.back();
      stack.pop_back();
      if (!others_.empty()) {
        const geometry::Vec3 c = centroids_.row(f).transpose();
        const int nearest = others_index_->nearest(c, 1).front();
        width = std::max(width, (other_centroids_.row(nearest).transpose() - c).norm());
      }
      for (int k = 0; k < 3; ++k) {
        const int g = adjacency_.other_face(adjacency_.face_edges(f, k), f);
        if (g >= 0 && inside_[static_cast<std::size_t>(g)] && region_[static_cast<std::size_t>(g)] < 0) {
          region_[static_cast<std::size_t>(g)] = id;
          stack.push_back(g);
        }
      }
    }
    widths_.push_back(width);
  }

  const geometry::EdgeAdjacency& adjacency_;
  const geometry::Points& centroids_;
  std::vector<bool> inside_;
  std::vector<int> region_, others_;
  geometry::Points other_centroids_;
  std::unique_ptr<geometry::CloudIndex> others_index_;
  std::vector<double> widths_;
};

// The axis a hole border's mouth is seen along, from the seen facets along the border: where they face
// round it (a bore's or a slot's wall: their mean normal under half as long as they are) the direction
// across all their normals; else their mean normal (a pinhole's surround, a shadow on one side of a
// wall). A loop's vector area would tilt with a border that runs down a wall at varying depth (25° on a
// slot's).
geometry::Vec3 mouth_axis(const geometry::TriangleMesh& scene, const std::vector<int>& faces) {
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  geometry::Vec3 sum = geometry::Vec3::Zero();
  double total = 0;
  for (int f : faces) {
    const geometry::Vec3 a = geometry::vertex(scene, scene.faces(f, 0)), b = geometry::vertex(scene, scene.faces(f, 1)),
                         c = geometry::vertex(scene, scene.faces(f, 2));
    const geometry::Vec3 area = (b - a).cross(c - a);
    if (area.norm() == 0) continue;
    scatter += area.norm() * area.normalized() * area.normalized().transpose();
    sum += area;
    total += area.norm();
  }
  if (total == 0) return geometry::Vec3::Zero();
  if (sum.norm() >= 0.5 * total) return sum.normalized();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(scatter);  // eigenvalues ascending
  return solver.eigenvectors().col(0);
}

// The widest disc inside a closed polyline seen along an axis, found on a grid of 400 steps across the
// loop's extent (0.25 % of it: 0.01 mm on a Ø3 hole, 0.03 mm on a 2 × 10 mm slot), fewer on a loop of
// over 1,250 segments.
double mouth_half_width(const std::vector<geometry::Vec3>& loop, const geometry::Vec3& axis) {
  if (loop.size() < 3 || axis.norm() == 0) return 0;
  geometry::Vec3 centre = geometry::Vec3::Zero();
  for (const geometry::Vec3& p : loop) centre += p;
  centre /= static_cast<double>(loop.size());
  const geometry::Vec3 u = axis.unitOrthogonal(), v = axis.cross(u);
  std::vector<Eigen::Vector2d> flat;
  Eigen::Vector2d low = Eigen::Vector2d::Constant(1e300), high = -low;
  for (const geometry::Vec3& p : loop) {
    flat.emplace_back((p - centre).dot(u), (p - centre).dot(v));
    low = low.cwiseMin(flat.back());
    high = high.cwiseMax(flat.back());
  }
  // A loop that does not go round the axis (4πA/P² of its projection under 0.2: a strip folded flat) has
  // no mouth to see down.
  double area = 0, perimeter = 0;
  for (std::size_t i = 0, j = flat.size() - 1; i < flat.size(); j = i++) {
    area += (flat[j].x() * flat[i].y() - flat[i].x() * flat[j].y()) / 2;
    perimeter += (flat[i] - flat[j]).norm();
  }
  if (perimeter == 0 || 4 * M_PI * std::abs(area) / (perimeter * perimeter) < 0.2) return 0;
  // Steps² × segments bounded (2·10⁸): a hole loop of the scene's 20,000 facets gets 100 steps, not hours.
  const double steps = std::clamp(std::sqrt(2e8 / static_cast<double>(flat.size())), 50.0, 400.0);
  const double step = (high - low).maxCoeff() / steps;
  double widest = 0;
  for (double x = low.x() + step / 2; x < high.x(); x += step)
    for (double y = low.y() + step / 2; y < high.y(); y += step) {
      bool inside = false;
      double nearest = 1e300;
      for (std::size_t i = 0, j = flat.size() - 1; i < flat.size(); j = i++) {
        const Eigen::Vector2d& a = flat[j];
        const Eigen::Vector2d& b = flat[i];
        if ((a.y() > y) != (b.y() > y) && x < a.x() + (y - a.y()) * (b.x() - a.x()) / (b.y() - a.y())) inside = !inside;
        const Eigen::Vector2d ab = b - a, ap = Eigen::Vector2d(x, y) - a;
        const double t = std::clamp(ap.dot(ab) / std::max(ab.squaredNorm(), 1e-300), 0.0, 1.0);
        nearest = std::min(nearest, (ap - t * ab).norm());
      }
      if (inside) widest = std::max(widest, nearest);
    }
  return widest;
}

}  // namespace

std::vector<ScanBorder> scan_borders(const geometry::TriangleMesh& scene, const std::vector<ScanView>& views,
                                     double max_incidence_deg, const std::vector<CoverageBand>& coverage) {
  if (!coverage.empty() && coverage.size() != views.size())
    throw std::invalid_argument("scan borders: one coverage band per view, or none");
  const ScanVisibility visibility(scene, max_incidence_deg);
  geometry::TriangleMesh seen{scene.vertices, geometry::Triangles(scene.faces.rows(), 3), {}};
  std::vector<int> scene_face;  // of each row of seen.faces
  std::vector<bool> is_seen(static_cast<std::size_t>(scene.faces.rows()), false);
  geometry::Points centroids(scene.faces.rows(), 3);
  for (Eigen::Index f = 0; f < scene.faces.rows(); ++f) {
    geometry::Vec3 centroid = geometry::Vec3::Zero();
    for (int k = 0; k < 3; ++k) centroid += geometry::vertex(scene, scene.faces(f, k));
    centroid /= 3;
    centroids.row(f) = centroid.transpose();
    for (std::size_t v = 0; v < views.size(); ++v)
      if ((coverage.empty() || coverage[v].keeps(centroid)) &&
          visibility.sees(centroid, static_cast<int>(f), views[v].direction)) {
        seen.faces.row(static_cast<Eigen::Index>(scene_face.size())) = scene.faces.row(f);
        scene_face.push_back(static_cast<int>(f));
        is_seen[static_cast<std::size_t>(f)] = true;
        break;
      }
  }
  seen.faces.conservativeResize(static_cast<Eigen::Index>(scene_face.size()), 3);

  const geometry::EdgeAdjacency scene_adjacency = geometry::edge_adjacency(scene);
  std::vector<bool> is_unseen(is_seen.size());
  std::transform(is_seen.begin(), is_seen.end(), is_unseen.begin(), [](bool s) { return !s; });
  RegionWidths seen_widths(scene_adjacency, centroids, is_seen), unseen_widths(scene_adjacency, centroids, is_unseen);
  std::vector<ScanBorder> borders;
  for (const geometry::BoundaryLoop& loop : geometry::boundary_loops(seen, geometry::edge_adjacency(seen))) {
    ScanBorder border;
    border.centre = geometry::loop_centre(seen, loop.vertices);
    border.perimeter_mm = loop.perimeter;
    border.kind = loop.kind;
    border.surface_normal = loop.surface_normal;
    for (int v : loop.vertices) border.points.push_back(geometry::vertex(seen, v));
    std::vector<int> border_faces;  // the seen facets along it, scene rows
    for (int h : loop.half_edges) {
      const int f = scene_face[static_cast<std::size_t>(geometry::EdgeAdjacency::face_of(h))];
      border_faces.push_back(f);
      const int g = scene_adjacency.other_face(scene_adjacency.face_edges(f, geometry::EdgeAdjacency::side_of(h)), f);
      border.seen_half_width_mm = std::max(border.seen_half_width_mm, seen_widths.of(f));
      if (g >= 0) border.unseen_half_width_mm = std::max(border.unseen_half_width_mm, unseen_widths.of(g));
    }
    if (loop.kind == geometry::LoopKind::hole) {
      border.mouth_axis = mouth_axis(scene, border_faces);
      border.mouth_half_width_mm = mouth_half_width(border.points, border.mouth_axis);
    }
    borders.push_back(border);
  }
  return borders;
}

}  // namespace cmm::sim
