// The rim of a slot (a stadium along x) by arc length: what the two box meshers and the analytic parts'
// true edges share, so that a slot's rim vertices and its true edge samples lie on one exact curve.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <numbers>

#include "geometry/box_with_holes_mesher.hpp"

namespace cmm::geometry {

// Runs counter-clockwise seen from +z from arc length 0 at the bottom of the right half circle: right
// half circle, upper straight side, left half circle, lower straight side. Every rim point is an axis
// point (on the segment between the end circles' centres) plus radius times the outward unit normal;
// on the straight sides the normal is exactly ±y, so their points lie exactly at y ± radius.
class SlotRim {
 public:
  struct Station {
    Eigen::Vector2d axis;    // nearest point of the slot's axis segment
    Eigen::Vector2d normal;  // outward (into the material), unit
  };

  explicit SlotRim(const VerticalHole& hole)
      : centre_(hole.x, hole.y), half_(hole.slot_length / 2), length_(hole.slot_length), r_(hole.radius) {}

  double radius() const { return r_; }
  double perimeter() const { return 2 * length_ + 2 * std::numbers::pi * r_; }

  // At arc length s, taken modulo the perimeter.
  Station at(double s) const {
    const double pi_r = std::numbers::pi * r_;
    s = std::fmod(s, perimeter());
    if (s < 0) s += perimeter();
    if (s < pi_r) return cap(+1, -std::numbers::pi / 2 + s / r_);
    s -= pi_r;
    if (s < length_) return {{centre_.x() + half_ - s, centre_.y()}, {0.0, 1.0}};
    s -= length_;
    if (s < pi_r) return cap(-1, std::numbers::pi / 2 + s / r_);
    s -= pi_r;
    return {{centre_.x() - half_ + std::min(s, length_), centre_.y()}, {0.0, -1.0}};
  }
  Eigen::Vector2d point(double s) const {
    const Station station = at(s);
    return station.axis + r_ * station.normal;
  }

  // The arc length of the rim point whose outward normal ray passes through p (p outside the rim).
  double arc_length_toward(const Eigen::Vector2d& p) const {
    const double pi_r = std::numbers::pi * r_;
    if (p.x() >= centre_.x() - half_ && p.x() <= centre_.x() + half_ && length_ > 0)
      return p.y() >= centre_.y() ? pi_r + (centre_.x() + half_ - p.x()) : 2 * pi_r + length_ + (p.x() - (centre_.x() - half_));
    if (p.x() > centre_.x()) return (std::atan2(p.y() - centre_.y(), p.x() - centre_.x() - half_) + std::numbers::pi / 2) * r_;
    double angle = std::atan2(p.y() - centre_.y(), p.x() - centre_.x() + half_);  // (π/2, 3π/2) on the left end
    if (angle < 0) angle += 2 * std::numbers::pi;
    return pi_r + length_ + (angle - std::numbers::pi / 2) * r_;
  }

  // Distance of p from the axis segment (the rim lies `radius` out from it).
  double axis_distance(const Eigen::Vector2d& p) const {
    const Eigen::Vector2d nearest(std::clamp(p.x(), centre_.x() - half_, centre_.x() + half_), centre_.y());
    return (p - nearest).norm();
  }

 private:
  Station cap(int side, double angle) const {
    return {{centre_.x() + side * half_, centre_.y()}, {std::cos(angle), std::sin(angle)}};
  }

  Eigen::Vector2d centre_;
  double half_, length_, r_;
};

}  // namespace cmm::geometry
