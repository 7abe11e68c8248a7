// The spanning-tree bound: Prim and Borůvka agree with each other and with a brute-force Kruskal,
// on random sets and on the degenerate ones (duplicates, collinear points, grids full of ties).
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

// Every pair sorted, joined with a union–find: the textbook algorithm, with no cleverness to trust.
double kruskal_cost(const Points& points) {
  const int n = static_cast<int>(points.size());
  struct Pair {
    double length;
    int i, j;
  };
  std::vector<Pair> edges;
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) edges.push_back({(points[i] - points[j]).norm(), i, j});
  std::sort(edges.begin(), edges.end(), [](const Pair& x, const Pair& y) { return x.length < y.length; });
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  auto root = [&](int i) {
    while (parent[i] != i) i = parent[i];
    return i;
  };
  double total = 0;
  for (const Pair& edge : edges)
    if (root(edge.i) != root(edge.j)) {
      parent[root(edge.i)] = root(edge.j);
      total += cost.of_distance(edge.length);
    }
  return total;
}

void expect_methods_agree(const Points& points) {
  const double prim = prim_spanning_tree_cost(points, cost);
  const double boruvka = boruvka_spanning_tree_cost(points, cost);
  EXPECT_NEAR(prim, boruvka, 1e-9 * std::max(1.0, prim)) << points.size() << " points";
}

// Borůvka takes over from Prim above 5,000 points; 6,000 compares them where the switch happens.
TEST(SpanningTree, PrimAndBoruvkaAgreeOnRandomSets) {
  expect_methods_agree(random_points(6000, 1));
  expect_methods_agree(random_points(2000, 2, 5));  // dense: many edges in the triangular profile
}

TEST(SpanningTree, PrimAndBoruvkaAgreeWithDuplicates) {
  Points points = random_points(750, 3);
  const Points copies = points;
  for (int k = 0; k < 3; ++k) points.insert(points.end(), copies.begin(), copies.end());  // each four times
  std::shuffle(points.begin(), points.end(), std::mt19937(4));
  expect_methods_agree(points);
  EXPECT_NEAR(boruvka_spanning_tree_cost(points, cost), boruvka_spanning_tree_cost(copies, cost), 1e-9);
}

TEST(SpanningTree, PrimAndBoruvkaAgreeOnCollinearPointsAndGrids) {
  Points line;
  for (int i = 0; i < 3000; ++i) line.emplace_back(0.5 * (i % 1500), 0.25 * (i % 1500) + 1);  // evenly spaced, twice
  std::shuffle(line.begin(), line.end(), std::mt19937(5));
  expect_methods_agree(line);
  const double line_tree = 1499 * cost.of_distance(std::hypot(0.5, 0.25));
  EXPECT_NEAR(boruvka_spanning_tree_cost(line, cost), line_tree, 1e-12 * line_tree);

  Points grid;
  for (int i = 0; i < 50; ++i)
    for (int j = 0; j < 45; ++j) grid.emplace_back(2.0 * i, 2.0 * j);
  expect_methods_agree(grid);
  const double grid_tree = (50 * 45 - 1) * cost.of_distance(2);
  EXPECT_NEAR(boruvka_spanning_tree_cost(grid, cost), grid_tree, 1e-12 * grid_tree);
}

TEST(SpanningTree, BothMatchKruskalOnSmallSets) {
  for (int n = 0; n <= 60; n += 3) {
    Points points = random_points(n, 100 + n, 50);
    if (n > 10) points[n - 1] = points[0];  // a duplicate now and then
    const double kruskal = kruskal_cost(points);
    EXPECT_NEAR(prim_spanning_tree_cost(points, cost), kruskal, 1e-9) << n;
    EXPECT_NEAR(boruvka_spanning_tree_cost(points, cost), kruskal, 1e-9) << n;
    EXPECT_NEAR(minimum_spanning_tree_cost(points, cost), kruskal, 1e-9) << n;
  }
}

TEST(SpanningTree, TrivialSetsCostNothing) {
  EXPECT_EQ(minimum_spanning_tree_cost({}, cost), 0);
  EXPECT_EQ(minimum_spanning_tree_cost({Eigen::Vector2d(1, 2)}, cost), 0);
  EXPECT_EQ(boruvka_spanning_tree_cost(Points(20, Eigen::Vector2d(1, 2)), cost), 0);
}

TEST(SpanningTree, RefusesNonFiniteCoordinates) {
  const Points points{{0, 0}, {std::nan(""), 1}};
  EXPECT_THROW(minimum_spanning_tree_cost(points, cost), std::invalid_argument);
  EXPECT_THROW(boruvka_spanning_tree_cost(points, cost), std::invalid_argument);
}

TEST(TravelLowerBound, NeverExceedsTheBestOrder) {
  // Brute force over all orders of 7 points (node 0 is home), with and without the return leg.
  for (unsigned seed = 0; seed < 5; ++seed) {
    const Points points = random_points(7, 200 + seed, 100);
    const Eigen::Vector2d home(0, 0);
    Points nodes{home};
    nodes.insert(nodes.end(), points.begin(), points.end());
    double table[8][8];
    for (int i = 0; i < 8; ++i)
      for (int j = 0; j < 8; ++j) table[i][j] = cost(nodes[i], nodes[j]);
    std::vector<int> order{1, 2, 3, 4, 5, 6, 7};
    double best_open = std::numeric_limits<double>::infinity(), best_closed = best_open;
    do {
      double open = table[0][order[0]];
      for (int k = 1; k < 7; ++k) open += table[order[k - 1]][order[k]];
      best_open = std::min(best_open, open);
      best_closed = std::min(best_closed, open + table[order[6]][0]);
    } while (std::next_permutation(order.begin(), order.end()));
    const double bound = travel_lower_bound(points, home, cost);
    EXPECT_GT(bound, 0);
    EXPECT_LE(bound, best_open + 1e-12);
    EXPECT_LE(best_open, best_closed);
  }
}

}  // namespace
