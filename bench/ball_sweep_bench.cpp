// Building the ball sweeper's tree and sweeping the probe ball at 100k and 1M triangles, on the case-3
// block meshed finely enough: the planner checks every approach and retract move with these queries.
#include <benchmark/benchmark.h>

#include <cmath>
#include <map>
#include <random>
#include <vector>

#include "geometry/analytic_parts.hpp"
#include "geometry/ball_sweep.hpp"

namespace {

using namespace cmm::geometry;

// The block has ≈ 78,000 triangles at 1 mm edges, and the count goes with 1/h².
double edge_length_for(long triangles) { return std::sqrt(78000.0 / static_cast<double>(triangles)); }

const TriangleMesh& block(long triangles) {
  static std::map<long, TriangleMesh> meshes;
  auto [it, fresh] = meshes.try_emplace(triangles);
  if (fresh) it->second = make_case3_block(edge_length_for(triangles)).mesh;
  return it->second;
}

const BallSweeper& sweeper(long triangles) {
  static std::map<long, BallSweeper> sweepers;
  auto it = sweepers.find(triangles);
  if (it == sweepers.end()) it = sweepers.emplace(triangles, BallSweeper(block(triangles))).first;
  return it->second;
}

struct Move {
  Vec3 start, direction;
  double radius;
};

// Starts 0–5 mm clear of a random face, moving towards it (`aimed`, a touch) or anywhere (a retract or
// a traverse, mostly free); radius 1–3 mm, at most 20 mm of travel.
std::vector<Move> moves_near_surface(const TriangleMesh& mesh, bool aimed) {
  std::mt19937_64 random(42);
  std::uniform_real_distribution<double> unit(0, 1);
  std::normal_distribution<double> normal;
  std::uniform_int_distribution<int> any_face(0, static_cast<int>(mesh.faces.rows()) - 1);
  std::vector<Move> moves;
  for (int i = 0; i < 4096; ++i) {
    const int f = any_face(random);
    const Vec3 a = vertex(mesh, mesh.faces(f, 0)), b = vertex(mesh, mesh.faces(f, 1)), c = vertex(mesh, mesh.faces(f, 2));
    const Vec3 n = (b - a).cross(c - a).normalized();
    const double radius = 1 + 2 * unit(random);
    const Vec3 jitter(normal(random), normal(random), normal(random));
    const Vec3 start = (a + b + c) / 3 + (radius + 5 * unit(random)) * n;
    const Vec3 direction = aimed ? (0.6 * jitter.normalized() - n).normalized() : jitter.normalized();
    moves.push_back({start, direction, radius});
  }
  return moves;
}

void bm_build_sweeper(benchmark::State& state) {
  const TriangleMesh& mesh = block(state.range(0));
  for (auto _ : state) {
    const BallSweeper built(mesh);
    benchmark::DoNotOptimize(&built);
  }
  state.counters["triangles"] = static_cast<double>(mesh.faces.rows());
}

void sweep_moves(benchmark::State& state, bool aimed) {
  const BallSweeper& swept = sweeper(state.range(0));
  const std::vector<Move> moves = moves_near_surface(block(state.range(0)), aimed);
  std::size_t i = 0;
  long hits = 0;
  for (auto _ : state) {
    const Move& move = moves[i++ % moves.size()];
    const auto hit = swept.first_hit(move.start, move.direction, 20, move.radius);
    hits += hit.has_value();
    benchmark::DoNotOptimize(hit);
  }
  state.counters["triangles"] = static_cast<double>(block(state.range(0)).faces.rows());
  state.counters["hit_fraction"] = static_cast<double>(hits) / static_cast<double>(state.iterations());
  state.SetItemsProcessed(state.iterations());
}

// The loop over every face that the tree saves, for scale.
void bm_first_hit_brute_force(benchmark::State& state) {
  const TriangleMesh& mesh = block(state.range(0));
  const std::vector<Move> moves = moves_near_surface(mesh, true);
  std::size_t i = 0;
  for (auto _ : state) {
    const Move& move = moves[i++ % moves.size()];
    benchmark::DoNotOptimize(first_hit_brute_force(mesh, move.start, move.direction, 20, move.radius));
  }
  state.SetItemsProcessed(state.iterations());
}

void bm_first_hit_towards_surface(benchmark::State& state) { sweep_moves(state, true); }
void bm_first_hit_any_direction(benchmark::State& state) { sweep_moves(state, false); }

void bm_closest_to_segment(benchmark::State& state) {
  const BallSweeper& swept = sweeper(state.range(0));
  const std::vector<Move> moves = moves_near_surface(block(state.range(0)), false);
  std::size_t i = 0;
  for (auto _ : state) {
    const Move& move = moves[i++ % moves.size()];
    benchmark::DoNotOptimize(swept.closest_to_segment(move.start, move.start + 20 * move.direction));
  }
  state.SetItemsProcessed(state.iterations());
}

BENCHMARK(bm_build_sweeper)->Arg(100'000)->Arg(1'000'000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(bm_first_hit_towards_surface)->Arg(100'000)->Arg(1'000'000)->Unit(benchmark::kMicrosecond);
BENCHMARK(bm_first_hit_any_direction)->Arg(100'000)->Arg(1'000'000)->Unit(benchmark::kMicrosecond);
BENCHMARK(bm_closest_to_segment)->Arg(1'000'000)->Unit(benchmark::kMicrosecond);
BENCHMARK(bm_first_hit_brute_force)->Arg(100'000)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
