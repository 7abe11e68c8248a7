// Planning every feature of a model; see measurement_plan.hpp.
#include "planner/measurement_plan.hpp"

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "geometry/ball_sweep.hpp"
#include "planner/number_text.hpp"

namespace cmm::planner {

namespace {

geometry::TriangleMesh in_machine_frame(const geometry::TriangleMesh& mesh, const Eigen::Isometry3d& T_M_S) {
  geometry::TriangleMesh moved;
  moved.faces = mesh.faces;
  moved.vertices.resize(mesh.vertices.rows(), 3);
  for (Eigen::Index i = 0; i < mesh.vertices.rows(); ++i)
    moved.vertices.row(i) = (T_M_S * Vec3(mesh.vertices.row(i).transpose())).transpose();
  return moved;
}

// Runs body(i) for i in [0, n) on a few threads; each index is independent. A cancel, or an
// exception in any thread (which would otherwise end the process), stops every thread at its next
// block of indices and is thrown here, on the caller's thread.
template <typename Body>
void parallel_for(std::size_t n, int threads, const geometry::CancelCheck& cancel, const char* what, Body body) {
  const unsigned count = std::max(1u, threads > 0 ? static_cast<unsigned>(threads) : std::thread::hardware_concurrency());
  std::atomic<std::size_t> next{0};
  std::atomic<bool> failed{false};
  std::exception_ptr failure;
  std::mutex failure_mutex;
  auto worker = [&] {
    try {
      for (std::size_t i; !failed && !cancel.stop_requested() && (i = next.fetch_add(64)) < n;)
        for (std::size_t k = i; k < std::min(n, i + 64); ++k) body(k);
    } catch (...) {
      const std::lock_guard lock(failure_mutex);
      if (!failure) failure = std::current_exception();
      failed = true;
    }
  };
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < count && n > 64; ++t) pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool) t.join();
  if (failure) std::rethrow_exception(failure);
  cancel.throw_if_requested(what);
}

std::string mm(double value) { return fixed(value, 3); }

}  // namespace

namespace {

// One tip's view of the machine: it active, the touch options at its radius.
struct TipPlanning {
  description::MachineDescription machine;
  TouchPlanOptions touch;
};

std::vector<TipPlanning> tips_to_plan(const description::MachineDescription& machine, const MeasurementPlanOptions& options) {
  std::vector<TipPlanning> tips;
  if (options.tips.empty()) return {{machine, options.touch}};
  for (const std::string& id : options.tips) {
    const description::StylusTip* tip = machine.find_tip(id);
    if (tip == nullptr) throw std::invalid_argument("the machine has no tip \"" + id + "\" to plan for");
    TipPlanning t{machine, options.touch};
    t.machine.active_tip = id;
    t.touch.radius = tip->ball_radius_mm;
    tips.push_back(std::move(t));
  }
  return tips;
}

// "edge points: 340 with T1; bores: 5 with T2": which tip measures what, when there is a choice.
std::string tips_note(const MeasurementPlan& plan, const std::vector<TipPlanning>& tips) {
  std::string note = "tips chosen per feature:";
  for (const TipPlanning& t : tips) {
    const std::string& id = t.machine.active_tip;
    const auto edges = std::count_if(plan.edges.begin(), plan.edges.end(),
                                     [&](const EdgePlan& e) { return e.method != EdgeMethod::none && e.tip == id; });
    const auto bores = std::count_if(plan.bores.begin(), plan.bores.end(), [&](const BorePlan& b) { return b.planned && b.tip == id; });
    note += " " + id + " (r " + mm(t.touch.radius) + " mm) " + std::to_string(edges) + " edge points, " +
            std::to_string(bores) + " bores;";
  }
  note.pop_back();
  return note;
}

}  // namespace

MeasurementPlan plan_measurement(const geometry::FeatureModel& model, const geometry::TriangleMesh& mesh,
                                 const Eigen::Isometry3d& T_M_S, const description::MachineDescription& machine,
                                 const MeasurementPlanOptions& options) {
  MeasurementPlan plan;
  const std::vector<TipPlanning> tips = tips_to_plan(machine, options);
  const geometry::TriangleMesh mesh_m = in_machine_frame(mesh, T_M_S);
  if (mesh_m.vertices.rows() == 0) throw std::invalid_argument("the reference mesh is empty");
  plan.floor_z = mesh_m.vertices.col(2).minCoeff();
  const double top = mesh_m.vertices.col(2).maxCoeff();
  double radius = 0;
  for (const TipPlanning& t : tips) radius = std::max(radius, t.touch.radius);
  plan.clearance_z = std::max(machine.clearance_z, top + radius + options.clearance_gap_mm);
  if (plan.clearance_z > machine.travel_box.max.z() - radius)
    throw std::invalid_argument("the part's top in M (z " + mm(top) + " mm) leaves no clearance plane below the travel box's top (z " +
                                mm(machine.travel_box.max.z()) + " mm)");
  if (plan.clearance_z > machine.clearance_z)
    plan.notes.push_back("clearance plane raised from the machine's z " + mm(machine.clearance_z) + " to " +
                         mm(plan.clearance_z) + " mm, above the part's top and the ball");
  plan.notes.push_back("the table or plate top is taken at the part's lowest point, z " + mm(plan.floor_z) + " mm in M");

  options.cancel.throw_if_requested("the reference mesh in M");
  const geometry::BallSweeper sweeper(mesh_m);
  plan.edges.resize(model.points.size());
  plan.bores.resize(model.holes.size());
  for (std::size_t k = 0; k < tips.size(); ++k) {
    const TipPlanning& tip = tips[k];
    const std::string& id = tip.machine.active_tip;
    const StylusClearance clearance(sweeper, plan.floor_z - 1e-6, tip.machine, tip.touch.radius, plan.clearance_z,
                                    tip.touch.delta);
    // A later tip takes an edge point only where the ones before could not measure it.
    parallel_for(model.points.size(), options.threads, options.cancel, "the edge points' touches", [&](std::size_t i) {
      if (k > 0 && plan.edges[i].method != EdgeMethod::none) return;
      EdgePlan e = plan_edge_point(model.points[i], T_M_S, clearance, tip.touch);
      if (k > 0 && e.method == EdgeMethod::none) return;  // the primary tip's reason stands
      e.tip = id;
      e.radius_mm = tip.touch.radius;
      plan.edges[i] = std::move(e);
    });
    parallel_for(model.holes.size(), options.threads, options.cancel, "the bores' touches", [&](std::size_t i) {
      BorePlan b = plan_bore(model.holes[i], T_M_S, clearance, tip.touch);
      const BorePlan& so_far = plan.bores[i];
      if (k > 0 && !(b.planned && (!so_far.planned || tip.touch.radius > so_far.radius_mm))) return;
      b.tip = id;
      b.radius_mm = tip.touch.radius;
      plan.bores[i] = std::move(b);
    });
  }
  if (tips.size() > 1) plan.notes.push_back(tips_note(plan, tips));

  std::vector<Touch> touches;
  for (EdgePlan& e : plan.edges)
    for (Touch& t : e.touches) {
      t.id = static_cast<int>(touches.size());
      t.edge_point = e.edge_point;
      t.tip = e.tip;
      touches.push_back(t);
    }
  for (BorePlan& b : plan.bores)
    for (Touch& t : b.touches) {
      t.id = static_cast<int>(touches.size());
      t.tip = b.tip;
      touches.push_back(t);
    }
  options.cancel.throw_if_requested("the touches");
  const Vec3 home(machine.travel_box.min.x(), machine.travel_box.min.y(), plan.clearance_z);
  plan.program = build_program(std::move(touches), tips.front().machine, home, plan.clearance_z);
  return plan;
}

}  // namespace cmm::planner
