// Lower bound on the travel time of a move program: the minimum spanning tree of the touches' (x, y)
// and the home point under the trapezoidal travel-time metric.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "planner/motion_time.hpp"

namespace cmm::planner {

// Why it is a lower bound: the travel of any program is a path home → every touch (→ home). An open
// path through all points is a spanning tree of them, so it costs at least the minimum spanning
// tree; a program that returns home contains such an open path (drop its last leg). The bound holds
// for the optimal order, hence for every order.

// Total cost of a minimum spanning tree of points (include the home point yourself) under cost.
// Exact: Prim's O(n²) algorithm up to 5,000 points, above that the Euclidean minimum spanning tree by
// Borůvka on a k-d tree; both give the same total because cost is an increasing function of the
// distance, so a tree minimal for the distance is minimal for the cost. Throws
// std::invalid_argument on a non-finite coordinate.
double minimum_spanning_tree_cost(const std::vector<Eigen::Vector2d>& points, const TravelCost& cost);

// The bound for a program over touch points starting at home (with or without the return leg).
double travel_lower_bound(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& home,
                          const TravelCost& cost);

// The two exact methods minimum_spanning_tree_cost chooses between, for tests and benchmarks.
// Prim runs on squared distances in O(n²), Borůvka in O(n log² n); both then sum cost over the
// edges of the Euclidean tree they found.
double prim_spanning_tree_cost(const std::vector<Eigen::Vector2d>& points, const TravelCost& cost);
double boruvka_spanning_tree_cost(const std::vector<Eigen::Vector2d>& points, const TravelCost& cost);

}  // namespace cmm::planner
