// Fills the report's and the QIF document's inputs from a job; see job_documents.hpp.
#include "daemon/job_documents.hpp"

#include "hal/utc_time.hpp"
#include "planner/job_report.hpp"
#include "planner/qif_export.hpp"

namespace cmm::daemon {

namespace {

planner::ReportRegistration report_registration(const JobRegistration& registration) {
  planner::ReportRegistration r;
  r.method = to_string(registration.method);
  r.T_M_S = registration.T_M_S;
  r.rms_mm = registration.fit.value("rms_mm", 0.0);
  for (const nlohmann::json& corner : registration.fit.value("corners", nlohmann::json::array()))
    r.corners.push_back({corner.value("id", 0), corner.value("norm_mm", 0.0)});
  return r;
}

planner::QifContext qif_context(int job_id, const JobResultInputs& in) {
  planner::QifContext c;
  c.job_id = std::to_string(job_id);
  c.job_name = in.request.name;
  c.part_name = in.request.name.empty() ? in.request.model : in.request.name;
  c.cmmd_version = in.version;
  c.station = in.config.station;
  c.machine.name = in.machine.name.empty() ? in.config.driver + " machine" : in.machine.name;
  c.machine.travel_min_M = in.machine.travel_box.min;
  c.machine.travel_max_M = in.machine.travel_box.max;
  c.tip.id = in.tip.id;
  c.tip.ball_radius_mm = in.machine.tip().ball_radius_mm;
  if (in.tip.qualification) {
    c.tip.offset_M = in.tip.qualification->offset;
    c.tip.qualified_utc = in.tip.qualification->time_utc;
    c.tip.qualification_residual_mm = in.tip.qualification->residual_rms_mm;
  } else {
    c.tip.offset_M = in.tip.offset;
  }
  c.started_utc = in.started_utc;
  c.finished_utc = in.finished_utc;
  c.written_utc = hal::utc_now();
  if (in.request.nominal) c.nominal_model = in.request.nominal->model;
  return c;
}

}  // namespace

void write_job_documents(JobStore& store, int job_id, const JobResultInputs& in, const planner::MeasurementResult& result) {
  planner::ReportInputs report;
  report.job_id = job_id;
  report.job_name = in.request.name;
  report.state = "done";
  report.model = in.request.model;
  if (in.request.nominal) report.nominal_model = in.request.nominal->model;
  report.station = in.config.station;
  report.cmmd_version = in.version;
  report.created_utc = in.started_utc;
  report.finished_utc = in.finished_utc;
  report.machine = {in.config.driver, in.machine.name, in.machine.travel_box};
  const description::StylusTip* configured = in.config.description.find_tip(in.tip.id);
  report.tip = {in.tip.id, configured ? configured->ball_radius_mm : in.tip.ball_radius_mm,
                configured ? configured->offset : in.tip.offset, in.tip.qualification};
  report.registration = report_registration(in.registration);
  report.result = result;
  report.reference_mesh = &in.model.mesh;
  store.write(job_id, JobFile::result_qif, planner::to_qif(result, qif_context(job_id, in)));
  store.write(job_id, JobFile::report, planner::render_report(report));
}

}  // namespace cmm::daemon
