// cmm-scan: what a laser scanner would have given for one of the analytic test parts: the scanned
// reference mesh (--mesh) and/or the raw multi-view cloud (--cloud), with their truth summary (--truth).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "geometry/analytic_parts.hpp"
#include "geometry/mesh_io.hpp"
#include "hal/description/eigen_json.hpp"
#include "sim/raw_scan.hpp"
#include "sim/scan_borders.hpp"
#include "sim/sim_config.hpp"
#include "sim/scanned_mesh.hpp"

namespace {

using namespace cmm;

struct Options {
  std::string part, mesh, cloud, truth, sim_config, plate_corners, nominal;
  double nominal_chord_mm = 0.001;
  double corner_noise = 0.01, rough_error = 1;
  double edge_length = 1, noise = 0.05, spacing = 0.5, stray_fraction = 0.002;
  double max_incidence_deg = sim::kDefaultMaxIncidenceDeg;
  sim::ViewSetOptions views;
  int view_count = 7;            // around + 1 from above
  double view_offset = -1;       // mm; < 0: registration errors drawn as ViewSetOptions says
  std::string sampling = "random", noise_model = "beam";
  double view_coverage = 1;
  std::vector<double> view_density;
  std::uint64_t seed = 1;
};

sim::ScanSampling sampling_named(const std::string& name) {
  for (sim::ScanSampling s : {sim::ScanSampling::random, sim::ScanSampling::grid, sim::ScanSampling::poisson})
    if (name == sim::to_string(s)) return s;
  throw std::invalid_argument("--sampling " + name + ": not random, grid or poisson");
}

sim::ScanNoise noise_named(const std::string& name) {
  for (sim::ScanNoise n : {sim::ScanNoise::beam, sim::ScanNoise::isotropic})
    if (name == sim::to_string(n)) return n;
  throw std::invalid_argument("--noise-model " + name + ": not beam or isotropic");
}

// The views the flags ask for: --views N spread as the defaults are, each off by --view-offset exactly
// when given, else by the seeded default registration errors.
std::vector<sim::ScanView> scan_views(const Options& o) {
  if (o.view_offset >= 0) return sim::views_with_offset(o.view_count, o.view_offset, o.seed, o.views.elevation_deg);
  sim::ViewSetOptions view_options = o.views;
  view_options.around = o.view_count - 1;
  view_options.from_above = true;
  view_options.seed = o.seed;
  return sim::default_views(view_options);
}


// What registration by a measured plate starts from: the plate's corners as the scan shows them
// (S is the part's own frame, the frame of the scanned mesh) and where an operator would jog the
// probe to each corner on the machine (M, a millimetre or so off), from the simulator's truth.
nlohmann::json plate_corners(const sim::SimConfig& config, const Options& o) {
  std::mt19937_64 random(o.seed + 7919);
  std::normal_distribution<double> scan_noise(0, o.corner_noise);
  std::uniform_real_distribution<double> rough(-o.rough_error, o.rough_error);
  const Eigen::Isometry3d T_S_P = config.T_P_Part.inverse();
  nlohmann::json scan = nlohmann::json::array(), machine = nlohmann::json::array();
  for (int id = 1; id <= config.plate.corner_count(); ++id) {
    const geometry::Vec3 c = config.plate.corner(id);
    const geometry::Vec3 s = T_S_P * c + geometry::Vec3(scan_noise(random), scan_noise(random), scan_noise(random));
    const geometry::Vec3 m = config.T_M_P * c + geometry::Vec3(rough(random), rough(random), 0.3 * rough(random));
    scan.push_back({{"id", id}, {"scan", description::vec3_json(s)}});
    machine.push_back({{"id", id}, {"machine", description::vec3_json(m)}});
  }
  return {{"scan_corners", scan}, {"rough_machine", machine}};
}

int scan(Options o) {
  if (!o.sim_config.empty()) {
    std::ifstream in(o.sim_config);
    if (!in) throw std::runtime_error("cannot open " + o.sim_config);
    const sim::SimConfig config = sim::sim_config_from_json(
        nlohmann::json::parse(in), std::filesystem::path(o.sim_config).parent_path().string());
    if (!config.part.mesh_file.empty()) throw std::invalid_argument(o.sim_config + ": its part is a mesh file, not an analytic part");
    if (o.part.empty()) o.part = config.part.analytic;
    if (o.part != config.part.analytic)
      throw std::invalid_argument("--part " + o.part + " is not the simulator's part (" + config.part.analytic + ")");
    if (!o.plate_corners.empty()) {
      std::ofstream out(o.plate_corners);
      out << plate_corners(config, o).dump(1) << '\n';
      if (!out.flush()) throw std::runtime_error("cannot write " + o.plate_corners);
      std::cout << o.plate_corners << ": the plate's " << config.plate.corner_count()
                << " corners as scanned (S) and roughly jogged to (M)\n";
    }
  }
  if (o.part.empty()) throw std::invalid_argument("give --part or --sim-config");
  if (!o.view_density.empty() && static_cast<int>(o.view_density.size()) != o.view_count)
    throw std::invalid_argument("--view-density: " + std::to_string(o.view_density.size()) + " factors for " +
                                std::to_string(o.view_count) + " views (--views)");
  const sim::ScanSampling sampling = sampling_named(o.sampling);
  const sim::ScanNoise noise_model = noise_named(o.noise_model);
  const geometry::AnalyticPart part = geometry::make_analytic_part(o.part, o.edge_length);
  const std::vector<sim::ScanView> views = scan_views(o);

  nlohmann::json truth = {
      {"part", o.part},
      {"seed", o.seed},
      {"options",
       {{"edge_length_mm", o.edge_length},
        {"noise_sigma_mm", o.noise},
        {"spacing_mm", o.spacing},
        {"stray_fraction", o.stray_fraction},
        {"max_incidence_deg", o.max_incidence_deg},
        {"sampling", o.sampling},
        {"noise_model", o.noise_model},
        {"view_coverage", o.view_coverage},
        {"view_density", o.view_density},
        {"views",
         {{"count", o.view_count},
          {"around", o.view_count - 1},
          {"elevation_deg", o.views.elevation_deg},
          {"from_above", true},
          {"view_offset_mm", o.view_offset >= 0 ? nlohmann::json(o.view_offset) : nlohmann::json(nullptr)},
          {"rotation_sigma_deg", o.view_offset >= 0 ? 0.0 : o.views.rotation_sigma_deg},
          {"translation_sigma_mm", o.view_offset >= 0 ? 0.0 : o.views.translation_sigma_mm}}}}},
      {"true_faces", part.mesh.faces.rows()},
      {"view_directions", nlohmann::json::array()}};
  for (const sim::ScanView& view : views) truth["view_directions"].push_back(description::vec3_json(view.direction));

  if (!o.nominal.empty()) {
    // The part as its CAD system would export it, in S: what an inspection holds the measurements against.
    const geometry::AnalyticPart cad =
        geometry::make_analytic_part(o.part, geometry::Tessellation{geometry::Tessellation::Style::cad, 1.0, o.nominal_chord_mm});
    geometry::write_mesh(o.nominal, cad.mesh);
    truth["nominal"] = {{"file", o.nominal}, {"faces", cad.mesh.faces.rows()}, {"chord_tolerance_mm", o.nominal_chord_mm}};
    std::cout << o.nominal << ": nominal " << o.part << " as a CAD export, " << cad.mesh.faces.rows()
              << " triangles (chords within " << o.nominal_chord_mm << " mm)\n";
  }
  if (!o.mesh.empty()) {
    const sim::ScannedMesh scanned = sim::synthesize_scanned_mesh(
        part.mesh, {.noise_sigma_mm = o.noise, .views = views, .max_incidence_deg = o.max_incidence_deg, .seed = o.seed});
    geometry::write_mesh(o.mesh, scanned.mesh);
    truth["mesh"] = {{"file", o.mesh},
                     {"vertices", scanned.mesh.vertices.rows()},
                     {"faces", scanned.mesh.faces.rows()},
                     {"removed_faces", scanned.removed_faces.size()}};
    std::cout << o.mesh << ": scanned " << o.part << ", " << scanned.mesh.faces.rows() << " triangles, "
              << scanned.removed_faces.size() << " of " << part.mesh.faces.rows() << " removed as unseen\n";
  }
  if (!o.cloud.empty()) {
    const sim::RawScan raw = sim::synthesize_raw_scan(part.mesh, {.spacing_mm = o.spacing,
                                                                   .noise_sigma_mm = o.noise,
                                                                   .views = views,
                                                                   .max_incidence_deg = o.max_incidence_deg,
                                                                   .stray_fraction = o.stray_fraction,
                                                                   .seed = o.seed,
                                                                   .sampling = sampling,
                                                                   .noise_model = noise_model,
                                                                   .view_coverage = o.view_coverage,
                                                                   .view_density = o.view_density});
    geometry::write_cloud(o.cloud, raw.cloud);
    const auto strays = std::count(raw.truth.stray.begin(), raw.truth.stray.end(), true);
    truth["cloud"] = {{"file", o.cloud}, {"points", raw.cloud.points.rows()}, {"strays", strays}, {"borders", nlohmann::json::array()}};
    if (o.view_coverage < 1) {
      // Each view kept the points p with direction · p ≤ limit_mm.
      truth["cloud"]["coverage"] = nlohmann::json::array();
      for (const sim::CoverageBand& band : raw.truth.coverage)
        truth["cloud"]["coverage"].push_back({{"direction", description::vec3_json(band.direction)}, {"limit_mm", band.limit_mm}});
    }
    // What a mesh of the scan should keep open: the borders of the seen region (within the views' bands), no others.
    for (const sim::ScanBorder& border : sim::scan_borders(part.mesh, views, o.max_incidence_deg, raw.truth.coverage))
      truth["cloud"]["borders"].push_back({{"centre", description::vec3_json(border.centre)},
                                           {"perimeter_mm", border.perimeter_mm},
                                           {"kind", border.kind == geometry::LoopKind::hole ? "hole" : "outer"}});
    std::cout << o.cloud << ": raw scan of " << o.part << " (" << o.sampling << " sampling, " << o.noise_model
              << " noise), " << raw.cloud.points.rows() << " points from " << views.size() << " views, " << strays
              << " strays\n";
  }
  if (!o.truth.empty()) {
    std::ofstream out(o.truth);
    out << truth.dump(2) << '\n';
    if (!out.flush()) throw std::runtime_error("cannot write " + o.truth);
  }
  return 0;
}

// A flag's value checked as a number with `ok`; CLI11 puts the flag's name before the message.
CLI::Validator number_in(const std::string& range, bool (*ok)(double)) {
  return CLI::Validator(
      [range, ok](std::string& text) {
        char* end = nullptr;
        const double value = std::strtod(text.c_str(), &end);
        const bool number = !text.empty() && end == text.c_str() + text.size();
        return number && ok(value) ? std::string() : text + " is not a number " + range;
      },
      "NUMBER " + range);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"cmm-scan: synthesize the scan of an analytic test part (scanned reference mesh, raw cloud)"};
  Options o;
  const std::vector<std::string>& names = geometry::analytic_part_names();
  app.add_option("--part", o.part, "the true part (default: the simulator's, with --sim-config)")
      ->check(CLI::IsMember(names));
  app.add_option("--sim-config", o.sim_config, "cmm-sim config: the part, and the plate and poses --plate-corners uses")
      ->check(CLI::ExistingFile);
  app.add_option("--plate-corners", o.plate_corners,
                 "write {scan_corners, rough_machine} for a job's measure_plate registration (needs --sim-config)")
      ->needs("--sim-config");
  app.add_option("--corner-noise", o.corner_noise, "sigma of the scanned plate corners, mm")->check(CLI::NonNegativeNumber);
  app.add_option("--rough-error", o.rough_error, "largest error of the jogged machine corners, mm")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--edge-length", o.edge_length, "edge length of the true part's mesh, mm")->check(CLI::PositiveNumber);
  app.add_option("--noise", o.noise, "Gaussian noise sigma: per vertex coordinate (mesh), as --noise-model says (cloud), mm")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--spacing", o.spacing, "raw scan sample spacing, mm")->check(CLI::PositiveNumber);
  app.add_option("--sampling", o.sampling,
                 "raw scan sampling: random (area-uniform per view), grid (each view's raster), poisson (merged, "
                 "Poisson-disk)")
      ->check(CLI::IsMember({"random", "grid", "poisson"}));
  app.add_option("--noise-model", o.noise_model, "raw scan noise: beam (along the view) or isotropic (per coordinate)")
      ->check(CLI::IsMember({"beam", "isotropic"}));
  app.add_option("--views", o.view_count, "scanner views: N - 1 around at 50 degrees elevation and one from above")
      ->check(CLI::Range(1, 360));
  app.add_option("--view-offset", o.view_offset,
                 "each view's registration error: a translation of exactly this many mm, seeded direction, no rotation")
      ->check(number_in(">= 0", [](double f) { return f >= 0 && std::isfinite(f); }));
  app.add_option("--view-coverage", o.view_coverage, "share of what it sees each view keeps, one band across it, in (0, 1]")
      ->check(number_in("in (0, 1]", [](double f) { return f > 0 && f <= 1; }));
  app.add_option("--view-density", o.view_density, "per-view factors on the raw scan density, one per view: a,b,c")
      ->delimiter(',')
      ->check(number_in("> 0", [](double f) { return f > 0 && std::isfinite(f); }));
  app.add_option("--stray-fraction", o.stray_fraction, "share of raw scan points that are strays")
      ->check(CLI::Range(0.0, 0.999));
  app.add_option("--max-incidence", o.max_incidence_deg, "steepest incidence a view still sees, degrees")
      ->check(CLI::Range(1.0, 89.0));
  app.add_option("--seed", o.seed, "seed of the noise, strays and view registration errors");
  app.add_option("--mesh", o.mesh, "scanned reference mesh to write (STL, PLY, OBJ, OFF)");
  app.add_option("--cloud", o.cloud, "raw scan cloud to write (PLY, XYZ)");
  app.add_option("--truth", o.truth, "JSON summary of the truth: options, seed, removed faces");
  app.add_option("--nominal", o.nominal, "the true part as a CAD export (few large triangles) in S, for inspection");
  app.add_option("--nominal-chord", o.nominal_chord_mm, "the nominal's largest chord error on curved faces, mm")
      ->check(CLI::PositiveNumber);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    const int code = app.exit(error);  // prints help, or the error and a hint
    return code == 0 ? 0 : 2;
  }
  if (o.mesh.empty() && o.cloud.empty() && o.plate_corners.empty() && o.nominal.empty()) {
    std::cerr << "cmm-scan: nothing to write: give --mesh out.ply, --cloud out.ply, --nominal out.stl and/or --plate-corners out.json\n";
    return 2;
  }
  try {
    return scan(o);
  } catch (const std::invalid_argument& error) {
    std::cerr << "cmm-scan: " << error.what() << '\n';
    return 2;
  } catch (const std::exception& error) {  // an unwritable file and the like
    std::cerr << "cmm-scan: " << error.what() << '\n';
    return 1;
  }
}
