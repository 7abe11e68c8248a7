// The extraction pipeline: adjacency → features → per-curve samples with side normals → bores on
// closed circular curves (bore_detection.cpp) → boundary loops (circular hole loops get inferred
// wall normals) → reference edge points.
#include "geometry/feature_model.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "geometry/feature_extractor.hpp"

namespace cmm::geometry {
namespace detail {
namespace {

std::vector<Vec3> positions(const TriangleMesh& mesh, const std::vector<int>& vertices) {
  std::vector<Vec3> points;
  points.reserve(vertices.size());
  for (int v : vertices) points.push_back(vertex(mesh, v));
  return points;
}

}  // namespace

Extractor::Extractor(const TriangleMesh& mesh, const FeatureModelOptions& options)
    : mesh_(mesh), options_(options), adjacency_(edge_adjacency(mesh)), faces_(face_geometry(mesh)) {
  options.cancel.throw_if_requested("mesh adjacency");
  model_.topology = topology_report(mesh, adjacency_);
  FeatureOptions features = options.features;
  features.cancel = options.cancel;
  model_.features = feature_edges(mesh, adjacency_, faces_, features);
  options.cancel.throw_if_requested("feature edge detection");
  model_.loops = boundary_loops(mesh, adjacency_);
  const double sigma = model_.features.noise.sigma_mm;
  noise_radius_ = options.neighbourhood_sigmas * sigma;
  noise_along_ = options.neighbourhood_along_sigmas * sigma;
  half_window_ = model_.features.noisy ? 3 : 0;
  // The centre weight of a quadratic Savitzky–Golay fit over 2m + 1 points is 3(3m² + 3m − 1) / ((2m + 1)(4m² + 4m − 3)).
  const double m = half_window_;
  const double leverage = m == 0 ? 1.0 : 3 * (3 * m * m + 3 * m - 1) / ((2 * m + 1) * (4 * m * m + 4 * m - 3));
  model_.point_sigma_mm = sigma * std::sqrt(leverage);
}

// The points sample_polyline will make, counted from the curves' lengths before any is made: the
// side normals behind each point are the costly part, and a fine spacing on a large model asks
// for millions of them.
void Extractor::check_point_count() const {
  if (options_.max_points == 0 || !(options_.spacing > 0)) return;
  double points = 0;
  for (const FeatureCurve& c : model_.features.curves) points += c.length / options_.spacing + 1;
  for (const BoundaryLoop& l : model_.loops) points += l.perimeter / options_.spacing + 1;
  if (points <= static_cast<double>(options_.max_points)) return;
  const auto count = static_cast<std::size_t>(std::min(points, 1e18));
  throw TooManyPoints("the feature curves at spacing " + std::to_string(options_.spacing) + " would give about " +
                          std::to_string(count) + " reference points, more than the limit of " +
                          std::to_string(options_.max_points) + ": use a coarser spacing",
                      count, options_.max_points);
}

FeatureModel Extractor::run() {
  check_point_count();
  const Points& similarity = model_.features.noisy ? model_.features.filtered_normals : faces_.normals;
  SideRegionFinder finder(mesh_, adjacency_, faces_, model_.features.is_feature, similarity,
                          options_.neighbourhood_max_turn_deg * std::numbers::pi / 180);
  const auto& curves = model_.features.curves;
  std::vector<std::vector<CurveSample>> samples(curves.size());
  std::vector<Rim> rims;
  for (std::size_t c = 0; c < curves.size(); ++c) {
    options_.cancel.throw_if_requested("the feature curves");
    const std::vector<Vec3> raw = positions(mesh_, curves[c].vertices);
    const std::optional<Circle3> rim = rim_circle(raw, curves[c].closed, curves[c].length);
    std::vector<double> noise_gain;
    const std::vector<Vec3> points = smooth_curve(raw, curves[c].closed, rim, noise_gain);
    samples[c] = sample_curve(finder, curves[c], points, noise_gain, rim);
    if (!two_distinct_sides(samples[c])) {
      samples[c].clear();
      ++model_.rejected_curves;
      continue;
    }
    if (rim) {
      if (auto bore = bore_rim(static_cast<int>(c), *rim, samples[c])) rims.push_back(*bore);
    }
  }
  options_.cancel.throw_if_requested("bore detection");
  std::vector<int> hole_of_curve = bores(finder, rims);
  for (const Rim& rim : rims) wall_normals_from_bore(rim, samples[rim.curve]);
  for (std::size_t c = 0; c < curves.size(); ++c) emit_curve_points(static_cast<int>(c), samples[c], hole_of_curve[c]);
  for (std::size_t l = 0; l < model_.loops.size(); ++l) {
    options_.cancel.throw_if_requested("the boundary loops");
    emit_loop_points(finder, static_cast<int>(l));
  }
  adopt_wall_hole_rims();
  if (!model_.points.empty()) {
    std::vector<double> sigmas;
    for (const EdgePoint& p : model_.points) sigmas.push_back(p.position_sigma_mm);
    std::nth_element(sigmas.begin(), sigmas.begin() + static_cast<long>(sigmas.size() / 2), sigmas.end());
    model_.point_sigma_mm = sigmas[sigmas.size() / 2];
  }
  return std::move(model_);
}

// A sample between two smoothed vertices is as uncertain as the worse of them.
double Extractor::position_sigma(const std::vector<double>& noise_gain, int segment) const {
  const auto i = static_cast<std::size_t>(segment);
  const double gain = std::max(noise_gain[i], noise_gain[(i + 1) % noise_gain.size()]);
  return model_.features.noise.sigma_mm * std::sqrt(gain);
}

std::vector<CurveSample> Extractor::sample_curve(SideRegionFinder& finder, const FeatureCurve& curve, const std::vector<Vec3>& points,
                                                 const std::vector<double>& noise_gain, const std::optional<Circle3>& rim) {
  std::vector<CurveSample> result;
  for (const PolylineSample& s : sample_polyline(points, curve.closed, options_.spacing)) {
    CurveSample sample{s, {}, {}, -1, -1, {}};
    const int e = curve.edges[s.segment];
    const int from = curve.vertices[s.segment];
    for (int i = 0; i < adjacency_.use_count(e); ++i) {
      const int h = adjacency_.half_edge(e, i);
      (mesh_.faces(h / 3, h % 3) == from ? sample.left_face : sample.right_face) = h / 3;
    }
    if (sample.left_face < 0 || sample.right_face < 0) continue;  // inconsistent orientation here
    const double along = along_edge(points, curve.closed, s, rim);
    const Vec3 turn = edge_turn(points, curve.closed, s, along, rim);
    sample.left = side(finder, sample.left_face, sample.right_face, s, turn, along);
    sample.right = side(finder, sample.right_face, sample.left_face, s, turn, along);
    sample.chord = chord_deviation(points, curve.closed, s.segment);
    sample.position_sigma_mm = position_sigma(noise_gain, s.segment);
    result.push_back(sample);
  }
  return result;
}

// A noisy mesh's creases are smoothed over ±3 vertices by arc length, a closed one over at most a twelfth
// of its vertices (a Ø6 rim has 19: 7 by arc length would cut its corner). A rim (a closed circular
// curve) is smoothed by angle instead, on its radius and height, over as far as the side normals reach
// along an edge (75 σ), at most a quarter of the way round and 32 vertices to either side. An exact
// mesh's are kept.
std::vector<Vec3> Extractor::smooth_curve(const std::vector<Vec3>& raw, bool closed, const std::optional<Circle3>& rim,
                                          std::vector<double>& noise_gain) const {
  const int vertices = static_cast<int>(raw.size());
  if (half_window_ == 0 || vertices == 0) {
    noise_gain.assign(raw.size(), 1.0);
    return raw;
  }
  if (rim) {
    // At most 32 vertices a side: a fine ring of a million vertices must not cost a million squared.
    const double reach = std::min(32.0, noise_along_ * vertices / (2 * std::numbers::pi * rim->radius));
    return smooth_rim(raw, *rim, std::min(std::max(static_cast<int>(std::lround(reach)), half_window_), vertices / 4),
                      &noise_gain);
  }
  return smooth_polyline(raw, closed, closed ? std::min(half_window_, vertices / 12) : half_window_, &noise_gain);
}

// The circle a closed curve runs round, if it is one (a rim).
std::optional<Circle3> Extractor::rim_circle(const std::vector<Vec3>& raw, bool closed, double length) const {
  if (!closed) return std::nullopt;
  const Circle3 circle = fit_circle(raw);
  if (!is_circle(circle, length, options_.circle_tolerance)) return std::nullopt;
  return circle;
}

// A crease separates two sides that face different ways. Where the neighbourhood normals of the
// two sides agree (median over the curve below half the feature angle), the curve was a fold of
// noise or of a coarse apex tessellation, not an edge.
bool Extractor::two_distinct_sides(const std::vector<CurveSample>& samples) const {
  if (samples.empty()) return false;
  std::vector<double> turn;
  for (const CurveSample& s : samples) turn.push_back(angle_between(s.left.normal, s.right.normal));
  std::nth_element(turn.begin(), turn.begin() + turn.size() / 2, turn.end());
  return turn[turn.size() / 2] >= distinct_sides_rad();
}

// How the edge turns at a sample (axis × rate per mm): a rim's is its circle's, which a coarse or uneven
// polyline (a decimated rim's chords of every length) does not tell as well; another curve's is read
// from the polyline over the reach.
Vec3 Extractor::curve_turn(const std::vector<Vec3>& points, bool closed, const PolylineSample& s, double reach,
                           const std::optional<Circle3>& rim) const {
  if (!rim) return polyline_turn(points, closed, s, reach);
  const Vec3 axis = rim->normal.normalized();
  Vec3 to_centre = rim->centre - s.position;
  to_centre -= to_centre.dot(axis) * axis;
  if (!(to_centre.norm() > 0)) return Vec3::Zero();
  return s.direction.cross(to_centre.normalized()) / rim->radius;
}

// The turn side_normal takes back out of a side's facets. Around a small rim the side region spans
// a wide arc, where a few degrees' error in the estimated axis would turn the facets of a flat top
// by more than the turn's own second-order effect: there the linear fit alone is better.
Vec3 Extractor::edge_turn(const std::vector<Vec3>& points, bool closed, const PolylineSample& s, double along,
                          const std::optional<Circle3>& rim) const {
  const Vec3 turn = curve_turn(points, closed, s, 2 * along, rim);
  return turn.norm() * along <= max_turn_reach ? turn : Vec3::Zero();
}

// How far along the edge a side's facets are taken, in mm: what the vertex noise asks for, and twice that
// where the edge is straight or turns slowly enough for edge_turn to take the turn out of the facets over
// that reach (more facets, the same bias); but at least the reference spacing and the crease segment the
// point lies on with half its neighbours' reach, so the facets touching the edge here are always in.
double Extractor::along_edge(const std::vector<Vec3>& points, bool closed, const PolylineSample& s,
                             const std::optional<Circle3>& rim) const {
  const auto i = static_cast<std::size_t>(s.segment);
  const double segment = (points[(i + 1) % points.size()] - points[i]).norm();
  double noise = noise_along_;
  if (model_.features.noisy) {
    const double turn = curve_turn(points, closed, s, 4 * noise_along_, rim).norm();
    noise = std::max(noise, std::min(2 * noise_along_, turn > 0 ? 0.9 * max_turn_reach / turn : 2 * noise_along_));
  }
  return std::max({noise, options_.spacing, 1.5 * segment});
}

// How far across the edge: what the noise asks for, but at least 2.5 spacings and 2.5 times the depth
// of the facet touching the edge (its far corner's distance from the edge), so the row beyond it is in
// and a curved side's field can be taken to the edge.
double Extractor::across_edge(int seed, const PolylineSample& s) const {
  double depth = 0;
  for (int k = 0; k < 3; ++k) {
    const Vec3 offset = vertex(mesh_, mesh_.faces(seed, k)) - s.position;
    depth = std::max(depth, (offset - offset.dot(s.direction) * s.direction).norm());
  }
  return std::max({noise_radius_, 2.5 * options_.spacing, 2.5 * depth});
}

// The side normal grown from a seed face; a seed that is a fold of noise (its region stays tiny)
// hands over to the neighbour whose region is largest: first within its side, then across the fold's
// far feature edge (a noisy crease's sliver fold lies between two feature curves).
SideNormal Extractor::side(SideRegionFinder& finder, int seed, int across, const PolylineSample& s, const Vec3& turn, double along) {
  const double radius = across_edge(seed, s);
  std::vector<int> region = finder.region(seed, s.position, s.direction, radius, along);
  if (model_.features.noisy && region.size() < min_region_faces) {
    for (int k = 0; k < 3; ++k) {
      const int e = adjacency_.face_edges(seed, k);
      const int neighbour = model_.features.is_feature[e] ? -1 : adjacency_.other_face(e, seed);
      if (neighbour < 0) continue;
      const std::vector<int>& other = finder.region(neighbour, s.position, s.direction, radius, along);
      if (other.size() > region.size()) region = other;
    }
  }
  // A fold of noise lying along the crease is a sliver between two feature curves: the side beyond it
  // is across its other feature edge, never across this curve's own (to `across`, the other side's seed).
  bool beyond_fold = false;
  if (model_.features.noisy && region.size() < min_region_faces) {
    for (int k = 0; k < 3; ++k) {
      const int e = adjacency_.face_edges(seed, k);
      const int neighbour = adjacency_.other_face(e, seed);
      if (neighbour < 0 || neighbour == across || !model_.features.is_feature[e]) continue;
      const std::vector<int>& other = finder.region(neighbour, s.position, s.direction, radius, along);
      if (other.size() > region.size()) region = other, beyond_fold = true;
    }
  }
  if (model_.features.noisy) {
    SideNormal out = side_normal(mesh_, faces_, region, s.position, s.direction, turn, std::nullopt);
    out.beyond_fold = beyond_fold;
    double area = 0;
    for (int f : region) out.centroid += faces_.areas[f] * face_centroid(mesh_, f), area += faces_.areas[f];
    if (area > 0) out.centroid /= area;
    return out;
  }
  // On a clean mesh the facets at the edge are best where they are exact; where they are not (a
  // decimated patch), more of the side steadies the fit. The neighbourhood that states the smallest
  // uncertainty is taken (Lepski's rule, which keeps a narrower fit that disagrees with a wider one,
  // kept a decimated rim's worst facets: their own spread understates them).
  SideNormal best = side_normal(mesh_, faces_, region, s.position, s.direction, turn, clean_noise(region));
  for (double widen : {2.0, 4.0}) {
    if (best.uncertainty_rad < 1e-3) break;  // 0.06°: no wider region would do better where it matters
    const std::vector<int>& wider = finder.region(seed, s.position, s.direction, widen * radius, widen * along);
    if (wider.size() <= region.size()) break;  // the side ends here
    SideNormal candidate = side_normal(mesh_, faces_, wider, s.position, s.direction, turn, clean_noise(wider));
    if (candidate.uncertainty_rad < best.uncertainty_rad) best = candidate;
    region = wider;
  }
  return best;
}

// The mesh's vertex noise, and the RMS distance of this region's own vertices from their local fit
// where that is larger (a decimated patch whose vertices were moved off the surface).
std::optional<CleanNoise> Extractor::clean_noise(const std::vector<int>& region) const {
  if (model_.features.noisy) return std::nullopt;
  const auto& residual = model_.features.noise.vertex_residual_mm;
  double sum = 0;
  int count = 0;
  for (int f : region)
    for (int k = 0; k < 3; ++k) {
      const float r = residual[static_cast<std::size_t>(mesh_.faces(f, k))];
      if (std::isnan(r)) continue;
      sum += static_cast<double>(r) * r, ++count;
    }
  const double local = count ? std::sqrt(sum / count) : 0;
  const double sigma = model_.features.noise.sigma_mm;
  return CleanNoise{std::max(sigma, local), sigma};
}

namespace {

// A point whose side lies beyond a fold of noise is still on the fold's curve, off the edge by about the
// fold's width: how far it is from where the two sides' planes (through their facets' centroids) meet,
// which the point's δ then covers (delta_at). On a curved side the plane through the centroid lies a
// little inside the surface, so the figure errs large.
double beyond_fold_offset(const Vec3& point, const SideNormal& up, const SideNormal& down) {
  if (!up.beyond_fold && !down.beyond_fold) return 0;
  const double c = up.normal.dot(down.normal), det = 1 - c * c;
  if (det < 1e-6) return 0;  // one plane: no crease line to be off
  const double r0 = up.normal.dot(up.centroid - point), r1 = down.normal.dot(down.centroid - point);
  return ((r0 - c * r1) / det * up.normal + (r1 - c * r0) / det * down.normal).norm();
}

}  // namespace

void Extractor::emit_curve_points(int curve, const std::vector<CurveSample>& samples, int hole) {
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
    // Beyond a fold the curve's convexity flag is the fold's, not the edge's: at a convex edge each
    // side's facets lie behind the other side's plane.
    if (up.beyond_fold || down.beyond_fold)
      p.convex = (up.centroid - p.position).dot(down.normal) < 0 && (down.centroid - p.position).dot(up.normal) < 0;
    p.interior_angle_rad = p.convex ? std::numbers::pi - turn : std::numbers::pi + turn;
    p.n_up_uncertainty_rad = up.uncertainty_rad, p.n_down_uncertainty_rad = down.uncertainty_rad;
    p.n_up_spread_rad = up.facet_spread_rad, p.n_down_spread_rad = down.facet_spread_rad;
    p.curve = curve;
    p.hole = hole;
    p.mesh_deviation_mm = s.chord.sagitta_mm + beyond_fold_offset(p.position, up, down);
    p.position_sigma_mm = s.position_sigma_mm;
    // A facet of a fan is exact at its middle: at most half a chord's turn along the edge from the point,
    // which tilts its normal in the cross-section by up to (θ/2)²/2. A window's margin takes that off.
    const double fan = std::pow(s.chord.turn_rad / 2, 2) / 2 / 3.5;
    p.n_up_uncertainty_rad = std::hypot(p.n_up_uncertainty_rad, fan);
    p.n_down_uncertainty_rad = std::hypot(p.n_down_uncertainty_rad, fan);
    if (model_.features.noisy && std::min(up.face_count, down.face_count) < static_cast<int>(min_region_faces)) {
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

void Extractor::emit_loop_points(SideRegionFinder& finder, int loop_index) {
  const BoundaryLoop& loop = model_.loops[loop_index];
  const std::vector<Vec3> raw = positions(mesh_, loop.vertices);
  const std::optional<Circle3> rim = rim_circle(raw, true, loop.perimeter);
  std::vector<double> noise_gain;
  const std::vector<Vec3> points = smooth_curve(raw, true, rim, noise_gain);
  std::optional<Hole> hole;
  if (loop.kind == LoopKind::hole) {
    if (const std::optional<WallHole> wall = wall_hole(mesh_, adjacency_, faces_, loop, options_.circle_tolerance)) {
      add_wall_hole(*wall);  // the loop is the seen wall's border, not a rim: its points stay boundary
    } else if (rim) {
      const Circle3& circle = *rim;
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
    const double along = along_edge(points, true, s, rim);
    const std::vector<int>& region = finder.region(face, s.position, s.direction, across_edge(face, s), along);
    const SideNormal side =
        side_normal(mesh_, faces_, region, s.position, s.direction, edge_turn(points, true, s, along, rim), clean_noise(region));
    EdgePoint p;
    p.id = static_cast<int>(model_.points.size());
    p.position = s.position;
    p.curve = loop_index;
    p.mesh_deviation_mm = chord_deviation(points, true, s.segment).sagitta_mm;
    p.position_sigma_mm = position_sigma(noise_gain, s.segment);
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
      (face_up ? p.n_down_uncertainty_rad : p.n_up_uncertainty_rad) =
          std::hypot(hole->roundness_mm / hole->radius, options_.inferred_wall_uncertainty_deg * std::numbers::pi / 180);
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

// A hole seen from its wall: unless a bore on the same axis line is already in the model (its rim a
// closed curve), it is a bore whose wall the mesh holds down to the seen depth. Where there is one, the
// rounder of the two circles is the hole's: a small noisy rim's crease fits badly (the plate's Ø3 rim
// from a random scan at σ 0.025 mm: 0.34 mm out of round, 0.1 mm off the axis, its short wall read as
// drafted so its own circle was not used), while its wall's circle was 0.002 mm off.
void Extractor::add_wall_hole(const WallHole& wall) {
  for (Hole& other : model_.holes) {
    const Vec3 off = other.centre - wall.entry_centre;
    const double across = (off - off.dot(wall.axis) * wall.axis).norm();
    if (across > std::max(0.2, 0.1 * wall.radius) || std::abs(other.radius - wall.radius) > 0.1 * wall.radius) continue;
    if (wall.roundness_mm < other.roundness_mm) {
      other.axis = wall.axis.dot(other.axis) >= 0 ? wall.axis : Vec3(-wall.axis);
      other.centre = wall.entry_centre + (other.centre - wall.entry_centre).dot(other.axis) * other.axis;  // at the rim's height
      other.radius = wall.radius;
      other.roundness_mm = wall.roundness_mm;
    }
    return;
  }
  Hole hole;
  hole.id = static_cast<int>(model_.holes.size());
  hole.source = HoleSource::bore;
  hole.centre = wall.entry_centre;
  hole.axis = wall.axis;
  hole.radius = wall.radius;
  hole.perimeter = 2 * std::numbers::pi * wall.radius;
  hole.roundness_mm = wall.roundness_mm;
  hole.depth = wall.seen_depth_mm;
  wall_holes_.push_back(hole.id);
  model_.holes.push_back(std::move(hole));
}

// The entry rim of a hole seen from its wall is a crease the noise broke into pieces (no closed curve
// made it a bore's rim): the sharp-edge points on its circle are its rim points.
void Extractor::adopt_wall_hole_rims() {
  for (int id : wall_holes_) {
    Hole& hole = model_.holes[static_cast<std::size_t>(id)];
    const double reach = std::max(kWallRimReachMm, 0.1 * hole.radius);
    for (EdgePoint& p : model_.points) {
      if (p.kind != EdgeKind::sharp_edge || p.hole >= 0) continue;
      const Vec3 off = p.position - hole.centre;
      const double along = off.dot(hole.axis), radial = (off - along * hole.axis).norm();
      if (std::abs(along) > reach || std::abs(radial - hole.radius) > reach) continue;
      p.kind = EdgeKind::hole_rim;
      p.hole = id;
      hole.rim_point_ids.push_back(p.id);
    }
  }
}

}  // namespace detail

FeatureModel extract_features(const TriangleMesh& mesh, const FeatureModelOptions& options) {
  FeatureModel model = detail::Extractor(mesh, options).run();
  for (const Hole& hole : model.holes)
    for (int id : hole.rim_point_ids) align_to_hole(model.points[static_cast<std::size_t>(id)], hole);
  return model;
}

}  // namespace cmm::geometry
