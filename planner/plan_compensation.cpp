// Compensating every planned feature; see plan_compensation.hpp.
#include "planner/plan_compensation.hpp"

#include <cmath>
#include <set>
#include <stdexcept>
#include <string>

#include "planner/number_text.hpp"

namespace cmm::planner {

namespace {

struct Context {
  const Eigen::Isometry3d& T_M_S;
  const std::map<int, TouchOutcome>& touches;
  const CompensationOptions& options;
};

// The trigger centres of `planned`, in order; or why there are none: the first touch without a
// result or without contact, named by id and target.
struct Centres {
  std::vector<Vec3> centres;
  std::string failure;
};

Centres centres_of(const std::vector<Touch>& planned, const std::map<int, TouchOutcome>& touches) {
  Centres out;
  for (const Touch& t : planned) {
    const std::string name = "touch " + std::to_string(t.id) + " (" + to_string(t.target) + " " + std::to_string(t.face) + ")";
    const auto found = touches.find(t.id);
    if (found == touches.end()) {
      out.failure = name + " has no result";
      return out;
    }
    if (!found->second.contact) {
      out.failure = name + " missed: no contact within its " + fixed(t.max_travel_mm, 3) + " mm search";
      return out;
    }
    if (!found->second.centre.allFinite()) {
      out.failure = name + " reported a centre that is not finite";
      return out;
    }
    out.centres.push_back(found->second.centre);
  }
  return out;
}

std::vector<int> ids_of(const std::vector<Touch>& planned) {
  std::vector<int> ids;
  for (const Touch& t : planned) ids.push_back(t.id);
  return ids;
}

// Measures a planned feature from its touches' centres: a touch without a result or without contact,
// or a CompensationError, leaves `r` failed with the reason and nothing measured in it.
template <typename Result, typename Measure>
void measure_feature(Result& r, const std::vector<Touch>& planned, const Context& c, Measure measure) {
  r.status = FeatureStatus::failed;
  const Centres centres = centres_of(planned, c.touches);
  if (!centres.failure.empty()) {
    r.reason = centres.failure;
    return;
  }
  const Result unmeasured = r;
  try {
    measure(centres.centres);
  } catch (const CompensationError& e) {
    r = unmeasured;
    r.reason = e.what();
    return;
  }
  r.status = FeatureStatus::measured;
}

// The radius a feature's touches were planned for: its tip's, or the job's one radius.
double radius_of(double planned_mm, const Context& c) { return planned_mm > 0 ? planned_mm : c.options.ball_radius_mm; }

// In M, as compensated: by two touches through the reference point or by the two faces' planes.
MeasuredPoint measure_in_machine(const geometry::EdgePoint& point, const EdgePlan& plan, const std::vector<Vec3>& centres,
                                 const Context& c) {
  const Eigen::Matrix3d R = c.T_M_S.linear();
  if (plan.method == EdgeMethod::two_touch) {
    if (!plan.window || centres.size() != 2) {
      throw CompensationError("edge point", point.id, CompensationError::Reason::bad_input,
                              "a two-touch plan needs a window and exactly two touches");
    }
    TwoTouchInput in;
    in.id = point.id;
    in.reference_point = c.T_M_S * point.position;
    in.tangent = R * plan.window->plane_normal;
    in.window_axis = R * plan.window->axis;
    in.ball_radius_mm = radius_of(plan.radius_mm, c);
    in.trigger_sigma_mm = c.options.trigger_sigma_mm;
    for (int i = 0; i < 2; ++i) {
      in.centre[i] = centres[static_cast<std::size_t>(i)];
      in.approach[i] = plan.touches[static_cast<std::size_t>(i)].direction;
    }
    return measure_edge_two_touch(in);
  }
  FaceEdgeInput in;
  in.id = point.id;
  in.reference_point = c.T_M_S * point.position;
  in.tangent = R * point.tangent;
  in.ball_radius_mm = radius_of(plan.radius_mm, c);
  in.trigger_sigma_mm = c.options.trigger_sigma_mm;
  in.up.nominal_normal = R * point.n_up;
  in.down.nominal_normal = R * point.n_down.value_or(Vec3::Zero());
  for (std::size_t k = 0; k < plan.touches.size(); ++k)  // faces 0, 1 lie on the up side, 2, 3 on the down side
    (plan.touches[k].face < 2 ? in.up : in.down).centres.push_back(centres[k]);
  return measure_edge_from_faces(in);
}

EdgeResult compensate_edge(const geometry::EdgePoint& point, const EdgePlan& plan, const Context& c) {
  EdgeResult r;
  r.id = point.id;
  r.kind = point.kind;
  r.method = plan.method;
  r.reference = point.position;
  r.touch_ids = ids_of(plan.touches);
  r.tip = plan.tip;
  r.reason = plan.reason;
  if (plan.method == EdgeMethod::none) return r;
  measure_feature(r, plan.touches, c, [&](const std::vector<Vec3>& centres) {
    r.machine = measure_in_machine(point, plan, centres, c);
    r.scan = to_scan_frame(*r.machine, c.T_M_S);
    r.deviation = signed_deviation(r.scan->position, point.position, point.n_up, point.n_down.value_or(Vec3::Zero()),
                                   point.tangent);
    // The window guarantees a touch on the edge, and the faces' touches land on the faces, only for an
    // edge within δ of the reference point. A point found farther away says that assumption broke (a
    // scan's defect put the reference off): the touches may have met a face, and the figure is refused.
    const double off = (r.scan->position - point.position).norm();
    if (plan.delta_mm > 0 && off > plan.delta_mm + 3 * r.scan->sigma_mm) {
      throw CompensationError("edge point", point.id, CompensationError::Reason::beyond_delta,
                              "measured " + fixed(off, 3) + " mm from its reference point, beyond the δ " +
                                  fixed(plan.delta_mm, 3) + " mm its touches were planned for: a touch may have met a face instead of the edge");
    }
  });
  return r;
}

HoleResult compensate_bore(const geometry::Hole& hole, const BorePlan& plan, const Context& c) {
  HoleResult r;
  r.id = hole.id;
  r.reason = plan.reason;
  r.touch_ids = ids_of(plan.touches);
  r.tip = plan.tip;
  r.depth_mm = plan.depth_mm;
  r.nominal_centre = hole.centre;
  r.nominal_axis = hole.axis.normalized();
  r.nominal_diameter_mm = 2 * hole.radius;
  if (!plan.planned) return r;
  measure_feature(r, plan.touches, c, [&](const std::vector<Vec3>& centres) {
    BoreInput in;
    in.hole_id = hole.id;
    in.centres = centres;
    in.axis = c.T_M_S.linear() * r.nominal_axis;
    in.ball_radius_mm = radius_of(plan.radius_mm, c);
    in.trigger_sigma_mm = c.options.trigger_sigma_mm;
    r.machine = measure_bore(in);
    r.scan = to_scan_frame(*r.machine, c.T_M_S);
    for (const MeasuredPoint& p : bore_wall_points(in, *r.machine)) r.wall_points.push_back(to_scan_frame(p, c.T_M_S));
    const Vec3 v = r.scan->centre - r.nominal_centre;
    r.centre_offset = v - v.dot(r.nominal_axis) * r.nominal_axis;
    r.centre_deviation_mm = r.centre_offset.norm();
    r.diameter_deviation_mm = r.scan->diameter_mm - r.nominal_diameter_mm;
  });
  return r;
}

void check_inputs(const geometry::FeatureModel& model, const MeasurementPlan& plan, const CompensationOptions& o) {
  if (!(o.ball_radius_mm > 0) || !std::isfinite(o.ball_radius_mm))
    throw std::invalid_argument("compensation: ball radius " + fixed(o.ball_radius_mm, 6) + " mm is not positive");
  if (!(o.trigger_sigma_mm >= 0) || !std::isfinite(o.trigger_sigma_mm))
    throw std::invalid_argument("compensation: trigger sigma " + fixed(o.trigger_sigma_mm, 6) + " mm is not a standard deviation");
  if (plan.edges.size() != model.points.size() || plan.bores.size() != model.holes.size())
    throw std::invalid_argument("compensation: the plan has " + std::to_string(plan.edges.size()) + " edge points and " +
                                std::to_string(plan.bores.size()) + " bores, the model " + std::to_string(model.points.size()) +
                                " and " + std::to_string(model.holes.size()) + ": not the plan of this model");
  for (std::size_t i = 0; i < plan.edges.size(); ++i)
    if (plan.edges[i].edge_point != model.points[i].id)
      throw std::invalid_argument("compensation: plan edge " + std::to_string(i) + " is for point " +
                                  std::to_string(plan.edges[i].edge_point) + ", the model's point there is " +
                                  std::to_string(model.points[i].id));
  for (std::size_t i = 0; i < plan.bores.size(); ++i)
    if (plan.bores[i].hole != model.holes[i].id)
      throw std::invalid_argument("compensation: plan bore " + std::to_string(i) + " is for hole " +
                                  std::to_string(plan.bores[i].hole) + ", the model's hole there is " +
                                  std::to_string(model.holes[i].id));
}

// Results the plan has no touch for: a journal from another plan, or registration touches.
std::string unknown_touches_note(const MeasurementPlan& plan, const std::map<int, TouchOutcome>& touches) {
  std::set<int> planned;
  for (const EdgePlan& e : plan.edges)
    for (const Touch& t : e.touches) planned.insert(t.id);
  for (const BorePlan& b : plan.bores)
    for (const Touch& t : b.touches) planned.insert(t.id);
  std::vector<int> unknown;
  for (const auto& [id, outcome] : touches)
    if (!planned.contains(id)) unknown.push_back(id);
  if (unknown.empty()) return {};
  std::string ids;
  for (std::size_t k = 0; k < std::min<std::size_t>(unknown.size(), 5); ++k) ids += (k ? ", " : "") + std::to_string(unknown[k]);
  if (unknown.size() > 5) ids += ", ...";
  return std::to_string(unknown.size()) + " touch result(s) belong to no edge point or bore of the plan and were ignored (ids " +
         ids + ")";
}

}  // namespace

MeasurementResult compensate_plan(const geometry::FeatureModel& model, const MeasurementPlan& plan,
                                  const Eigen::Isometry3d& T_M_S, const std::map<int, TouchOutcome>& touches,
                                  const CompensationOptions& options) {
  check_inputs(model, plan, options);
  const Context context{T_M_S, touches, options};
  MeasurementResult result;
  result.T_M_S = T_M_S;
  result.ball_radius_mm = options.ball_radius_mm;
  result.trigger_sigma_mm = options.trigger_sigma_mm;
  for (std::size_t i = 0; i < model.points.size(); ++i)
    result.edges.push_back(compensate_edge(model.points[i], plan.edges[i], context));
  for (std::size_t i = 0; i < model.holes.size(); ++i)
    result.holes.push_back(compensate_bore(model.holes[i], plan.bores[i], context));
  result.summary = summarise(result.edges, result.holes);
  if (std::string note = unknown_touches_note(plan, touches); !note.empty()) result.notes.push_back(std::move(note));
  return result;
}

}  // namespace cmm::planner
