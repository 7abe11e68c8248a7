// Test support for the ordering and the spanning-tree bound: the default machine's travel cost and
// seeded random touch positions on the table.
#pragma once

#include <random>
#include <vector>

#include "planner/motion_time.hpp"

namespace cmm::planner::testing {

using Points = std::vector<Eigen::Vector2d>;

inline const TravelCost travel_cost{100, 500};

inline Points random_points(int n, unsigned seed, double size = 300) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> coordinate(0, size);
  Points points(n);
  for (auto& p : points) p = {coordinate(random), coordinate(random)};
  return points;
}

}  // namespace cmm::planner::testing
