// The result files of a job (result.json, CSV, merged cloud) from its plan and touches, with what
// traceability needs.
#include "daemon/job_result.hpp"

#include <cmath>
#include <cstdio>
#include <set>
#include <vector>

#include "daemon/client/sha256.hpp"
#include "daemon/job_documents.hpp"
#include "daemon/job_inspection.hpp"
#include "planner/measured_cloud.hpp"
#include "planner/plan_compensation.hpp"
#include "planner/result_csv.hpp"
#include "planner/result_json.hpp"

namespace cmm::daemon {

namespace {

std::string sha256_of(std::string_view text) {
  Sha256 digest;
  digest.update(text);
  return digest.hex_digest();
}

// What a result needs to be traced back to: which software, config, machine, tip and inputs.
nlohmann::json traceability(const JobResultInputs& in, double radius_mm) {
  std::string config_hash;
  try {
    config_hash = sha256_hex_of_file(in.config.source);
  } catch (const std::exception&) {
    config_hash = "";  // cmmd started from defaults, not a file
  }
  nlohmann::json tip = {{"id", in.tip.id}, {"qualification", nullptr}, {"qualifications", nlohmann::json::array()}};
  if (in.qualifications) {
    // The first is the one the job was planned and registered with; every one with the touches it covers.
    const nlohmann::json file = to_json(*in.qualifications);
    tip["id"] = in.qualifications->tip;
    tip["qualification"] = file["qualifications"][0]["qualification"];
    tip["qualifications"] = file["qualifications"];
    for (nlohmann::json& q : tip["qualifications"]) {
      q["job_touches"] = 0;
      q["first_touch"] = q["last_touch"] = nullptr;
      // What touches_at_radius moves its touches by: from the radius its tip was planned with.
      double planned = radius_mm;
      for (const PlannedTip& p : in.registration.tips)
        if (p.id == q.value("tip", in.qualifications->tip)) planned = p.radius_mm;
      q["radius_adjustment_mm"] = q["ball_radius_mm"].get<double>() - planned;
    }
    for (const planner::Touch& t : in.plan.program.touches) {  // in the order they were made
      if (!in.touches.contains(t.id)) continue;
      const auto found = in.touch_qualification.find(t.id);
      const std::size_t k = found == in.touch_qualification.end() ? 0 : static_cast<std::size_t>(found->second);
      if (k >= tip["qualifications"].size()) continue;
      nlohmann::json& q = tip["qualifications"][k];
      q["job_touches"] = q["job_touches"].get<int>() + 1;
      if (q["first_touch"].is_null()) q["first_touch"] = t.id;
      q["last_touch"] = t.id;
    }
  } else if (in.tip.qualification) {
    tip["qualification"] = {{"time_utc", in.tip.qualification->time_utc},
                            {"ball_radius_mm", in.tip.qualification->ball_radius_mm},
                            {"residual_rms_mm", in.tip.qualification->residual_rms_mm}};
  }
  return {{"cmmd_version", in.version},
          {"config_file", in.config.source.string()},
          {"config_sha256", config_hash},
          {"machine_description_sha256", sha256_of(description::to_json(in.machine).dump())},
          {"driver", in.config.driver},
          {"model", in.request.model},
          {"model_file", in.model.inputs.model_file.string()},
          {"reference_mesh", in.reference_mesh},
          {"tip", tip},
          {"seeds", {{"job", in.request.seed}, {"machine", in.config.machine.value("seed", nlohmann::json(nullptr))}}},
          {"started_utc", in.started_utc},
          {"finished_utc", in.finished_utc}};
}

// Which tip and which of the job's qualifications made each touch, in the order they were made.
nlohmann::json touch_tips(const JobResultInputs& in) {
  nlohmann::json list = nlohmann::json::array();
  for (const planner::Touch& t : in.plan.program.touches) {
    const auto made = in.touches.find(t.id);
    if (made == in.touches.end()) continue;
    const auto q = in.touch_qualification.find(t.id);
    list.push_back({{"touch", t.id}, {"tip", made->second.tip_id}, {"q", q == in.touch_qualification.end() ? 0 : q->second}});
  }
  return list;
}

// The tips the job measured with their nominal values (never qualified, as the request allowed):
// every figure they made rests on a radius and offset nobody measured.
std::vector<std::string> unqualified_tip_notes(const JobResultInputs& in) {
  std::vector<std::string> notes;
  if (!in.qualifications) return notes;
  std::set<std::string> tips;
  for (const auto& [touch, q] : in.touch_qualification)
    if (q >= 0 && static_cast<std::size_t>(q) < in.qualifications->list.size() &&
        !in.qualifications->list[static_cast<std::size_t>(q)].qualification)
      tips.insert(in.qualifications->list[static_cast<std::size_t>(q)].tip);
  for (const std::string& tip : tips)
    notes.push_back("nominal tip, not qualified: tip " + tip +
                    " measured with its nominal radius and offset (allow_unqualified_tip); every figure made with it "
                    "(the features whose \"tip\" is " + tip + ") carries its unknown radius and offset error");
  return notes;
}

// Job-wide remarks on the qualifications, for the result's notes.
std::vector<std::string> qualification_notes(const JobResultInputs& in, double radius_mm) {
  std::vector<std::string> notes = unqualified_tip_notes(in);
  if (!in.qualifications) return notes;
  const auto& list = in.qualifications->list;
  std::map<std::string, int> entries;  // by tip
  for (const QualificationInForce& q : list) ++entries[q.tip];
  char line[512];
  for (const auto& [tip, n] : entries) {
    if (n < 2) continue;
    std::snprintf(line, sizeof line,
                  "tip %s was qualified %d times during the job (traceability.tip.qualifications): each touch is "
                  "compensated with the radius qualified for it, moved by (r - R) along its approach, R the radius "
                  "the plan was made for (%.6f mm for the job's primary tip)",
                  tip.c_str(), n, radius_mm);
    notes.emplace_back(line);
  }
  for (std::size_t k = 1; k < list.size(); ++k) {
    if (list[k].tip != list[k - 1].tip) continue;  // another tip's entry: nothing to compare
    const double moved = (list[k].offset - list[k - 1].offset).norm();
    const double dr = list[k].ball_radius_mm - list[k - 1].ball_radius_mm;
    // Two qualifications of one untouched stylus agree to a micrometre or two; more is the stylus moved.
    if (moved > 0.005 || std::abs(dr) > 0.002) {
      std::snprintf(line, sizeof line,
                    "tip %s's qualification %zu differs from the one before by %.4f mm in offset and %.4f mm in "
                    "radius: if the stylus was knocked in between, the touches before it are off by as much",
                    in.qualifications->tip.c_str(), k, moved, dr);
      notes.emplace_back(line);
    }
  }
  return notes;
}

}  // namespace

// A touch made under a qualification of radius r touched where its ball's surface met the part: r
// ahead of its centre along the contact normal, which for a planned touch is its approach d (a face
// met square on; an edge's apex on the centre line through the reference point, within δ sideways,
// so the normal is off d by at most asin(δ/r)). The centre + (r − R)·d then has that same contact
// point at radius R, to (r − R)(1 − cos θ): 0.02·|r − R| at worst for δ 0.2 mm on a 1 mm ball,
// nanometres for any requalification of one tip (a larger change holds the job). The ball centre itself is the controller's, made with
// the offset in force then; nothing more is changed. The first qualification's touches are the
// plan's own and stay as they are.
std::map<int, planner::TouchOutcome> touches_at_radius(const std::vector<planner::Touch>& planned,
                                                       const std::map<int, hal::TouchResult>& touches,
                                                       const std::map<int, int>& touch_qualification,
                                                       const JobQualifications* qualifications,
                                                       const std::map<std::string, double>& planned_radius) {
  std::map<int, const planner::Touch*> by_id;
  for (const planner::Touch& t : planned) by_id[t.id] = &t;
  std::map<int, planner::TouchOutcome> outcomes;
  for (const auto& [id, r] : touches) {
    planner::TouchOutcome o{r.contact, r.centre};
    const auto q = touch_qualification.find(id);
    const auto touch = by_id.find(id);
    if (qualifications && q != touch_qualification.end() && static_cast<std::size_t>(q->second) < qualifications->list.size() &&
        touch != by_id.end() && r.contact) {
      const QualificationInForce& made = qualifications->list[static_cast<std::size_t>(q->second)];
      if (const auto radius = planned_radius.find(made.tip); radius != planned_radius.end())
        o.centre += (made.ball_radius_mm - radius->second) * touch->second->direction.normalized();
    }
    outcomes[id] = o;
  }
  return outcomes;
}

std::string write_job_result(JobStore& store, int job_id, const JobResultInputs& in) {
  const double radius = in.registration.radius_mm;
  std::map<std::string, double> planned_radius;
  for (const PlannedTip& t : in.registration.tips) planned_radius[t.id] = t.radius_mm;
  const std::map<int, planner::TouchOutcome> outcomes =
      touches_at_radius(in.plan.program.touches, in.touches, in.touch_qualification, in.qualifications, planned_radius);
  planner::MeasurementResult result = planner::compensate_plan(
      in.model.features, in.plan, in.registration.T_M_S, outcomes, {radius, in.config.job.trigger_sigma_mm});
  for (std::string& note : qualification_notes(in, radius)) result.notes.push_back(std::move(note));
  // A nominal that cannot be read or placed costs the verdicts, never the measurements: the result is
  // written without them and says why.
  std::string inspection_problem;
  if (in.models && in.request.nominal) {
    try {
      result.inspection = inspect_job(in.request, *in.models, in.model, result);
    } catch (const std::exception& e) {
      inspection_problem = e.what();
      result.notes.push_back(std::string("no verdicts: ").append(e.what()));
    }
  }

  nlohmann::json j = planner::to_json(result);
  j["job"] = job_id;
  j["touches"] = in.touches.size();
  j["touch_tips"] = touch_tips(in);
  j["machine_time_s"] = in.machine_time_s;
  j["probing_time_s"] = in.probing_time_s;
  j["estimate_s"] = in.plan.program.time_s;
  j["name"] = in.request.name;
  j["registration"] = in.registration.fit;
  j["registration_method"] = to_string(in.registration.method);
  j["traceability"] = traceability(in, radius);
  j["files"] = {{"csv", file_name(JobFile::result_csv)},          {"holes_csv", file_name(JobFile::holes_csv)},
                {"merged_cloud", file_name(JobFile::merged_cloud)}, {"plan", file_name(JobFile::plan)},
                {"touches", file_name(JobFile::touches)}, {"qif", file_name(JobFile::result_qif)},
                {"report", file_name(JobFile::report)}};
  store.write(job_id, JobFile::result_csv, planner::to_csv(result));
  store.write(job_id, JobFile::holes_csv, planner::holes_to_csv(result));
  geometry::Points scan_points = in.model.mesh.vertices;
  planner::write_merged_ply(store.path(job_id, JobFile::merged_cloud), scan_points,
                            planner::measured_points_in_scan(result), in.request.delta_mm);  // δ bounds a reference point's error
  try {
    write_job_documents(store, job_id, in, result);
  } catch (const std::invalid_argument& e) {
    // A document that cannot be made (a number QIF cannot hold) costs that document, not the result.
    j["notes"].push_back(std::string("no report or QIF file: ").append(e.what()));
  }
  store.write(job_id, JobFile::result, j.dump(1) + "\n");

  const planner::ResultSummary& s = result.summary;
  char line[256];
  std::snprintf(line, sizeof line,
                "%d of %d edge points measured (%d failed); deviation RMS %.4f mm, max %.4f mm; %d of %d holes measured",
                s.edges_measured, s.edge_points, s.edges_failed, s.rms_deviation_mm, s.max_deviation_mm,
                s.holes_measured, s.holes);
  std::string summary = line;
  if (result.inspection) {
    const planner::InspectionResult& r = *result.inspection;
    std::snprintf(line, sizeof line, "; verdict %s (%d pass, %d fail, %d undecided; ", planner::to_string(r.verdict),
                  r.edge_counts.pass + r.hole_counts.pass, r.edge_counts.fail + r.hole_counts.fail,
                  r.edge_counts.undecided + r.hole_counts.undecided);
    summary.append(line).append(planner::coverage_text(r)).append(")");
  } else if (!inspection_problem.empty()) {
    summary.append("; no verdicts: ").append(inspection_problem);
  }
  return summary;
}

}  // namespace cmm::daemon
