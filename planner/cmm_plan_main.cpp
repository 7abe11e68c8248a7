// cmm-plan: offline planning from a mesh, no machine. Reads the model, extracts reference edge points
// and holes, registers S to M, plans windows, touches and the ordered move program, writes the plan
// JSON (and DMIS) and prints a summary an operator can read at a glance.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "geometry/atomic_file.hpp"
#include "geometry/feature_model.hpp"
#include "geometry/file_error.hpp"
#include "geometry/mesh_io.hpp"
#include "hal/description/json_fields.hpp"
#include "hal/description/machine_description.hpp"
#include "hal/description/plate.hpp"
#include "planner/dmis_export.hpp"
#include "planner/measurement_plan.hpp"
#include "planner/plan_json.hpp"
#include "planner/reference_model.hpp"
#include "planner/registration.hpp"

namespace {

using namespace cmm;

// Wall time of each stage, for the summary's last line.
struct StageTimes {
  using Clock = std::chrono::steady_clock;
  Clock::time_point last = Clock::now();
  std::vector<std::pair<const char*, double>> stages;
  void done(const char* stage) {
    const Clock::time_point now = Clock::now();
    stages.emplace_back(stage, std::chrono::duration<double>(now - last).count());
    last = now;
  }
};

struct Options {
  std::string model, output, machine, plate, registration, dmis, emit_mesh;
  geometry::ScanOptions scan;
  double bin_size = 0;
  planner::PlanInputs inputs;
  bool radius_given = false;
};

std::string format_mm(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

// The ball the plan is for: the active tip's qualified radius unless --probe-radius says otherwise.
// Another tip of that radius becomes the active one; a radius no tip has is planned for a copy of
// the active tip, with a note, so that the plan, the DMIS and the machine description agree.
void choose_tip(description::MachineDescription& machine, Options& o) {
  if (!o.radius_given) {
    o.inputs.probe_radius = machine.tip().ball_radius_mm;
    return;
  }
  const double r = o.inputs.probe_radius;
  for (const description::StylusTip& tip : machine.tips)
    if (std::abs(tip.ball_radius_mm - r) <= 1e-9) {
      if (tip.id != machine.active_tip)
        o.inputs.notes.push_back("tip " + tip.id + " made active: it is the one of radius " + format_mm(r) + " mm");
      machine.active_tip = tip.id;
      return;
    }
  description::StylusTip tip = machine.tip();
  o.inputs.notes.push_back("no tip of the machine has radius " + format_mm(r) + " mm: planned for tip " + tip.id +
                           " with its ball changed to that radius; qualify such a tip before running the plan");
  tip.id += "_r" + format_mm(r);
  tip.ball_radius_mm = r;
  if (const std::string why = description::tip_problem(tip); !why.empty())
    throw std::invalid_argument("--probe-radius " + format_mm(r) + ": no tip has that radius, and tip " +
                                machine.tip().id + " with its ball changed to it is unusable (" + why + ")");
  machine.tips.push_back(tip);
  machine.active_tip = tip.id;
}

// An output that could not be written: exit 1, not a bad input.
struct WriteError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

void write_output(const std::string& path, const std::string& text) {
  try {
    geometry::write_atomically(path, text);
  } catch (const geometry::FileError& e) {
    throw WriteError(std::string("cannot write ") + e.what());
  }
}

void print_summary(const Options& o, const StageTimes& times, const geometry::FeatureModel& model, const geometry::ReadReport& read,
                   const planner::MeasurementPlan& plan, const description::MachineDescription& machine,
                   const std::optional<planner::RegistrationResult>& registration) {
  const auto& t = model.topology;
  const auto& in = o.inputs;
  std::size_t sharp = 0, rim = 0, boundary = 0, convex = 0;
  for (const auto& p : model.points) {
    (p.kind == geometry::EdgeKind::sharp_edge ? sharp : p.kind == geometry::EdgeKind::hole_rim ? rim : boundary)++;
    convex += p.convex && p.kind != geometry::EdgeKind::boundary;
  }
  std::printf("model      %s: %zu vertices, %zu triangles (scale %g)\n", o.model.c_str(), in.vertex_count,
              in.face_count, in.scale);
  if (in.scan) {
    const geometry::ScanReport& s = *in.scan;
    std::printf("scan       %zu points in, %zu outliers removed, noise sigma %.4f mm (from the local fits' residuals)\n",
                s.points_in, s.outliers_removed, s.noise_sigma_mm);
    std::printf("thin       bin %.4f mm: %s; %zu points kept%s\n", s.bin_size_mm, s.bin_size_source.c_str(), s.points_kept,
                in.scan_options && in.scan_options->adaptive ? " (adaptive bins)" : "");
    if (s.points_sparse > 0)
      std::printf("sparse     %zu kept points where the scan is sparser than the bin needs: their edges follow its spacing, "
                  "and the tolerance is not held there\n", s.points_sparse);
    std::printf("mesh       %zu triangles, %zu component(s), %zu outer and %zu hole loop(s), %zu crease(s) joined with %zu "
                "points on them%s%s\n",
                s.triangles, s.components, s.outer_loops, s.hole_loops, s.creases, s.crease_points,
                o.emit_mesh.empty() ? "" : ", written to ", o.emit_mesh.c_str());
    std::printf("scan time ");
    for (const geometry::ScanStageTime& t : s.times) std::printf(" %s %.3f s", t.stage.c_str(), t.seconds);
    std::printf("\n");
  }
  std::printf("read       %zu vertices welded, %zu degenerate and %zu duplicate faces dropped\n", read.vertices_welded,
              read.degenerate_faces_dropped, read.duplicate_faces_dropped);
  std::printf("topology   %d component(s), %s, %zu boundary edges in %zu loops, %zu non-manifold edges%s\n",
              t.components, t.closed() ? "closed" : "open", t.boundary_edges, model.loops.size(), t.non_manifold_edges,
              t.inconsistently_oriented_edges ? ", ORIENTATION INCONSISTENT" : "");
  double deviation = 0;
  for (const auto& p : model.points) deviation = std::max(deviation, p.mesh_deviation_mm);
  std::printf("surface    vertex noise sigma %.4f mm on %d of %d vertices -> %s; crease chords up to %.4f mm off the edge\n",
              model.features.noise.sigma_mm, model.features.noise.measured, model.features.noise.sampled,
              model.features.noisy ? "noisy: normals filtered, sides fitted over the neighbourhood" : "clean: sides from the facets at the edge",
              deviation);
  std::printf("features   %zu sharp curves over %g deg\n", model.features.curves.size(), in.feature_angle_deg);
  std::printf("points     %zu reference edge points every %g: %zu sharp edge, %zu hole rim, %zu open boundary; %zu convex\n",
              model.points.size(), in.spacing, sharp, rim, boundary, convex);
  std::size_t bores = 0;
  for (const auto& h : model.holes) bores += h.source == geometry::HoleSource::bore;
  std::printf("holes      %zu hole(s): %zu bore(s) with their wall, %zu open rim(s) whose wall the mesh lacks\n",
              model.holes.size(), bores, model.holes.size() - bores);
  for (const auto& h : model.holes) {
    char depth[32] = "n/a (no wall)";
    if (h.depth) std::snprintf(depth, sizeof depth, "%.3f", *h.depth);
    std::printf("hole %-3d   %-13s centre (%.3f, %.3f, %.3f)  diameter %.3f  depth %s  roundness %.4f\n", h.id,
                geometry::to_string(h.source), h.centre.x(), h.centre.y(), h.centre.z(), 2 * h.radius, depth,
                h.roundness_mm);
  }
  if (registration)
    std::printf("register   %zu corners, RMS %.4f mm%s\n", registration->ids.size(), registration->fit.rms_mm,
                registration->order_verified ? ", corner order confirmed by the fiducial" : "");
  else
    std::printf("register   none given: T_M_S = identity, the plan's machine coordinates are the scan's\n");
  std::map<std::string, int> methods;
  for (const auto& e : plan.edges) methods[planner::to_string(e.method)]++;
  int bored = 0;
  for (const auto& b : plan.bores) bored += b.planned;
  std::printf("probe      tip %s, r %g mm, delta %g mm: %d by two touches, %d by face touches, %d not probeable; "
              "%d of %zu bores\n",
              machine.active_tip.c_str(), in.probe_radius, in.delta, methods["two_touch"], methods["faces"],
              methods["none"], bored, plan.bores.size());
  // What is not probeable and why, most frequent first: the operator's list of what to fix in the mesh.
  std::map<std::string, int> reasons;
  for (const auto& e : plan.edges)
    if (e.method == planner::EdgeMethod::none) ++reasons[e.reason.substr(0, e.reason.find(" (")).substr(0, 120)];
  std::vector<std::pair<int, std::string>> by_count;
  for (const auto& [reason, count] : reasons) by_count.emplace_back(count, reason);
  std::sort(by_count.rbegin(), by_count.rend());
  std::printf("probeable  %zu of %zu edge points (%.1f %%)\n", plan.edges.size() - static_cast<std::size_t>(methods["none"]),
              plan.edges.size(), plan.edges.empty() ? 0.0 : 100.0 * (1.0 - static_cast<double>(methods["none"]) / static_cast<double>(plan.edges.size())));
  for (std::size_t i = 0; i < std::min<std::size_t>(by_count.size(), 5); ++i)
    std::printf("  not      %5d x %s\n", by_count[i].first, by_count[i].second.c_str());
  std::printf("program    %zu touches, clearance plane z %.3f: estimated %.1f s (lower bound %.1f s)\n",
              plan.program.touches.size(), plan.clearance_z, plan.program.time_s, plan.program.lower_bound_s);
  std::printf("plan       written to %s%s\n", o.output.c_str(), o.dmis.empty() ? "" : (", DMIS to " + o.dmis).c_str());
  std::printf("time      ");
  for (const auto& [stage, seconds] : times.stages) std::printf(" %s %.3f s", stage, seconds);
  std::printf("\n");
}

int plan(Options o) {
  planner::PlanInputs& inputs = o.inputs;
  StageTimes times;
  description::MachineDescription machine =
      o.machine.empty() ? description::default_machine() : description::read_machine(o.machine);
  if (o.machine.empty()) inputs.notes.push_back("no --machine given: the default machine description (config/machine.json)");
  choose_tip(machine, o);
  planner::ReferenceModelOptions model_options;
  model_options.scale = inputs.scale;
  model_options.spacing = inputs.spacing;
  model_options.feature_angle_deg = inputs.feature_angle_deg;
  model_options.scan = o.scan;
  planner::ReferenceModel reference = planner::load_reference_model(o.model, machine.travel_box, model_options);
  reference.inputs.probe_radius = inputs.probe_radius;
  planner::settle_delta(reference.inputs, inputs.delta, inputs.delta_source, reference.features);
  reference.inputs.notes = inputs.notes;
  inputs = reference.inputs;
  const geometry::TriangleMesh& mesh = reference.mesh;
  const geometry::FeatureModel& model = reference.features;
  times.done("model");
  if (!o.emit_mesh.empty()) {
    try {
      geometry::write_mesh(o.emit_mesh, mesh);
    } catch (const geometry::FileError& e) {
      throw WriteError(std::string("cannot write ") + e.what());
    }
  }

  std::optional<planner::RegistrationResult> registration;
  Eigen::Isometry3d T_M_S = Eigen::Isometry3d::Identity();
  if (!o.registration.empty()) {
    const planner::RegistrationInput corners = planner::read_registration(o.registration);
    std::optional<description::Plate> plate;
    if (!o.plate.empty()) plate = description::read_plate(o.plate);
    registration = planner::fit_registration(corners, plate ? &*plate : nullptr);
    T_M_S = registration->T_M_S;
  } else {
    inputs.notes.push_back("no registration given: T_M_S is taken as identity (machine coordinates = scan coordinates)");
  }

  times.done("registration");

  planner::MeasurementPlanOptions plan_options;
  plan_options.touch.radius = inputs.probe_radius;
  plan_options.touch.delta = inputs.delta;
  const planner::MeasurementPlan plan = planner::plan_measurement(model, mesh, T_M_S, machine, plan_options);
  times.done("plan");

  // Both texts first, so that a program the DMIS export refuses leaves no plan behind either.
  const nlohmann::json registration_json = registration ? planner::to_json(*registration) : nlohmann::json(nullptr);
  const std::string plan_text = planner::plan_json(model, inputs, &plan, &machine, registration_json).dump(1) + "\n";
  std::ostringstream dmis;
  if (!o.dmis.empty())
    planner::write_dmis(dmis, plan.program, machine, planner::dmis_features(plan.program, model.holes),
                        {"cmm-plan", std::filesystem::path(o.model).stem().string()});
  write_output(o.output, plan_text);
  if (!o.dmis.empty()) write_output(o.dmis, dmis.str());
  times.done("write");
  print_summary(o, times, model, inputs.read_report, plan, machine, registration);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"cmm-plan: plan the CMM re-measurement of a scanned part's edges and holes (no machine)"};
  Options o;
  planner::PlanInputs& inputs = o.inputs;
  app.add_option("MODEL", o.model,
                 "reference mesh (STL, PLY, OBJ, OFF) or raw scan (points only: PLY, XYZ/ASC, PCD), thinned and "
                 "triangulated first")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("-o,--output", o.output, "plan JSON to write")->required();
  app.add_option("--scale", inputs.scale, "multiply coordinates by this (unitless models to mm)")
      ->check(CLI::PositiveNumber);
  app.add_option("--spacing", inputs.spacing, "distance between reference edge points, mm")
      ->check(CLI::PositiveNumber);
  app.add_option("--feature-angle", inputs.feature_angle_deg, "dihedral angle above which an edge is sharp, degrees")
      ->check(CLI::Range(1.0, 179.0));
  app.add_option("--probe-radius", inputs.probe_radius,
                 "stylus ball radius r, mm (default: the machine's active tip's qualified radius)")
      ->check(CLI::PositiveNumber);
  app.add_option("--delta", inputs.delta, "bound on the reference points' error in M, mm")->check(CLI::PositiveNumber);
  app.add_option("--machine", o.machine, "machine description (default: config/machine.json, built in)")
      ->check(CLI::ExistingFile);
  app.add_option("--registration", o.registration, "base-plate corners in S and M (docs/registration.md)")
      ->check(CLI::ExistingFile);
  app.add_option("--plate", o.plate, "plate description; overrides the one named in the registration file")
      ->check(CLI::ExistingFile);
  app.add_option("--dmis", o.dmis, "also write the move program as DMIS (docs/dmis.md)");
  auto* tolerance = app.add_option("--tolerance", o.scan.tolerance_mm,
                                   "raw scan: the mesh's largest distance from the scanned surface (epsilon), mm")
                        ->check(CLI::PositiveNumber);
  app.add_option("--bin-size", o.bin_size, "raw scan: thinning bin size, mm, instead of the one the tolerance gives")
      ->check(CLI::PositiveNumber)
      ->excludes(tolerance);
  app.add_flag("--adaptive", o.scan.adaptive, "raw scan: bins follow the curvature (fewer points at the same tolerance)");
  app.add_option("--emit-mesh", o.emit_mesh, "also write the mesh the plan was made on (STL, PLY, OBJ, OFF)");
  CLI11_PARSE(app, argc, argv);
  if (o.bin_size > 0) o.scan.bin_size_mm = o.bin_size;
  if (!o.plate.empty() && o.registration.empty()) {
    std::cerr << "cmm-plan: --plate checks a corner fit and needs --registration corners.json\n";
    return 2;
  }
  o.radius_given = app.count("--probe-radius") > 0;
  inputs.delta_source = app.count("--delta") ? "given with --delta" : "default: laser scanner noise bound (thesis Ch. 5)";
  try {
    return plan(o);
  } catch (const geometry::FileError& error) {
    std::cerr << "cmm-plan: " << error.what() << '\n';
    return 2;
  } catch (const description::FieldError& error) {
    std::cerr << "cmm-plan: " << error.what() << '\n';
    return 2;
  } catch (const planner::RegistrationError& error) {
    std::cerr << "cmm-plan: " << o.registration << ": registration refused: " << error.what() << '\n';
    return 2;
  } catch (const std::invalid_argument& error) {  // an input the planner cannot use, named by the message
    std::cerr << "cmm-plan: " << error.what() << '\n';
    return 2;
  } catch (const planner::ModelError& error) {
    std::cerr << "cmm-plan: " << error.what() << '\n';
    return 2;
  } catch (const WriteError& error) {
    std::cerr << "cmm-plan: " << error.what() << '\n';
    return 1;
  } catch (const std::exception& error) {  // out of memory and the like: say so, no core dump
    std::cerr << "cmm-plan: while planning " << o.model << ": " << error.what() << '\n';
    return 1;
  }
}
