// The extraction pipeline: adjacency → features → per-curve samples with side normals → bores on
// closed circular curves → boundary loops (circular hole loops get inferred wall normals).
#include "geometry/feature_model.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>

#include "geometry/circle_fit.hpp"
#include "geometry/face_geometry.hpp"
#include "geometry/polyline_sampling.hpp"
#include "geometry/side_normal.hpp"

namespace cmm::geometry {
namespace {

// One sample on a feature curve with the normals of the face sides left and right of the curve
// direction (left: the face whose winding runs along the curve).
struct CurveSample {
  PolylineSample at;
  SideNormal left, right;
  int left_face = -1, right_face = -1;
};

struct Rim {
  int curve;
  Circle3 circle;
  bool wall_is_left;
  int wall_face;
  Vec3 axis;  // out of the material at this rim
  double draft = 0;  // tan of the wall's tilt toward the axis direction, over the whole wall
};

double angle_between(const Vec3& a, const Vec3& b) { return std::atan2(a.cross(b).norm(), a.dot(b)); }

std::vector<Vec3> positions(const TriangleMesh& mesh, const std::vector<int>& vertices) {
  std::vector<Vec3> points;
  points.reserve(vertices.size());
  for (int v : vertices) points.push_back(vertex(mesh, v));
  return points;
}

// Small residuals alone are not enough: nearly collinear points fit a huge circle well. A rim goes
// all the way round, so its length must be close to 2πR too (an inscribed octagon is 2.6 % short).
bool is_circle(const Circle3& c, double perimeter, double tolerance) {
  const double circumference = 2 * std::numbers::pi * c.radius;
  return c.radius > 0 && c.rms_mm < tolerance * c.radius && c.out_of_plane_mm < tolerance * c.radius &&
         std::abs(perimeter - circumference) < 2 * tolerance * circumference;
}

// Lexicographic +z, +y, +x preference, the same order as the n_up convention.
bool prefer_axis(const Vec3& a, const Vec3& b) { return is_up_side(a, b); }

class Extractor {
 public:
  Extractor(const TriangleMesh& mesh, const FeatureModelOptions& options)
      : mesh_(mesh), options_(options), adjacency_(edge_adjacency(mesh)), faces_(face_geometry(mesh)) {
    model_.topology = topology_report(mesh, adjacency_);
    model_.features = feature_edges(mesh, adjacency_, faces_, options.features);
    model_.loops = boundary_loops(mesh, adjacency_);
    radius_ = (model_.features.noisy ? options.noisy_neighbourhood_edges : options.neighbourhood_edges) *
              model_.features.mean_edge_length;
    along_ = options.neighbourhood_along_edges * model_.features.mean_edge_length;
    half_window_ = model_.features.noisy ? 3 : 0;
  }

  FeatureModel run() {
    const Points& similarity = model_.features.noisy ? model_.features.filtered_normals : faces_.normals;
    SideRegionFinder finder(mesh_, adjacency_, faces_, model_.features.is_feature, similarity,
                            options_.neighbourhood_max_turn_deg * std::numbers::pi / 180);
    const auto& curves = model_.features.curves;
    std::vector<std::vector<CurveSample>> samples(curves.size());
    std::vector<Rim> rims;
    for (std::size_t c = 0; c < curves.size(); ++c) {
      const std::vector<Vec3> raw = positions(mesh_, curves[c].vertices);
      const std::vector<Vec3> points = smooth_polyline(raw, curves[c].closed, smoothing_window(raw.size(), curves[c].closed));
      samples[c] = sample_curve(finder, curves[c], points);
      if (!two_distinct_sides(samples[c])) {
        samples[c].clear();
        ++model_.rejected_curves;
        continue;
      }
      if (curves[c].closed) {
        if (auto rim = bore_rim(static_cast<int>(c), raw, samples[c])) rims.push_back(*rim);
      }
    }
    std::vector<int> hole_of_curve = bores(finder, rims);
    for (const Rim& rim : rims) wall_normals_from_bore(rim, samples[rim.curve]);
    for (std::size_t c = 0; c < curves.size(); ++c) emit_curve_points(static_cast<int>(c), samples[c], hole_of_curve[c]);
    for (std::size_t l = 0; l < model_.loops.size(); ++l) emit_loop_points(finder, static_cast<int>(l));
    return std::move(model_);
  }

 private:
  std::vector<CurveSample> sample_curve(SideRegionFinder& finder, const FeatureCurve& curve, const std::vector<Vec3>& points) {
    std::vector<CurveSample> result;
    for (const PolylineSample& s : sample_polyline(points, curve.closed, options_.spacing)) {
      CurveSample sample{s, {}, {}, -1, -1};
      const int e = curve.edges[s.segment];
      const int from = curve.vertices[s.segment];
      for (int i = 0; i < adjacency_.use_count(e); ++i) {
        const int h = adjacency_.half_edge(e, i);
        (mesh_.faces(h / 3, h % 3) == from ? sample.left_face : sample.right_face) = h / 3;
      }
      if (sample.left_face < 0 || sample.right_face < 0) continue;  // inconsistent orientation here
      sample.left = side(finder, sample.left_face, s);
      sample.right = side(finder, sample.right_face, s);
      result.push_back(sample);
    }
    return result;
  }

  // Noisy meshes smooth ±3 vertices; a small closed curve less, so the window never spans more than
  // about a twelfth of a loop (a Ø6 rim has 19 vertices: 7 would span 130° of it).
  int smoothing_window(std::size_t vertices, bool closed) const {
    if (half_window_ == 0) return 0;
    return closed ? std::min(half_window_, static_cast<int>(vertices / 12)) : half_window_;
  }

  // A crease separates two sides that face different ways. Where the neighbourhood normals of the
  // two sides agree (median over the curve below half the feature angle), the curve was a fold of
  // noise or of a coarse apex tessellation, not an edge.
  bool two_distinct_sides(const std::vector<CurveSample>& samples) const {
    if (samples.empty()) return false;
    std::vector<double> turn;
    for (const CurveSample& s : samples) turn.push_back(angle_between(s.left.normal, s.right.normal));
    std::nth_element(turn.begin(), turn.begin() + turn.size() / 2, turn.end());
    return turn[turn.size() / 2] >= distinct_sides_rad();
  }

  double distinct_sides_rad() const { return 0.5 * options_.features.angle_deg * std::numbers::pi / 180; }

  // The side normal grown from a seed face; a seed that is a fold of noise (its region stays tiny)
  // hands over to the neighbour whose region is largest.
  SideNormal side(SideRegionFinder& finder, int seed, const PolylineSample& s) {
    std::vector<int> region = finder.region(seed, s.position, s.direction, radius_, along_);
    if (region.size() < min_region_faces) {
      for (int k = 0; k < 3; ++k) {
        const int e = adjacency_.face_edges(seed, k);
        const int neighbour = model_.features.is_feature[e] ? -1 : adjacency_.other_face(e, seed);
        if (neighbour < 0) continue;
        const std::vector<int>& other = finder.region(neighbour, s.position, s.direction, radius_, along_);
        if (other.size() > region.size()) region = other;
      }
    }
    return side_normal(mesh_, faces_, region, s.position, s.direction);
  }

  // A closed circular curve with one side a wall around the axis whose normals face the axis.
  std::optional<Rim> bore_rim(int curve, const std::vector<Vec3>& points, const std::vector<CurveSample>& samples) {
    const Circle3 circle = fit_circle(points);
    if (!is_circle(circle, model_.features.curves[curve].length, options_.circle_tolerance) || samples.empty())
      return std::nullopt;
    auto faces_axis = [&](const Vec3& n, const Vec3& p) {
      return std::abs(n.dot(circle.normal)) < 0.5 && n.dot(circle.centre - p) > 0;
    };
    int left = 0, right = 0;
    for (const CurveSample& s : samples) {
      left += faces_axis(s.left.normal, s.at.position);
      right += faces_axis(s.right.normal, s.at.position);
    }
    const int needed = static_cast<int>(std::ceil(0.8 * samples.size()));
    if ((left >= needed) == (right >= needed)) return std::nullopt;
    const bool wall_is_left = left >= needed;
    Vec3 face_normal = Vec3::Zero();
    for (const CurveSample& s : samples) face_normal += wall_is_left ? s.right.normal : s.left.normal;
    const Vec3 axis = face_normal.dot(circle.normal) >= 0 ? circle.normal : Vec3(-circle.normal);
    return Rim{curve, circle, wall_is_left, wall_is_left ? samples[0].left_face : samples[0].right_face, axis};
  }

  // Rims whose walls are one patch belong to one bore; returns the hole id per curve (or -1).
  std::vector<int> bores(SideRegionFinder& finder, std::vector<Rim>& rims) {
    std::vector<int> hole_of_curve(model_.features.curves.size(), -1);
    std::map<int, std::vector<const Rim*>> by_wall;
    std::map<int, std::vector<int>> wall_faces;
    for (Rim& rim : rims) {
      const std::vector<int>& wall = finder.patch(rim.wall_face);
      const int key = *std::min_element(wall.begin(), wall.end());
      const Vec3 axis = wall_axis(rim, wall);
      rim.axis = axis.dot(rim.axis) >= 0 ? axis : Vec3(-axis);
      rim.draft = wall_draft(rim, wall);
      by_wall[key].push_back(&rim);
      wall_faces.try_emplace(key, wall);
    }
    for (const auto& [key, group] : by_wall) {
      const Rim* entry = group.front();
      for (const Rim* rim : group) {
        const bool convex = model_.features.curves[rim->curve].convex;
        const bool entry_convex = model_.features.curves[entry->curve].convex;
        if (convex != entry_convex ? convex : prefer_axis(rim->axis, entry->axis) && rim->axis != entry->axis) entry = rim;
      }
      Hole hole;
      hole.id = static_cast<int>(model_.holes.size());
      hole.source = HoleSource::bore;
      hole.centre = entry->circle.centre;
      hole.axis = entry->axis;
      hole.radius = entry->circle.radius;
      hole.perimeter = model_.features.curves[entry->curve].length;
      hole.roundness_mm = entry->circle.roundness_mm;
      // Depth: between the fitted planes of the bore's two rims (a through hole, or a blind hole's
      // entry and bottom); with one rim, over the wall itself, trimming the 2 % extremes that
      // noise makes.
      if (group.size() >= 2) {
        double deepest = 0;
        for (const Rim* rim : group) deepest = std::max(deepest, std::abs((rim->circle.centre - hole.centre).dot(hole.axis)));
        hole.depth = deepest;
      } else {
        std::vector<double> along;
        for (int f : wall_faces[key]) {
          if (std::abs(faces_.normals.row(f).dot(hole.axis.transpose())) > 0.3) continue;
          for (int k = 0; k < 3; ++k) along.push_back((vertex(mesh_, mesh_.faces(f, k)) - hole.centre).dot(hole.axis));
        }
        if (along.size() >= 3) {
          std::sort(along.begin(), along.end());
          const std::size_t trim = along.size() / 50;
          hole.depth = along[along.size() - 1 - trim] - along[trim];
        }
      }
      for (const Rim* rim : group) hole_of_curve[rim->curve] = hole.id;
      model_.holes.push_back(hole);
    }
    return hole_of_curve;
  }

  // A bore wall's normal at a rim point is known far better from the circle fitted to the whole rim
  // than from the few wall faces near the point (on a Ø6 bore the wall turns 30° within 1.6 mm):
  // the radial direction to the axis, tilted by the wall's draft measured over the whole wall.
  // The bore's axis from its wall: the direction all wall normals are square to (the smallest
  // eigenvector of their scatter), from hundreds of faces rather than one noisy rim's plane.
  Vec3 wall_axis(const Rim& rim, const std::vector<int>& wall) const {
    Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
    int used = 0;
    for (int f : wall) {
      const Vec3 n = faces_.normals.row(f).transpose();
      if (std::abs(n.dot(rim.axis)) > 0.5) continue;  // not wall
      scatter += faces_.areas[f] * n * n.transpose();
      ++used;
    }
    if (used < 8) return rim.axis;
    return Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter).eigenvectors().col(0);
  }

  // The wall's mean tilt along the axis over the whole bore: the folds along its two rims lean
  // opposite ways and cancel. Taken as zero (a cylinder) unless 3 standard errors away from it.
  double wall_draft(const Rim& rim, const std::vector<int>& wall) const {
    double w_sum = 0, w2_sum = 0, sum = 0, squares = 0;
    for (int f : wall) {
      const Vec3 n = faces_.normals.row(f).transpose();
      Vec3 to_axis = rim.circle.centre - face_centroid(mesh_, f);
      to_axis -= to_axis.dot(rim.axis) * rim.axis;
      const double radial = n.dot(to_axis.normalized());
      if (radial < 0.5) continue;  // not wall
      const double w = faces_.areas[f], draft = n.dot(rim.axis) / radial;
      w_sum += w, w2_sum += w * w, sum += w * draft, squares += w * draft * draft;
    }
    if (w_sum <= 0) return 0;
    const double mean = sum / w_sum;
    const double standard_error = std::sqrt(std::max(0.0, squares / w_sum - mean * mean) * w2_sum) / w_sum;
    return std::abs(mean) > 3 * standard_error ? mean : 0.0;
  }

  void wall_normals_from_bore(const Rim& rim, std::vector<CurveSample>& samples) {
    auto radial = [&](const Vec3& p) {
      Vec3 to_axis = rim.circle.centre - p;
      to_axis -= to_axis.dot(rim.axis) * rim.axis;
      return Vec3(to_axis.normalized());
    };
    const double draft = rim.draft;
    for (CurveSample& s : samples) {
      SideNormal& wall = rim.wall_is_left ? s.left : s.right;
      const Vec3 fitted = (radial(s.at.position) + draft * rim.axis).normalized();
      wall.uncertainty_rad = std::max(rim.circle.rms_mm / rim.circle.radius, wall.uncertainty_rad / 3);
      wall.normal = fitted;
    }
  }

  void emit_curve_points(int curve, const std::vector<CurveSample>& samples, int hole) {
    const bool convex = model_.features.curves[curve].convex;
    for (const CurveSample& s : samples) {
      const bool left_up = is_up_side(s.left.normal, s.right.normal);
      const SideNormal& up = left_up ? s.left : s.right;
      const SideNormal& down = left_up ? s.right : s.left;
      EdgePoint p;
      p.id = static_cast<int>(model_.points.size());
      p.kind = hole >= 0 ? EdgeKind::hole_rim : EdgeKind::sharp_edge;
      p.convex = convex;
      p.position = s.at.position;
      p.n_up = up.normal;
      p.n_down = down.normal;
      const Vec3 cross = up.normal.cross(down.normal);
      p.tangent = cross.norm() > 1e-9 ? Vec3(cross.normalized()) : s.at.direction;
      const double turn = angle_between(up.normal, down.normal);
      p.interior_angle_rad = convex ? std::numbers::pi - turn : std::numbers::pi + turn;
      p.n_up_uncertainty_rad = up.uncertainty_rad, p.n_down_uncertainty_rad = down.uncertainty_rad;
      p.n_up_spread_rad = up.facet_spread_rad, p.n_down_spread_rad = down.facet_spread_rad;
      p.curve = curve;
      p.hole = hole;
      if (std::min(up.face_count, down.face_count) < static_cast<int>(min_region_faces)) {
        p.probeable = false;
        p.reason = "too few faces beside the edge here to estimate the normal of both sides (a fold of scan noise?)";
      } else if (turn < distinct_sides_rad()) {
        p.probeable = false;
        p.reason = "the two sides' normals differ by only " + std::to_string(static_cast<int>(std::lround(turn * 180 / std::numbers::pi))) +
                   " deg here: the crease fades out in the mesh";
      }
      if (hole >= 0) model_.holes[hole].rim_point_ids.push_back(p.id);
      model_.points.push_back(p);
    }
  }

  void emit_loop_points(SideRegionFinder& finder, int loop_index) {
    const BoundaryLoop& loop = model_.loops[loop_index];
    const std::vector<Vec3> raw = positions(mesh_, loop.vertices);
    const std::vector<Vec3> points = smooth_polyline(raw, true, smoothing_window(raw.size(), true));
    std::optional<Hole> hole;
    if (loop.kind == LoopKind::hole) {
      const Circle3 circle = fit_circle(raw);
      if (is_circle(circle, loop.perimeter, options_.circle_tolerance)) {
        hole = Hole{};
        hole->id = static_cast<int>(model_.holes.size());
        hole->source = HoleSource::open_boundary;
        hole->centre = circle.centre;
        hole->axis = circle.normal.dot(loop.surface_normal) >= 0 ? circle.normal : Vec3(-circle.normal);
        hole->radius = circle.radius;
        hole->perimeter = loop.perimeter;
        hole->roundness_mm = circle.roundness_mm;
      }
    }
    for (const PolylineSample& s : sample_polyline(points, true, options_.spacing)) {
      const int face = loop.half_edges[s.segment] / 3;
      const SideNormal side = side_normal(mesh_, faces_, finder.region(face, s.position, s.direction, radius_, along_), s.position, s.direction);
      EdgePoint p;
      p.id = static_cast<int>(model_.points.size());
      p.position = s.position;
      p.curve = loop_index;
      if (hole) {
        // The scan lost the wall: a bore wall is parallel to the axis and faces it.
        Vec3 to_axis = hole->centre - s.position;
        to_axis -= to_axis.dot(hole->axis) * hole->axis;
        const Vec3 wall = to_axis.normalized();
        const bool face_up = is_up_side(side.normal, wall);
        p.kind = EdgeKind::hole_rim;
        p.hole = hole->id;
        p.normals_inferred = true;
        p.n_up = face_up ? side.normal : wall;
        p.n_down = face_up ? wall : side.normal;
        const Vec3 cross = p.n_up.cross(*p.n_down);
        p.tangent = cross.norm() > 1e-9 ? Vec3(cross.normalized()) : s.direction;
        p.interior_angle_rad = std::numbers::pi - angle_between(side.normal, wall);
        (face_up ? p.n_up_uncertainty_rad : p.n_down_uncertainty_rad) = side.uncertainty_rad;
        (face_up ? p.n_up_spread_rad : p.n_down_spread_rad) = side.facet_spread_rad;
        hole->rim_point_ids.push_back(p.id);
      } else {
        p.kind = EdgeKind::boundary;
        p.n_up = side.normal;
        p.tangent = s.direction;
        p.n_up_uncertainty_rad = side.uncertainty_rad;
        p.n_up_spread_rad = side.facet_spread_rad;
        p.probeable = false;
        p.reason = "open boundary: the mesh has no surface beyond it, so only one side is known and "
                   "it cannot be probed as an edge";
      }
      model_.points.push_back(p);
    }
    if (hole) model_.holes.push_back(*hole);
  }

  const TriangleMesh& mesh_;
  const FeatureModelOptions& options_;
  EdgeAdjacency adjacency_;
  FaceGeometry faces_;
  FeatureModel model_;
  static constexpr std::size_t min_region_faces = 6;
  double radius_ = 0, along_ = 0;
  int half_window_ = 0;
};

}  // namespace

FeatureModel extract_features(const TriangleMesh& mesh, const FeatureModelOptions& options) {
  return Extractor(mesh, options).run();
}

}  // namespace cmm::geometry
