// Resampling a feature curve or boundary loop at a fixed spacing, after optional smoothing of its
// vertices; reference edge points are placed at the samples.
#pragma once

#include <vector>

#include "geometry/circle_fit.hpp"
#include "geometry/mesh.hpp"

namespace cmm::geometry {

struct PolylineSample {
  Vec3 position;
  Vec3 direction;  // unit, along the polyline
  int segment;     // index of the segment the sample lies on
};

// Local quadratic (Savitzky–Golay) fit over ±half_window vertices by arc length: removes
// vertex noise without shrinking circles, as a moving average would. `noise_gain`, when given, gets
// per vertex the variance of the smoothed position over a raw vertex's (1 where nothing is smoothed;
// largest at an open curve's ends, where the fit reaches out to one side).
std::vector<Vec3> smooth_polyline(const std::vector<Vec3>& points, bool closed, int half_window,
                                  std::vector<double>* noise_gain = nullptr);

// The same fit for a closed curve that is a circle (a rim), made on its radius and height about the
// circle's axis by angle: a round rim keeps both constant, so a window as wide as the noise asks for
// leaves no bias, where one by arc length cuts the corner of a small circle. Along the rim the
// vertices stay where they are.
std::vector<Vec3> smooth_rim(const std::vector<Vec3>& points, const Circle3& circle, int half_window,
                             std::vector<double>* noise_gain = nullptr);

// Samples at the centres of equal arcs no longer than `spacing`, so no sample sits on a corner
// and every point of the curve is within spacing/2 of one. A closed polyline wraps around.
std::vector<PolylineSample> sample_polyline(const std::vector<Vec3>& points, bool closed, double spacing);

// How the polyline turns at a sample: axis × rate (rad per unit length), from the chords to the
// points `half_length` back and ahead along it (fewer at an open end). Zero on a straight run, and
// where the rate over half the span differs by over 15 % (a corner, not a circle, is within reach).
// A side normal at s along a rim is this turn applied to the normal at the sample, to second order.
Vec3 polyline_turn(const std::vector<Vec3>& points, bool closed, const PolylineSample& sample, double half_length);

// How far segment `segment` of the polyline may lie from the smooth curve its vertices sample. An arc
// turns the same way at both ends of a chord, by similar angles of at most 60°: then `turn_rad` is the
// smaller of the two (the angle the chord subtends) and the chord lies up to its sagitta L·θ/8 inside
// the arc (16 chords of an R 100 circle: 1.92 mm). A corner, a zigzag of decimation, a straight run
// or an open end does not, and there the chord is the curve (both 0).
struct ChordDeviation {
  double turn_rad = 0;
  double sagitta_mm = 0;
};
ChordDeviation chord_deviation(const std::vector<Vec3>& points, bool closed, int segment);

}  // namespace cmm::geometry
