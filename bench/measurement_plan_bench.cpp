// Offline planning against reading the model, and the ordered program against its lower bound: the
// case-3 block as binary STL, read, its features extracted at a spacing, and every point planned.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <map>
#include <string>

#include "geometry/analytic_parts.hpp"
#include "geometry/feature_model.hpp"
#include "geometry/mesh_io.hpp"
#include "hal/description/machine_description.hpp"
#include "planner/measurement_plan.hpp"

namespace {

using namespace cmm;

// Ranges are in µm so that they can be benchmark arguments: mesh edge length, point spacing.
constexpr double um = 1e-3;

// One STL per edge length, written once per process: the read benchmark reads what a user would.
const std::filesystem::path& block_stl(long edge_um) {
  static std::map<long, std::filesystem::path> files;
  auto [it, added] = files.try_emplace(edge_um);
  if (added) {
    it->second = std::filesystem::temp_directory_path() / ("cmmd_bench_block_" + std::to_string(edge_um) + ".stl");
    geometry::write_mesh(it->second, geometry::make_case3_block(edge_um * um).mesh);
  }
  return it->second;
}

geometry::TriangleMesh read_block(long edge_um) {
  return std::get<geometry::TriangleMesh>(geometry::read_model(block_stl(edge_um)).model);
}

geometry::FeatureModel features(const geometry::TriangleMesh& mesh, long spacing_um) {
  geometry::FeatureModelOptions options;
  options.spacing = spacing_um * um;
  return geometry::extract_features(mesh, options);
}

planner::MeasurementPlanOptions plan_options() {
  planner::MeasurementPlanOptions options;
  options.touch.radius = 2.5;  // the default machine's T2, whose shaft reaches the bores
  options.touch.delta = 0.2;
  return options;
}

description::MachineDescription machine() {
  description::MachineDescription m = description::default_machine();
  m.active_tip = "T2";
  return m;
}

void bm_read_model(benchmark::State& state) {
  block_stl(state.range(0));
  for (auto _ : state) benchmark::DoNotOptimize(read_block(state.range(0)).faces.data());
  state.counters["triangles"] = static_cast<double>(read_block(state.range(0)).faces.rows());
}

void bm_extract_features(benchmark::State& state) {
  const geometry::TriangleMesh mesh = read_block(state.range(0));
  std::size_t points = 0;
  for (auto _ : state) points = features(mesh, state.range(1)).points.size();
  state.counters["edge_points"] = static_cast<double>(points);
}

// Windows, approaches, every stylus clearance check against the mesh in M, ordering and the
// estimate: everything after the features, the plan JSON's writing aside.
void bm_plan_measurement(benchmark::State& state) {
  const geometry::TriangleMesh mesh = read_block(state.range(0));
  const geometry::FeatureModel model = features(mesh, state.range(1));
  const description::MachineDescription m = machine();
  planner::MeasurementPlan plan;
  for (auto _ : state)
    plan = planner::plan_measurement(model, mesh, Eigen::Isometry3d::Identity(), m, plan_options());
  std::size_t probeable = 0;
  for (const auto& e : plan.edges) probeable += e.method != planner::EdgeMethod::none;
  double travel = 0;
  for (const auto& motion : plan.program.motions) travel += motion.kind == planner::MotionKind::travel ? motion.time_s : 0;
  const double fixed = plan.program.time_s - travel, travel_bound = plan.program.lower_bound_s - fixed;
  state.counters["edge_points"] = static_cast<double>(model.points.size());
  state.counters["probeable"] = static_cast<double>(probeable);
  state.counters["touches"] = static_cast<double>(plan.program.touches.size());
  state.counters["estimate_s"] = plan.program.time_s;
  state.counters["estimate/bound"] = plan.program.time_s / plan.program.lower_bound_s;
  state.counters["travel/bound"] = travel / travel_bound;
}

// 0.28 mm and 0.14 mm meshes: 1M and 4M triangles. At 0.7 mm spacing the block has ~2,000 edge
// points; at 14 µm ~100,000 (its edges are 1.42 m long in all).
BENCHMARK(bm_read_model)->Arg(280)->Arg(140)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);
BENCHMARK(bm_extract_features)->Args({280, 700})->Args({280, 14})->Args({140, 14})
    ->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(2);
BENCHMARK(bm_plan_measurement)->Args({280, 700})->Args({280, 14})->Args({140, 14})
    ->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(2);

}  // namespace

BENCHMARK_MAIN();
