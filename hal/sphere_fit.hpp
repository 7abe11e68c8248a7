// Least-squares sphere through measured points: what qualification fits to the ball centres it
// touched on the reference sphere (their sphere has radius R_sphere + r_ball).
#pragma once

#include <vector>

#include "hal/motion.hpp"

namespace cmm::hal {

struct SphereFit {
  Vec3 centre = Vec3::Zero();
  double radius = 0;
  double residual_rms = 0;  // of the radial distances, mm
};

// Algebraic fit for a start, then Gauss–Newton on the geometric distances (the algebraic fit alone
// is biased when the points cover only a cap, as touches on a reference sphere do). Throws
// std::invalid_argument for fewer than four points, non-finite points, or points on one plane.
SphereFit fit_sphere(const std::vector<Vec3>& points);

}  // namespace cmm::hal
