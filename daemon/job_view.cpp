// job.view from the job's files, each read by the reader that owns its format: registration.json
// (job_registration_from_json), touches.jsonl (recover_journal); plan.json and result.json are the
// JSON cmmd wrote, of which the view keeps the few fields the dashboard draws.
#include "daemon/job_view.hpp"

#include <optional>
#include <string>

#include "daemon/client/base64.hpp"
#include "daemon/job_registration.hpp"
#include "daemon/touch_journal.hpp"
#include "hal/description/eigen_json.hpp"

namespace cmm::daemon {

namespace {

using nlohmann::json;

std::optional<json> read_json(const JobStore& store, int job_id, JobFile file) {
  const std::optional<std::string> text = store.read(job_id, file);
  if (!text) return std::nullopt;
  return json::parse(*text);
}

// plan.json's edge points and holes, in S, with the touch ids that measure each: what the view
// colours by method or reason, and what a job.touch's id is looked up in.
void add_plan(json& view, const json& plan) {
  for (const json& p : plan.at("edge_points"))
    view["edge_points"].push_back({{"id", p.at("id")},
                                   {"position_S", p.at("position")},
                                   {"kind", p.at("kind")},
                                   {"method", p.value("method", json("none"))},
                                   {"probeable", p.value("probeable", false)},
                                   {"reason", p.value("reason", json(nullptr))},
                                   {"touches", p.value("touches", json::array())}});
  for (const json& h : plan.at("holes")) {
    const json& bore = h.value("bore", json(nullptr));
    view["holes"].push_back({{"id", h.at("id")},
                             {"centre_S", h.at("centre")},
                             {"axis_S", h.at("axis")},
                             {"radius", h.at("radius")},
                             {"reason", h.value("bore_reason", json(nullptr))},
                             {"touches", bore.is_object() ? bore.value("touches", json::array()) : json::array()}});
  }
}

// result.json cut down to what a click on a point shows: each feature's deviation against the scan
// and its `inspection` (against the nominal, with tolerance and verdict); the job-wide inspection
// (verdict, counts, tolerances, the nominal's placement) and the summary are kept whole, they are small.
json reduced_result(const json& result) {
  json reduced = {{"edge_points", json::array()},
                  {"holes", json::array()},
                  {"summary", result.value("summary", json(nullptr))},
                  {"inspection", result.value("inspection", json(nullptr))}};
  for (const json& e : result.at("edge_points"))
    reduced["edge_points"].push_back({{"id", e.at("id")},
                                      {"status", e.at("status")},
                                      {"reason", e.value("reason", json(nullptr))},
                                      {"measured_S", e.value("measured_S", json(nullptr))},
                                      {"deviation_mm", e.value("deviation_mm", json(nullptr))},
                                      {"sigma_mm", e.value("sigma_mm", json(nullptr))},
                                      {"inspection", e.value("inspection", json(nullptr))}});
  for (const json& h : result.at("holes"))
    reduced["holes"].push_back({{"id", h.at("id")},
                                {"status", h.at("status")},
                                {"reason", h.value("reason", json(nullptr))},
                                {"measured_S", h.value("measured_S", json(nullptr))},
                                {"diameter_mm", h.value("diameter_mm", json(nullptr))},
                                {"diameter_deviation_mm", h.value("diameter_deviation_mm", json(nullptr))},
                                {"centre_deviation_mm", h.value("centre_deviation_mm", json(nullptr))},
                                {"centre_sigma_mm", h.value("centre_sigma_mm", json(nullptr))},
                                {"nominal", h.value("nominal", json(nullptr))},
                                {"inspection", h.value("inspection", json(nullptr))}});
  return reduced;
}

}  // namespace

json job_view(const JobStore& store, int job_id) {
  json view = {{"job", job_id},
               {"reference_ply", nullptr},
               {"T_M_S", nullptr},
               {"edge_points", json::array()},
               {"holes", json::array()},
               {"touches_done", json::array()},
               {"result", nullptr}};
  // Binary PLY as the job stored it (docs/result.md, the reference mesh): the browser's PLYLoader reads it as is.
  if (const std::optional<std::string> mesh = store.read(job_id, JobFile::reference_mesh))
    view["reference_ply"] = encode_base64(*mesh);
  if (const std::optional<json> registration = read_json(store, job_id, JobFile::registration))
    view["T_M_S"] = description::transform_json(job_registration_from_json(*registration).T_M_S);
  if (const std::optional<json> plan = read_json(store, job_id, JobFile::plan)) add_plan(view, *plan);
  for (const JournalEntry& e : recover_journal(store.path(job_id, JobFile::touches)).entries)
    view["touches_done"].push_back(e.touch_id);
  if (const std::optional<json> result = read_json(store, job_id, JobFile::result)) view["result"] = reduced_result(*result);
  return view;
}

}  // namespace cmm::daemon
