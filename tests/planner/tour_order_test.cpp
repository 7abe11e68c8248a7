// Touch ordering: always a permutation, never worse than the input order or plain nearest neighbour,
// near the brute-force optimum on small sets and near the spanning-tree bound on grids; duplicates,
// ties and the free end handled.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <stdexcept>

#include "planner/tour_order.hpp"
#include "planner/travel_bound.hpp"
#include "travel_points.hpp"

namespace {

using namespace cmm::planner;
using cmm::planner::testing::Points;
using cmm::planner::testing::random_points;

const TravelCost& cost = cmm::planner::testing::travel_cost;

// Edge points along a few arcs, each touched twice a few mm apart: what the planner produces.
Points paired_arc_points(int pairs, unsigned seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> unit(0, 1);
  Points points;
  while (static_cast<int>(points.size()) < 2 * pairs) {
    const Eigen::Vector2d centre(300 * unit(random), 300 * unit(random));
    const double radius = 5 + 40 * unit(random), start = 6.3 * unit(random);
    for (int k = 0; k < 30 && static_cast<int>(points.size()) < 2 * pairs; ++k) {
      const double angle = start + k * 2.0 / radius;
      const Eigen::Vector2d on_arc = centre + radius * Eigen::Vector2d(std::cos(angle), std::sin(angle));
      points.push_back(on_arc + Eigen::Vector2d(1.5, 0));
      points.push_back(on_arc - Eigen::Vector2d(1.5, 0));
    }
  }
  std::shuffle(points.begin(), points.end(), random);
  return points;
}

bool is_permutation_of_indices(const std::vector<int>& order, std::size_t n) {
  std::vector<int> sorted = order, expected(n);
  std::sort(sorted.begin(), sorted.end());
  std::iota(expected.begin(), expected.end(), 0);
  return sorted == expected;
}

std::vector<int> identity(std::size_t n) {
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  return order;
}

// Every order of the points, on a precomputed cost table (node 0 is home) so that it stays quick
// in unoptimised builds.
double brute_force_optimum(const Points& points, const Eigen::Vector2d& home, bool return_home) {
  const int n = static_cast<int>(points.size());
  Points nodes{home};
  nodes.insert(nodes.end(), points.begin(), points.end());
  std::vector<double> table((n + 1) * (n + 1));
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) table[i * (n + 1) + j] = cost(nodes[i], nodes[j]);
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 1);
  double best = std::numeric_limits<double>::infinity();
  do {
    double total = table[order[0]];
    for (int k = 1; k < n; ++k) total += table[order[k - 1] * (n + 1) + order[k]];
    if (return_home) total += table[order[n - 1] * (n + 1)];
    best = std::min(best, total);
  } while (std::next_permutation(order.begin(), order.end()));
  return best;
}

TEST(OrderTouches, IsAPermutationBetterThanInputAndNearestNeighbour) {
  for (bool return_home : {true, false})
    for (unsigned seed = 0; seed < 4; ++seed) {
      const Points points = seed % 2 ? random_points(300 + 200 * seed, seed) : paired_arc_points(400, seed);
      const Eigen::Vector2d home(-20, 150);
      OrderOptions options;
      options.return_home = return_home;
      const std::vector<int> order = order_touches(points, home, cost, options);
      ASSERT_TRUE(is_permutation_of_indices(order, points.size()));
      options.max_moves = 0;
      const std::vector<int> nearest = order_touches(points, home, cost, options);
      ASSERT_TRUE(is_permutation_of_indices(nearest, points.size()));
      const double improved = travel_time(points, home, order, cost, return_home);
      EXPECT_LE(improved, travel_time(points, home, nearest, cost, return_home));
      EXPECT_LT(improved, travel_time(points, home, identity(points.size()), cost, return_home));
      EXPECT_GE(improved, travel_lower_bound(points, home, cost));
    }
}

TEST(OrderTouches, NearTheOptimumOnSmallSets) {
  double sum_ratio = 0;
  int sets = 0;
  for (bool return_home : {true, false})
    for (unsigned seed = 0; seed < 6; ++seed) {
      const Points points = random_points(8, 50 + seed, 200);
      const Eigen::Vector2d home(100, -10);
      OrderOptions options;
      options.return_home = return_home;
      const std::vector<int> order = order_touches(points, home, cost, options);
      const double ratio = travel_time(points, home, order, cost, return_home) /
                           brute_force_optimum(points, home, return_home);
      EXPECT_LE(ratio, 1.05) << "seed " << seed << (return_home ? " closed" : " open");
      EXPECT_GE(ratio, 1 - 1e-12);
      sum_ratio += ratio;
      ++sets;
    }
  EXPECT_LE(sum_ratio / sets, 1.02);
}

TEST(OrderTouches, GridWithinFifteenPercentOfTheBound) {
  // A grid is all ties; from a corner the open path can reach the spanning-tree bound exactly.
  Points points;
  for (int i = 0; i < 30; ++i)
    for (int j = 0; j < 30; ++j) points.emplace_back(5.0 * i, 5.0 * j);
  std::shuffle(points.begin(), points.end(), std::mt19937(9));
  const Eigen::Vector2d home(0, -5);
  OrderOptions options;
  options.return_home = false;
  const std::vector<int> order = order_touches(points, home, cost, options);
  ASSERT_TRUE(is_permutation_of_indices(order, points.size()));
  const double bound = travel_lower_bound(points, home, cost);
  EXPECT_LE(travel_time(points, home, order, cost, false), 1.15 * bound);
}

TEST(OrderTouches, CollinearPointsAreSweptInOneGo) {
  Points points;
  for (int i = 1; i <= 200; ++i) points.emplace_back(3.0 * i, 10);
  std::shuffle(points.begin(), points.end(), std::mt19937(2));
  const Eigen::Vector2d home(0, 10);
  OrderOptions options;
  options.return_home = false;
  const std::vector<int> order = order_touches(points, home, cost, options);
  EXPECT_NEAR(travel_time(points, home, order, cost, false), 200 * cost.of_distance(3), 1e-9);
}

TEST(OrderTouches, DuplicatesAreVisitedBackToBack) {
  Points points = random_points(200, 11);
  const Points distinct = points;
  for (int copy = 0; copy < 3; ++copy) points.insert(points.end(), distinct.begin(), distinct.begin() + 100);
  std::shuffle(points.begin(), points.end(), std::mt19937(12));
  const Eigen::Vector2d home(150, 150);
  const std::vector<int> order = order_touches(points, home, cost);
  ASSERT_TRUE(is_permutation_of_indices(order, points.size()));
  int zero_legs = 0;
  for (std::size_t k = 1; k < order.size(); ++k) zero_legs += points[order[k]] == points[order[k - 1]];
  EXPECT_EQ(zero_legs, 300);  // every copy right after its twin
}

TEST(OrderTouches, DegenerateSets) {
  const Eigen::Vector2d home(1, 1);
  EXPECT_TRUE(order_touches({}, home, cost).empty());
  EXPECT_EQ(order_touches({{5, 5}}, home, cost), std::vector<int>{0});
  EXPECT_EQ(order_touches(Points(50, home), home, cost), identity(50));  // all at home: input order
  const std::vector<int> two = order_touches({{100, 0}, {2, 1}}, home, cost, {.return_home = false});
  EXPECT_EQ(two, (std::vector<int>{1, 0}));
  EXPECT_THROW(order_touches({{0, std::nan("")}}, home, cost), std::invalid_argument);
  EXPECT_THROW(order_touches({{0, 0}}, Eigen::Vector2d(INFINITY, 0), cost), std::invalid_argument);
}

TEST(OrderTouches, TheFreeEndIsUsed) {
  // Points on a line away from home: with a return leg the order hardly matters at the far end,
  // without one the path must not double back.
  Points points;
  for (int i = 0; i < 50; ++i) points.emplace_back(10.0 + 4.0 * ((i * 37) % 50), 0);
  const Eigen::Vector2d home(0, 0);
  OrderOptions options;
  options.return_home = false;
  const std::vector<int> order = order_touches(points, home, cost, options);
  EXPECT_EQ(points[order.front()].x(), 10);
  EXPECT_EQ(points[order.back()].x(), 10 + 4 * 49);
}

TEST(OrderTouches, BudgetsStopTheImprovement) {
  const Points points = random_points(1000, 21);
  const Eigen::Vector2d home(0, 0);
  OrderOptions options;
  options.improve_time_s = 0;
  const std::vector<int> rushed = order_touches(points, home, cost, options);
  ASSERT_TRUE(is_permutation_of_indices(rushed, points.size()));
  options.improve_time_s = 10;
  options.max_moves = 5;
  const double five = travel_time(points, home, order_touches(points, home, cost, options), cost);
  options.max_moves = 0;
  const double none = travel_time(points, home, order_touches(points, home, cost, options), cost);
  options.max_moves = -1;
  const double all = travel_time(points, home, order_touches(points, home, cost, options), cost);
  EXPECT_LT(five, none);
  EXPECT_LT(all, five);
}

}  // namespace
