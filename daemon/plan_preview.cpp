// plan.preview: plan a request and dry-run its program on a simulator of the reference mesh.
#include "daemon/plan_preview.hpp"

#include <unistd.h>

#include <atomic>
#include <numbers>
#include <optional>

#include "daemon/job_planning.hpp"
#include "daemon/job_reference.hpp"
#include "daemon/model_units_check.hpp"
#include "daemon/registration_check.hpp"
#include "daemon/client/rpc_error.hpp"
#include "daemon/driver_factory.hpp"
#include "daemon/touch_motion.hpp"
#include "geometry/mesh_io.hpp"
#include "hal/description/eigen_json.hpp"
#include "hal/fault.hpp"
#include "planner/rigid_fit.hpp"

namespace cmm::daemon {

namespace {

nlohmann::json pose_json(const Eigen::Isometry3d& T) {
  // sim_config's poses rotate about x, then y, then z: R = Rz·Ry·Rx.
  const Eigen::Vector3d zyx = T.rotation().eulerAngles(2, 1, 0) * (180 / std::numbers::pi);
  const Eigen::Vector3d t = T.translation();
  return {{"rotation_deg", {zyx[2], zyx[1], zyx[0]}}, {"translation", description::vec3_json(t)}};
}

Eigen::Isometry3d preview_registration(const JobRequest& request, std::vector<std::string>& notes) {
  if (request.given) {
    std::vector<planner::Vec3> scan, machine;
    for (const planner::CornerPair& c : request.given->corners) {
      scan.push_back(c.scan);
      machine.push_back(c.machine);
    }
    return planner::fit_rigid(scan, machine).transform;
  }
  if (request.measure) {
    notes.push_back("registration previewed from the rough machine corners; the job measures the plate");
    return planner::fit_rigid(request.measure->scan, request.measure->rough_machine).transform;
  }
  notes.push_back("no registration given: T_M_S is taken as identity");
  return Eigen::Isometry3d::Identity();
}

// The simulator reads its part from a mesh file. A raw scan's part is the mesh the front end made of
// it, written to a private temporary file (cmmd's unit has PrivateTmp) for the dry run and removed after.
class MeshedScanFile {
 public:
  explicit MeshedScanFile(const geometry::TriangleMesh& mesh) {
    static std::atomic<unsigned> next{0};
    path_ = std::filesystem::temp_directory_path() /
            ("cmmd-preview-" + std::to_string(::getpid()) + "-" + std::to_string(next++) + ".ply");
    geometry::write_mesh(path_, mesh);
  }
  ~MeshedScanFile() {
    std::error_code ignored;
    std::filesystem::remove(path_, ignored);
  }
  MeshedScanFile(const MeshedScanFile&) = delete;
  MeshedScanFile& operator=(const MeshedScanFile&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

// The simulator's block: the reference mesh standing where T_M_S puts it, on a plate under it.
// `part_file` at `part_scale` is that mesh.
nlohmann::json sim_block(const std::filesystem::path& part_file, double part_scale, const JobRequest& request,
                         const description::MachineDescription& machine, const geometry::TriangleMesh& mesh,
                         const Eigen::Isometry3d& T_M_S) {
  const Eigen::Vector3d lo = mesh.vertices.colwise().minCoeff().transpose();
  const Eigen::Vector3d hi = mesh.vertices.colwise().maxCoeff().transpose();
  const description::Plate& plate = request.plate;
  Eigen::Vector3d plate_mid = Eigen::Vector3d::Zero();
  for (const planner::Vec3& c : plate.corners) plate_mid += c;
  plate_mid /= static_cast<double>(plate.corners.size());
  Eigen::Isometry3d T_S_P = Eigen::Isometry3d::Identity();
  T_S_P.translation() = Eigen::Vector3d(0.5 * (lo.x() + hi.x()), 0.5 * (lo.y() + hi.y()), lo.z()) -
                        Eigen::Vector3d(plate_mid.x(), plate_mid.y(), plate.top_z());
  return {{"machine", description::to_json(machine)},
          {"plate", description::to_json(plate)},
          {"plate_pose", pose_json(T_M_S * T_S_P)},
          {"part", {{"mesh", part_file.string()}, {"scale", part_scale}}},
          {"part_pose", pose_json(T_S_P.inverse())},
          {"trigger_sigma_mm", 0},
          {"home_position", description::vec3_json(machine.travel_box.max)}};
}

// Back to a machine that moves after a fault: enabled, abort cleared, homed.
void recover(hal::Cmm& cmm) {
  hal::MachineStatus s = cmm.status();
  if (s.lifecycle == hal::Lifecycle::connected) cmm.enable();
  if (s.aborted || s.estop) cmm.reset();
  if (!cmm.status().homed) cmm.home();
}

}  // namespace

nlohmann::json preview_plan(const nlohmann::json& params, const DaemonConfig& config, const ModelStore& models,
                            const description::MachineDescription* info, const geometry::CancelCheck& cancel) {
  const JobRequest request = parse_job_request(params, config, true);
  const std::filesystem::path model_file = models.resolve(request.model, "/model");
  // What job.submit would refuse, refused before the work: the registration, then the model's unit.
  check_request_registration(request, info ? machine_for_job(config.description, *info) : config.description);
  std::vector<std::string> notes = check_request_units(request, models, config.description.travel_box);
  const ReferenceModel model = load_reference_model(model_file, request, config.description.travel_box, cancel);
  const Eigen::Isometry3d T_M_S = preview_registration(request, notes);
  const description::MachineDescription machine =
      info ? machine_for_job(config.description, *info) : config.description;
  if (!info) notes.push_back("the machine could not be read: planned for the configured tip radii");
  // The tips the job would plan with now; the dry run changes tips where the program does.
  std::vector<std::string> tips = job_tips(request, config.description, machine, &notes);
  if (!machine.find_tip(tips.front())) tips = {machine.active_tip};
  description::MachineDescription primary = machine;
  primary.active_tip = tips.front();
  const planner::MeasurementPlan plan = plan_job(model, T_M_S, primary, cancel, tips);

  const std::unique_ptr<hal::Cmm> simulator = make_simulator(".");
  hal::Cmm& cmm = *simulator;
  std::optional<MeshedScanFile> meshed;
  if (model.scan) meshed.emplace(model.mesh);
  cmm.configure(meshed ? sim_block(meshed->path(), 1, request, machine, model.mesh, T_M_S)
                       : sim_block(model_file, request.scale, request, machine, model.mesh, T_M_S));
  cmm.connect();
  cmm.enable();
  cmm.home();
  const double homed_at_s = cmm.status().t_s;
  int contacts = 0, misses = 0, early = 0, out_of_travel = 0, other = 0;
  nlohmann::json problems = nlohmann::json::array();
  hal::Vec3 at = cmm.status().position;
  description::MachineDescription now = primary;  // its active tip follows the program's changes
  if (cmm.info().active_tip != now.active_tip) cmm.select_tip(now.active_tip);
  for (const planner::Touch& t : plan.program.touches) {
    cancel.throw_if_requested("the dry run");
    try {
      if (!t.tip.empty() && t.tip != now.active_tip) {
        run_motions(cmm, planner::tip_change_motions(at, t.tip, plan.program.clearance_z, now));
        now.active_tip = t.tip;
        at = cmm.status().position;
      }
      const std::vector<planner::Motion> motions =
          motions_from(at, planner::motions_of(plan.program, t.id), t, plan.program.clearance_z, now);
      at = t.start;
      const hal::TouchResult r = run_motions(cmm, motions);
      (r.contact ? contacts : misses)++;
      if (!r.contact) problems.push_back({{"touch", t.id}, {"kind", "miss"}});
    } catch (const hal::Fault& f) {
      if (f.kind() == hal::FaultKind::early_trigger) early++;
      else if (f.kind() == hal::FaultKind::soft_limit) out_of_travel++;
      else other++;
      if (problems.size() < 100) problems.push_back({{"touch", t.id}, {"kind", hal::to_string(f.kind())}, {"message", f.what()}});
      try {
        recover(cmm);
        at = cmm.status().position;
      } catch (const hal::Fault& stuck) {
        // The simulated ball cannot get free (it stopped inside the mesh): the rest would not say more.
        problems.push_back({{"touch", t.id}, {"kind", "dry_run_stopped"}, {"message", stuck.what()}});
        break;
      }
    }
  }
  std::size_t probeable = 0;
  for (const geometry::EdgePoint& p : model.features.points) probeable += p.convex;
  std::size_t measured_by_plan = 0;
  for (const planner::EdgePlan& e : plan.edges) measured_by_plan += e.method != planner::EdgeMethod::none;
  for (const std::string& n : plan.notes) notes.push_back(n);
  return {{"reference_mesh",
           {{"vertices", model.mesh.vertices.rows()},
            {"faces", model.mesh.faces.rows()},
            {"extent_mm", description::vec3_json(Eigen::Vector3d(model.mesh.vertices.colwise().maxCoeff() -
                                                                 model.mesh.vertices.colwise().minCoeff()))},
            {"scan", model.scan ? scan_report_json(*model.scan) : nlohmann::json(nullptr)}}},
          {"features",
           {{"edge_points", model.features.points.size()},
            {"probeable", measured_by_plan},
            {"convex", probeable},
            {"holes", model.features.holes.size()}}},
          {"touches", plan.program.touches.size()},
          {"tip", primary.active_tip},
          {"tips", tips},
          {"probe_radius", primary.tip().ball_radius_mm},
          {"estimate", {{"time_s", plan.program.time_s}, {"lower_bound_s", plan.program.lower_bound_s}}},
          {"dry_run",
           {{"time_s", cmm.status().t_s - homed_at_s},
            {"touches", plan.program.touches.size()},
            {"contacts", contacts},
            {"misses", misses},
            {"early_triggers", early},
            {"out_of_travel", out_of_travel},
            {"other_faults", other},
            {"problems", problems}}},
          {"notes", notes}};
}

}  // namespace cmm::daemon
