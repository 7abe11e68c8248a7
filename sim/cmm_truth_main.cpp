// cmm-truth: holds a job's result against the simulator's truth — each measured edge point (M)
// against the true part's sharp edges, each measured bore against the true hole — for demos and tests.
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <vector>

#include "geometry/analytic_parts.hpp"
#include "geometry/true_edge_distance.hpp"
#include "hal/description/eigen_json.hpp"
#include "sim/sim_config.hpp"

namespace {

using namespace cmm;
using nlohmann::json;

json read_json(const std::string& file) {
  std::ifstream in(file);
  if (!in) throw std::runtime_error("cannot open " + file);
  return json::parse(in);
}


struct Stats {
  std::vector<double> values;
  double rms() const {
    double s = 0;
    for (double v : values) s += v * v;
    return values.empty() ? 0 : std::sqrt(s / static_cast<double>(values.size()));
  }
  double max() const {
    double m = 0;
    for (double v : values) m = std::max(m, std::abs(v));
    return m;
  }
};

int compare(const std::string& config_file, const std::string& result_file, double tolerance, const std::string& out) {
  const sim::SimConfig config =
      sim::sim_config_from_json(read_json(config_file), std::filesystem::path(config_file).parent_path().string());
  if (!config.part.mesh_file.empty()) throw std::invalid_argument(config_file + ": a mesh part has no analytic truth");
  const geometry::AnalyticPart part = geometry::make_analytic_part(config.part.analytic, config.part.edge_length_mm);
  const Eigen::Isometry3d T_Part_M = (config.T_M_P * config.T_P_Part).inverse();
  const json result = read_json(result_file);

  Stats edges;
  int over = 0, worst_id = -1;
  double worst = -1;
  for (const json& e : result.at("edge_points")) {
    if (e.value("status", "") != "measured" || !e["measured_M"].is_object()) continue;
    const double d = geometry::nearest_true_edge(part, T_Part_M * description::vec3_from_json(e["measured_M"]["position"])).distance;
    edges.values.push_back(d);
    over += d > tolerance;
    if (d > worst) {
      worst = d;
      worst_id = e["id"].get<int>();
    }
  }
  Stats centres, diameters;
  for (const json& h : result.at("holes")) {
    if (h.value("status", "") != "measured" || !h["measured_M"].is_object()) continue;
    const geometry::Vec3 c = T_Part_M * description::vec3_from_json(h["measured_M"]["centre"]);
    const geometry::TrueHole* best = nullptr;
    double best_d = 1e300;
    for (const geometry::TrueHole& t : part.holes) {
      const geometry::Vec3 v = c - t.centre;
      const double d = (v - v.dot(t.axis) * t.axis).norm();
      if (d < best_d) {
        best_d = d;
        best = &t;
      }
    }
    if (best == nullptr) continue;
    centres.values.push_back(best_d);
    diameters.values.push_back(h["diameter_mm"].get<double>() - 2 * best->radius);
  }
  std::printf("truth       %s (%s), pose from %s\n", part.name.c_str(), "analytic", config_file.c_str());
  std::printf("edges       %zu measured points vs the true edges: RMS %.4f mm, max %.4f mm (point %d); %d over %.3f mm\n",
              edges.values.size(), edges.rms(), edges.max(), worst_id, over, tolerance);
  std::printf("holes       %zu measured bores vs the true holes: centre off the axis max %.4f mm, diameter error "
              "RMS %.4f mm, max %.4f mm\n",
              centres.values.size(), centres.max(), diameters.rms(), diameters.max());
  if (!out.empty()) {
    std::ofstream file(out);
    file << json{{"edges", {{"count", edges.values.size()}, {"rms_mm", edges.rms()}, {"max_mm", edges.max()},
                            {"worst_id", worst_id}, {"over_tolerance", over}, {"tolerance_mm", tolerance}}},
                 {"holes", {{"count", centres.values.size()}, {"max_centre_mm", centres.max()},
                            {"diameter_rms_mm", diameters.rms()}, {"diameter_max_mm", diameters.max()}}}}
                .dump(1)
         << "\n";
  }
  return over == 0 ? 0 : 3;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"cmm-truth: compare a job's result.json with the simulator's true part"};
  std::string config, result, out;
  double tolerance = 0.01;
  app.add_option("--config", config, "the cmm-sim config the job ran against")->required()->check(CLI::ExistingFile);
  app.add_option("RESULT", result, "result.json (cmmctl result ID)")->required()->check(CLI::ExistingFile);
  app.add_option("--tolerance", tolerance, "edge distance counted as out of tolerance, mm");
  app.add_option("--json", out, "also write the figures as JSON");
  CLI11_PARSE(app, argc, argv);
  try {
    return compare(config, result, tolerance, out);
  } catch (const std::exception& e) {
    std::cerr << "cmm-truth: " << e.what() << "\n";
    return 2;
  }
}
