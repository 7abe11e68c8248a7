// The order the machine visits its touches in: an open path over the touches' (x, y) on the
// clearance plane, from home and (by default) back, short in travel time.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "planner/motion_time.hpp"

namespace cmm::planner {

struct OrderOptions {
  bool return_home = true;  // the program ends at home; false leaves the last touch's end free
  int neighbours = 10;      // candidate list length for 2-opt and Or-opt (the k nearest points)
  // Budgets for the improvement phase (the nearest-neighbour construction always completes).
  double improve_time_s = 1.0;  // wall time
  long max_moves = -1;          // improving moves applied; -1 unlimited, 0 gives plain nearest neighbour
};

// Indices into points in visiting order: a permutation of 0 … n−1. The order starts at home and
// minimises travel heuristically under cost: nearest-neighbour construction on a k-d tree, then
// 2-opt and Or-opt (segments of up to three points, either way round) over k-nearest candidate
// lists until no move improves or a budget runs out. Exact duplicates are visited one after the
// other, in input order; the input order itself is returned when it is cheaper. Throws
// std::invalid_argument on a non-finite coordinate.
std::vector<int> order_touches(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& home,
                               const TravelCost& cost, const OrderOptions& options = {});

// Travel time of visiting points in order from home (and back when return_home).
double travel_time(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& home,
                   const std::vector<int>& order, const TravelCost& cost, bool return_home = true);

}  // namespace cmm::planner
