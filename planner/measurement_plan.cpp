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

MeasurementPlan plan_measurement(const geometry::FeatureModel& model, const geometry::TriangleMesh& mesh,
                                 const Eigen::Isometry3d& T_M_S, const description::MachineDescription& machine,
                                 const MeasurementPlanOptions& options) {
  MeasurementPlan plan;
  const geometry::TriangleMesh mesh_m = in_machine_frame(mesh, T_M_S);
  if (mesh_m.vertices.rows() == 0) throw std::invalid_argument("the reference mesh is empty");
  plan.floor_z = mesh_m.vertices.col(2).minCoeff();
  const double top = mesh_m.vertices.col(2).maxCoeff();
  const double radius = options.touch.radius;
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
  const StylusClearance clearance(sweeper, plan.floor_z - 1e-6, machine, radius, plan.clearance_z, options.touch.delta);
  plan.edges.resize(model.points.size());
  parallel_for(model.points.size(), options.threads, options.cancel, "the edge points' touches", [&](std::size_t i) {
    plan.edges[i] = plan_edge_point(model.points[i], T_M_S, clearance, options.touch);
  });
  plan.bores.resize(model.holes.size());
  parallel_for(model.holes.size(), options.threads, options.cancel, "the bores' touches", [&](std::size_t i) {
    plan.bores[i] = plan_bore(model.holes[i], T_M_S, clearance, options.touch);
  });

  std::vector<Touch> touches;
  for (EdgePlan& e : plan.edges)
    for (Touch& t : e.touches) {
      t.id = static_cast<int>(touches.size());
      t.edge_point = e.edge_point;
      touches.push_back(t);
    }
  for (BorePlan& b : plan.bores)
    for (Touch& t : b.touches) {
      t.id = static_cast<int>(touches.size());
      touches.push_back(t);
    }
  options.cancel.throw_if_requested("the touches");
  const Vec3 home(machine.travel_box.min.x(), machine.travel_box.min.y(), plan.clearance_z);
  plan.program = build_program(std::move(touches), machine, home, plan.clearance_z);
  return plan;
}

}  // namespace cmm::planner
