// Reading binary STL and extracting features at 100k, 1M and 4M triangles, on the case-3 block
// meshed finely enough (its features scale with it: 22 curves, 5 bores at every size).
#include <benchmark/benchmark.h>

#include <cmath>
#include <filesystem>
#include <map>

#include "geometry/analytic_parts.hpp"
#include "geometry/feature_model.hpp"
#include "geometry/mesh_io.hpp"

namespace {

using namespace cmm::geometry;
namespace fs = std::filesystem;

// The block has ≈ 78,000 triangles at 1 mm edges, and the count goes with 1/h².
double edge_length_for(long triangles) { return std::sqrt(78000.0 / static_cast<double>(triangles)); }

// One STL per size, written once into the temp folder and reused by later runs.
const fs::path& stl_file(long triangles) {
  static std::map<long, fs::path> files;
  auto [it, fresh] = files.try_emplace(triangles);
  if (fresh) {
    it->second = fs::temp_directory_path() / ("cmmd_bench_block_" + std::to_string(triangles) + ".stl");
    if (!fs::exists(it->second)) write_mesh(it->second, make_case3_block(edge_length_for(triangles)).mesh);
  }
  return it->second;
}

void bm_read_binary_stl(benchmark::State& state) {
  const fs::path& file = stl_file(state.range(0));
  long faces = 0, vertices = 0;
  for (auto _ : state) {
    const TriangleMesh mesh = read_mesh(file);
    faces = mesh.faces.rows();
    vertices = mesh.vertices.rows();
    benchmark::DoNotOptimize(mesh.vertices.data());
  }
  state.counters["triangles"] = static_cast<double>(faces);
  state.counters["vertices"] = static_cast<double>(vertices);
  state.counters["MB"] = static_cast<double>(fs::file_size(file)) / 1e6;
  state.SetItemsProcessed(state.iterations() * faces);
}

void bm_extract_features(benchmark::State& state) {
  const TriangleMesh mesh = read_mesh(stl_file(state.range(0)));
  std::size_t points = 0;
  for (auto _ : state) {
    const FeatureModel model = extract_features(mesh);
    points = model.points.size();
    benchmark::DoNotOptimize(model.points.data());
  }
  state.counters["triangles"] = static_cast<double>(mesh.faces.rows());
  state.counters["edge_points"] = static_cast<double>(points);
  state.SetItemsProcessed(state.iterations() * mesh.faces.rows());
}

BENCHMARK(bm_read_binary_stl)->Arg(100'000)->Arg(1'000'000)->Arg(4'000'000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(bm_extract_features)->Arg(100'000)->Arg(1'000'000)->Arg(4'000'000)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
