// Touch ordering and its spanning-tree bound at program sizes (2,000 touches) and far beyond
// (100,000), on points laid like a planner's: pairs of touches a few mm apart along arcs and lines.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>

#include "planner/tour_order.hpp"
#include "planner/travel_bound.hpp"

namespace {

using namespace cmm::planner;
using Points = std::vector<Eigen::Vector2d>;

const TravelCost cost{100, 500};  // the default machine's travel limits
const Eigen::Vector2d home(0, 0);

// Curves (arcs and straight runs) with an edge point every 2 mm, each touched twice 3 mm apart
// across the edge; one point in 20 is planned twice at exactly the same spot.
Points edge_like_points(int count, unsigned seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> unit(0, 1);
  const double field = 20 * std::sqrt(static_cast<double>(count));  // keeps the density fixed
  Points points;
  points.reserve(count);
  while (static_cast<int>(points.size()) < count) {
    const Eigen::Vector2d start(field * unit(random), field * unit(random));
    const double radius = unit(random) < 0.5 ? 5 + 60 * unit(random) : INFINITY;  // arc or line
    const double heading = 6.283 * unit(random);
    const int along = 5 + static_cast<int>(60 * unit(random));
    for (int k = 0; k < along && static_cast<int>(points.size()) < count; ++k) {
      const double s = 2.0 * k, turn = std::isinf(radius) ? 0 : s / radius;
      const Eigen::Vector2d tangent(std::cos(heading + turn), std::sin(heading + turn));
      const Eigen::Vector2d at = std::isinf(radius) ? Eigen::Vector2d(start + s * tangent)
                                                    : Eigen::Vector2d(start + radius * Eigen::Vector2d(std::sin(heading + turn) - std::sin(heading),
                                                                                                 std::cos(heading) - std::cos(heading + turn)));
      const Eigen::Vector2d across(-tangent.y(), tangent.x());
      points.push_back(at + 1.5 * across);
      if (static_cast<int>(points.size()) < count) points.push_back(at - 1.5 * across);
      if (unit(random) < 0.05 && static_cast<int>(points.size()) < count) points.push_back(points.back());
    }
  }
  std::shuffle(points.begin(), points.end(), random);
  return points;
}

void bm_order_touches(benchmark::State& state) {
  const Points points = edge_like_points(static_cast<int>(state.range(0)), 1);
  OrderOptions options;
  options.improve_time_s = 10;  // let it converge: the figure of interest is the time it needs
  std::vector<int> order;
  for (auto _ : state) {
    order = order_touches(points, home, cost, options);
    benchmark::DoNotOptimize(order.data());
  }
  OrderOptions nearest = options;
  nearest.max_moves = 0;
  const double ordered = travel_time(points, home, order, cost);
  const double bound = travel_lower_bound(points, home, cost);
  state.counters["travel_s"] = ordered;
  state.counters["nn_travel_s"] = travel_time(points, home, order_touches(points, home, cost, nearest), cost);
  state.counters["bound_s"] = bound;
  state.counters["travel/bound"] = ordered / bound;
}

void bm_nearest_neighbour(benchmark::State& state) {
  const Points points = edge_like_points(static_cast<int>(state.range(0)), 1);
  OrderOptions options;
  options.max_moves = 0;
  for (auto _ : state) benchmark::DoNotOptimize(order_touches(points, home, cost, options).data());
}

void bm_spanning_tree_boruvka(benchmark::State& state) {
  const Points points = edge_like_points(static_cast<int>(state.range(0)), 1);
  for (auto _ : state) benchmark::DoNotOptimize(boruvka_spanning_tree_cost(points, cost));
}

void bm_spanning_tree_prim(benchmark::State& state) {
  const Points points = edge_like_points(static_cast<int>(state.range(0)), 1);
  for (auto _ : state) benchmark::DoNotOptimize(prim_spanning_tree_cost(points, cost));
}

BENCHMARK(bm_order_touches)->Arg(2'000)->Arg(100'000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(bm_nearest_neighbour)->Arg(2'000)->Arg(100'000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(bm_spanning_tree_prim)->Arg(2'000)->Arg(5'000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(bm_spanning_tree_boruvka)->Arg(2'000)->Arg(5'000)->Arg(100'000)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
