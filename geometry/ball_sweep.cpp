// Around a face, a ball's centre cannot enter a slab over it, a cylinder round each edge or a sphere at each
// corner: first contact is the earliest entry, in closed form, with faces taken relative to the query point.
#include "geometry/ball_sweep.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <vector>

namespace cmm::geometry {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kOnFeature = 1e-9;  // mm: a contact this close to an edge or a corner is on it
// Faces thinner than this fraction of their longest edge are left to their edges and corners. That moves a
// contact by less than the thinness; the normal of such a sliver is not known much better than that anyway.
constexpr double kSliver = 1e-8;

// One face, its corners relative to the query point. Corner 0 is opposite the longest edge, so the
// normal comes from the two shorter edges, which give it most accurately.
struct Face {
  std::array<Vec3, 3> p;
  Vec3 normal;  // unit, or zero for a sliver
  double longest;
};

Face relative_face(const TriangleMesh& mesh, int f, const Vec3& origin) {
  std::array<Vec3, 3> q;
  std::array<double, 3> opposite;  // squared length of the edge opposite each corner
  for (int k = 0; k < 3; ++k) q[k] = vertex(mesh, mesh.faces(f, k)) - origin;
  for (int k = 0; k < 3; ++k) opposite[k] = (q[(k + 2) % 3] - q[(k + 1) % 3]).squaredNorm();
  const int k0 = static_cast<int>(std::max_element(opposite.begin(), opposite.end()) - opposite.begin());
  Face face{{q[k0], q[(k0 + 1) % 3], q[(k0 + 2) % 3]}, Vec3::Zero(), std::sqrt(opposite[k0])};
  const Vec3 n = (face.p[1] - face.p[0]).cross(face.p[2] - face.p[0]);
  const double twice_area = n.norm();
  if (twice_area > kSliver * opposite[k0]) face.normal = n / twice_area;
  return face;
}

bool is_sliver(const Face& face) { return face.normal.isZero(); }

// For a point in the face's plane.
bool inside(const Face& face, const Vec3& x) {
  for (int k = 0; k < 3; ++k) {
    const Vec3& a = face.p[k];
    const Vec3& b = face.p[(k + 1) % 3];
    if ((b - a).cross(x - a).dot(face.normal) < 0) return false;
  }
  return true;
}

Vec3 closest_on_segment(const Vec3& x, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double length2 = ab.squaredNorm();
  if (length2 == 0) return a;
  return a + std::clamp((x - a).dot(ab) / length2, 0.0, 1.0) * ab;
}

Vec3 closest_on_face(const Face& face, const Vec3& x) {
  if (!is_sliver(face)) {
    const Vec3 foot = x - (x - face.p[0]).dot(face.normal) * face.normal;
    if (inside(face, foot)) return foot;
  }
  Vec3 best = face.p[0];
  for (int k = 0; k < 3; ++k) {
    const Vec3 q = closest_on_segment(x, face.p[k], face.p[(k + 1) % 3]);
    if ((q - x).squaredNorm() < (best - x).squaredNorm()) best = q;
  }
  return best;
}

ContactFeature feature_at(const Face& face, const Vec3& x) {
  for (const Vec3& corner : face.p)
    if ((x - corner).norm() <= kOnFeature) return ContactFeature::vertex;
  for (int k = 0; k < 3; ++k)
    if ((x - closest_on_segment(x, face.p[k], face.p[(k + 1) % 3])).norm() <= kOnFeature) return ContactFeature::edge;
  return ContactFeature::face;
}

// Closest points of segments p1q1 and p2q2 (Ericson, Real-Time Collision Detection, 5.1.9).
std::pair<Vec3, Vec3> closest_between_segments(const Vec3& p1, const Vec3& q1, const Vec3& p2, const Vec3& q2) {
  const Vec3 d1 = q1 - p1, d2 = q2 - p2, r = p1 - p2;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  if (a == 0 && e == 0) return {p1, p2};
  double s = 0, t = 0;
  if (a == 0) {
    t = std::clamp(f / e, 0.0, 1.0);
  } else {
    const double c = d1.dot(r);
    if (e == 0) {
      s = std::clamp(-c / a, 0.0, 1.0);
    } else {
      const double b = d1.dot(d2), denominator = a * e - b * b;
      s = denominator > 0 ? std::clamp((b * f - c * e) / denominator, 0.0, 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0) {
        t = 0;
        s = std::clamp(-c / a, 0.0, 1.0);
      } else if (t > 1) {
        t = 1;
        s = std::clamp((b - c) / a, 0.0, 1.0);
      }
    }
  }
  return {p1 + s * d1, p2 + t * d2};
}

struct Nearest {
  double distance;
  Vec3 point;  // on the face
};

// Apart from a crossing, the closest pair has an end of the segment or a point of an edge in it.
Nearest segment_to_face(const Face& face, const Vec3& a, const Vec3& b) {
  if (!is_sliver(face)) {
    const double ha = (a - face.p[0]).dot(face.normal), hb = (b - face.p[0]).dot(face.normal);
    if (ha != hb && std::min(ha, hb) <= 0 && std::max(ha, hb) >= 0) {
      const Vec3 x = a + ha / (ha - hb) * (b - a);
      const Vec3 foot = x - (x - face.p[0]).dot(face.normal) * face.normal;
      if (inside(face, foot)) return {(x - foot).norm(), foot};
    }
  }
  Nearest best{kInf, Vec3::Zero()};
  auto consider = [&](const Vec3& on_segment, const Vec3& on_face) {
    const double distance = (on_segment - on_face).norm();
    if (distance < best.distance) best = {distance, on_face};
  };
  consider(a, closest_on_face(face, a));
  consider(b, closest_on_face(face, b));
  for (int k = 0; k < 3; ++k) {
    const auto [on_segment, on_edge] = closest_between_segments(a, b, face.p[k], face.p[(k + 1) % 3]);
    consider(on_segment, on_edge);
  }
  return best;
}

// Entry into the round region |m + t·d| < r around an axis or a point, where m and d are the start and
// the direction with their parts along the axis removed: a = d·d, b = m·d. The root is taken in the
// form that does not cancel, and comes out ≤ 0 for a ball already touching that is moving in.
double round_entry(double a, double b, double distance, double r) {
  if (b >= 0) return kInf;  // moving away, or parallel
  const double c = (distance - r) * (distance + r);
  const double discriminant = b * b - a * c;
  if (discriminant < 0) return kInf;
  return c / (std::sqrt(discriminant) - b);
}

double corner_entry(const Vec3& corner, const Vec3& d, double r) {
  return round_entry(1.0, -corner.dot(d), corner.norm(), r);
}

// The cylinder around edge pq, between the planes through p and q across it (the corners' spheres cap it).
double edge_entry(const Vec3& p, const Vec3& q, const Vec3& d, double r) {
  const double length = (q - p).norm();
  if (length == 0) return kInf;
  const Vec3 u = (q - p) / length;
  const Vec3 m = -p;
  const Vec3 m_across = m - m.dot(u) * u, d_across = d - d.dot(u) * u;
  const double t = round_entry(d_across.squaredNorm(), m_across.dot(d_across), m_across.norm(), r);
  if (t == kInf) return kInf;
  const double along = (m + std::max(t, 0.0) * d).dot(u);
  return along >= 0 && along <= length ? t : kInf;
}

// The slab of half-width r about the face's plane: when the centre first reaches it (0 if it starts in
// it), and when it enters it over the face itself (the slab's sides over the edges lie in the cylinders).
struct SlabEntry {
  double plane, face;
};

SlabEntry slab_entry(const Face& face, const Vec3& d, double r) {
  if (is_sliver(face)) return {0.0, kInf};
  const double height = -face.p[0].dot(face.normal), rate = d.dot(face.normal);
  const double side = height >= 0 ? 1.0 : -1.0, clearance = std::abs(height) - r;
  if (side * rate >= 0) return {clearance <= 0 ? 0.0 : kInf, kInf};
  const double t = clearance / (-side * rate);
  const double at = std::max(t, 0.0);
  const Vec3 foot = at * d - (height + at * rate) * face.normal;
  return {at, inside(face, foot) ? t : kInf};
}

// Travel (< limit) at which a ball leaving the origin along unit d first touches the face, provided it
// goes on to overlap the face by more than kSweepTouch before max_travel. The distance to a convex face
// is convex along the path, so the first touch and the deepest point bound a single stretch of contact.
std::optional<double> sweep_face(const Face& face, const Vec3& d, double max_travel, double r, double limit) {
  const SlabEntry slab = slab_entry(face, d, r);
  if (!(slab.plane < limit)) return std::nullopt;  // nothing of the face is in reach before its plane is
  double entry = slab.face;
  for (int k = 0; k < 3; ++k) {
    entry = std::min(entry, corner_entry(face.p[k], d, r));
    entry = std::min(entry, edge_entry(face.p[k], face.p[(k + 1) % 3], d, r));
  }
  entry = std::max(entry, 0.0);
  if (!(entry < limit)) return std::nullopt;
  const double leave = std::min(max_travel, entry + face.longest + 2 * r);  // the contact lasts no longer
  // Any point of overlap settles it; one a radius on, or at the end, finds most, quicker than the minimum.
  const Vec3 on = std::min(leave, entry + r) * d;
  if ((closest_on_face(face, on) - on).norm() < r - kSweepTouch) return entry;
  if (!(segment_to_face(face, entry * d, leave * d).distance < r - kSweepTouch)) return std::nullopt;
  return entry;
}

// Where the ray s + t·d (unit d) first comes within `radius` of `centre`: 0 if it starts there, +∞ never.
double ray_ball_entry(const Vec3& s, const Vec3& d, const Vec3& centre, double radius) {
  const Vec3 m = centre - s;
  const double ahead = m.dot(d), clearance = (m.norm() - radius) * (m.norm() + radius);
  if (clearance <= 0) return 0;
  const double discriminant = ahead * ahead - clearance;
  if (ahead <= 0 || discriminant < 0) return kInf;
  return clearance / (ahead + std::sqrt(discriminant));
}

// A ball around a face (about its centroid): testing it first is cheaper than the exact test and, near a
// contact, far tighter than the face's box.
struct Ball {
  Vec3 centre;
  double radius;
};

Ball face_ball(const TriangleMesh& mesh, int f) {
  const Vec3 a = vertex(mesh, mesh.faces(f, 0)), b = vertex(mesh, mesh.faces(f, 1)), c = vertex(mesh, mesh.faces(f, 2));
  const Vec3 centroid = (a + b + c) / 3;
  return {centroid, std::sqrt(std::max({(a - centroid).squaredNorm(), (b - centroid).squaredNorm(),
                                        (c - centroid).squaredNorm()}))};
}

// Where the ray s + t·d enters the box for some t in [0, limit]; +∞ if it does not.
double ray_box_entry(const Vec3& s, const Vec3& d, const Vec3& lo, const Vec3& hi, double limit) {
  double enter = 0, leave = limit;
  for (int k = 0; k < 3; ++k) {
    if (d[k] == 0) {
      if (s[k] < lo[k] || s[k] > hi[k]) return kInf;
      continue;
    }
    const double t0 = (lo[k] - s[k]) / d[k], t1 = (hi[k] - s[k]) / d[k];
    enter = std::max(enter, std::min(t0, t1));
    leave = std::min(leave, std::max(t0, t1));
    if (enter > leave) return kInf;
  }
  return enter;
}

double point_box_distance(const Vec3& p, const Vec3& lo, const Vec3& hi) {
  return (lo - p).cwiseMax(p - hi).cwiseMax(0.0).norm();
}

void check_sweep(const Vec3& start, const Vec3& direction, double max_travel, double radius) {
  if (!start.allFinite()) throw std::invalid_argument("ball sweep: start is not finite");
  if (!direction.allFinite() || direction.norm() == 0)
    throw std::invalid_argument("ball sweep: direction is zero or not finite");
  if (!(max_travel >= 0)) throw std::invalid_argument("ball sweep: max_travel is negative or NaN");
  if (!(radius > 0) || !std::isfinite(radius)) throw std::invalid_argument("ball sweep: radius must be positive");
}

// The faces as a walk visits them: in slots, each holding one of the caller's faces.
struct Slots {
  const TriangleMesh& mesh;         // faces in slot order
  const std::vector<int>& face_of;  // the caller's index of the face in each slot
};

struct NearestSlot {
  double distance = kInf;
  Vec3 point = Vec3::Zero();
  int slot = -1;  // none closer than the limit
};

// `walk` is a tree walk or a plain loop, called as walk(limit, bound, leaf) like TriangleBvh::nearest_first.
template <class Walk>
NearestSlot closest_to_point_by(const Slots& slots, const Walk& walk, const Vec3& p, double limit) {
  NearestSlot best;
  walk(
      limit, [&](const Vec3& lo, const Vec3& hi, double) { return point_box_distance(p, lo, hi); },
      [&](int first, int count, double limit) {
        for (int slot = first; slot < first + count; ++slot) {
          const Vec3 q = closest_on_face(relative_face(slots.mesh, slot, p), Vec3::Zero());
          if (q.norm() < limit) {
            limit = q.norm();
            best = {limit, p + q, slot};
          }
        }
        return limit;
      });
  return best;
}

template <class Walk>
std::optional<SweepHit> first_hit_by(const Slots& slots, const Walk& walk, double box_margin, const Vec3& start,
                                     const Vec3& direction, double max_travel, double radius) {
  check_sweep(start, direction, max_travel, radius);
  if (const NearestSlot overlap = closest_to_point_by(slots, walk, start, radius - kSweepTouch); overlap.slot >= 0) {
    const ContactFeature feature = feature_at(relative_face(slots.mesh, overlap.slot, start), overlap.point - start);
    return SweepHit{0, start, overlap.point, slots.face_of[overlap.slot], feature};
  }

  const Vec3 d = direction.normalized();
  const double reach = radius + box_margin;
  int hit_slot = -1;
  double travel = kInf;
  walk(
      max_travel,
      [&](const Vec3& lo, const Vec3& hi, double limit) {
        // Both the widened box and the ball around it hold every point within reach of the box; each
        // is the tighter one somewhere (long boxes, corners), so the later entry bounds best.
        const double box = ray_box_entry(start, d, lo.array() - reach, hi.array() + reach, limit);
        return box == kInf ? kInf : std::max(box, ray_ball_entry(start, d, (lo + hi) / 2, (hi - lo).norm() / 2 + reach));
      },
      [&](int first, int count, double limit) {
        for (int slot = first; slot < first + count; ++slot) {
          const Ball ball = face_ball(slots.mesh, slot);
          if (!(ray_ball_entry(start, d, ball.centre, ball.radius + reach) < limit)) continue;
          if (const auto t = sweep_face(relative_face(slots.mesh, slot, start), d, max_travel, radius, limit)) {
            limit = travel = *t;
            hit_slot = slot;
          }
        }
        return limit;
      });
  if (hit_slot < 0) return std::nullopt;

  const Vec3 centre = start + travel * d;
  const Face face = relative_face(slots.mesh, hit_slot, centre);
  const Vec3 contact = closest_on_face(face, Vec3::Zero());
  return SweepHit{travel, centre, centre + contact, slots.face_of[hit_slot], feature_at(face, contact)};
}

const TriangleMesh& checked(const TriangleMesh& mesh) {
  const double* coordinates = mesh.vertices.data();
  if (!std::all_of(coordinates, coordinates + mesh.vertices.size(), [](double x) { return std::isfinite(x); }))
    throw std::invalid_argument("ball sweep: a vertex coordinate is not finite");
  if (mesh.faces.size() > 0 && (mesh.faces.minCoeff() < 0 || mesh.faces.maxCoeff() >= mesh.vertices.rows()))
    throw std::invalid_argument("ball sweep: a face refers to a vertex that does not exist");
  return mesh;
}

}  // namespace

BallSweeper::BallSweeper(const TriangleMesh& mesh)
    : tree_(checked(mesh)), mesh_(tree_.in_slot_order(mesh)), box_margin_(kSweepTouch) {
  // Face tests round at about 1e-16 of the coordinates; keep the boxes well clear of that.
  if (mesh_.vertices.size() > 0) box_margin_ += 1e-12 * mesh_.vertices.cwiseAbs().maxCoeff();
}

std::optional<SweepHit> BallSweeper::first_hit(const Vec3& start, const Vec3& direction, double max_travel,
                                               double radius) const {
  const auto walk = [this](double limit, auto&& bound, auto&& leaf) { tree_.nearest_first(limit, bound, leaf); };
  return first_hit_by(Slots{mesh_, tree_.order()}, walk, box_margin_, start, direction, max_travel, radius);
}

BallSweeper::Closest BallSweeper::closest_to_point(const Vec3& p, double within) const {
  if (!p.allFinite() || std::isnan(within)) throw std::invalid_argument("closest_to_point: a coordinate or the bound is not a number");
  const auto walk = [this](double limit, auto&& bound, auto&& leaf) { tree_.nearest_first(limit, bound, leaf); };
  const NearestSlot nearest = closest_to_point_by(Slots{mesh_, tree_.order()}, walk, p, within);
  return {nearest.distance, nearest.point, nearest.slot >= 0 ? tree_.order()[nearest.slot] : -1};
}

BallSweeper::Closest BallSweeper::closest_to_segment(const Vec3& a, const Vec3& b, double within) const {
  if (!a.allFinite() || !b.allFinite() || std::isnan(within))
    throw std::invalid_argument("closest_to_segment: a coordinate or the bound is not a number");
  const Vec3 d = b - a;
  // A lower bound on the distance to anything within `size` of `centre`.
  auto ball_gap = [&](const Vec3& centre, double size) {
    return std::max(0.0, (closest_on_segment(centre, a, b) - centre).norm() - size);
  };
  Closest best{kInf, Vec3::Zero(), -1};
  tree_.nearest_first(
      within,
      [&](const Vec3& lo, const Vec3& hi, double limit) {
        // The ball around the box bounds small boxes well, the widened box long thin ones.
        if (ray_box_entry(a, d, lo.array() - limit, hi.array() + limit, 1.0) == kInf) return kInf;
        return ball_gap((lo + hi) / 2, (hi - lo).norm() / 2);
      },
      [&](int first, int count, double limit) {
        for (int slot = first; slot < first + count; ++slot) {
          const Ball ball = face_ball(mesh_, slot);
          if (!(ball_gap(ball.centre, ball.radius) < limit)) continue;
          const Nearest near = segment_to_face(relative_face(mesh_, slot, a), Vec3::Zero(), d);
          if (near.distance < limit) {
            limit = near.distance;
            best = {limit, a + near.point, tree_.order()[slot]};
          }
        }
        return limit;
      });
  return best;
}

std::optional<SweepHit> first_hit_brute_force(const TriangleMesh& mesh, const Vec3& start, const Vec3& direction,
                                              double max_travel, double radius) {
  std::vector<int> identity(checked(mesh).faces.rows());
  std::iota(identity.begin(), identity.end(), 0);
  const int faces = static_cast<int>(identity.size());
  const auto walk = [faces](double limit, auto&&, auto&& leaf) { leaf(0, faces, limit); };
  return first_hit_by(Slots{mesh, identity}, walk, 0.0, start, direction, max_travel, radius);
}

}  // namespace cmm::geometry
