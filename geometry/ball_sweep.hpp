// Exact first contact of a moving ball (the probe tip) with a triangle mesh, and clearances to it:
// the planner's collision test for every approach and retract move, so it is exact rather than sampled.
#pragma once

#include <limits>
#include <optional>

#include "geometry/mesh.hpp"
#include "geometry/triangle_bvh.hpp"

namespace cmm::geometry {

enum class ContactFeature { face, edge, vertex };

struct SweepHit {
  double travel = 0;  // mm the centre moved from the start to the first contact (>= 0)
  Vec3 centre;        // ball centre at contact
  Vec3 contact;       // the touched point of the mesh
  int face = -1;      // a face containing `contact`
  ContactFeature feature = ContactFeature::face;  // where on `face`: interior, an edge or a corner (within 1 nm)
};

// A touch is not a collision: the ball hits a face only if it would overlap it by more than this; a ball
// starting closer than radius − kSweepTouch overlaps at once. Grazing along a face at exactly the radius,
// leaving a face it touches, or ending a move just touching a face is no hit.
inline constexpr double kSweepTouch = 1e-9;  // mm

// Faces are two-sided surfaces: which side holds material does not matter. Builds its tree once; after
// that every query is const and needs no lock to share between threads.
class BallSweeper {
 public:
  // Keeps its own copy of the faces (a changed or freed mesh cannot break it), in the tree's order.
  // Throws std::invalid_argument for a face index out of range or a coordinate that is not finite.
  explicit BallSweeper(const TriangleMesh& mesh);

  // The first contact of a ball of `radius` (> 0) whose centre moves from `start` along `direction`
  // (normalized here, must not be zero) for at most `max_travel` mm (may be +∞). nullopt if the move is
  // free. A ball that already overlaps the mesh returns travel 0 with the closest point as contact.
  std::optional<SweepHit> first_hit(const Vec3& start, const Vec3& direction, double max_travel, double radius) const;

  // The nearest point of the mesh, looked for only closer than `within`: distance +∞ and face −1
  // when nothing is (or the mesh is empty). A clearance check asks "is anything within the shaft's
  // radius", and the bound lets the tree skip everything farther: ~10× faster than the full search.
  struct Closest {
    double distance;
    Vec3 point;  // on the mesh
    int face;
  };
  Closest closest_to_point(const Vec3& p, double within = std::numeric_limits<double>::infinity()) const;
  Closest closest_to_segment(const Vec3& a, const Vec3& b, double within = std::numeric_limits<double>::infinity()) const;

 private:
  TriangleBvh tree_;
  TriangleMesh mesh_;  // the faces in the tree's slots
  double box_margin_;  // widens boxes past any rounding in the face tests, so pruning never drops a contact
};

// The same answer as BallSweeper::first_hit by a loop over every face and no tree: the reference the
// tests and benchmarks hold the tree against.
std::optional<SweepHit> first_hit_brute_force(const TriangleMesh& mesh, const Vec3& start, const Vec3& direction,
                                              double max_travel, double radius);

}  // namespace cmm::geometry
