// The mesh a job plans on, kept in its folder: reference.ply, and reference.json saying where it came
// from (the model, its scale, the scan report when the model was a raw scan) with the mesh's sha256.
// The first run makes the mesh from the model and stores it; every later run of the job (a resume, a
// restart, a reregister) plans on the stored mesh at scale 1, so a restart can never mesh a scan
// differently, nor pick up a model file changed since, and the touch ids of plan.json stay the plan's.
#pragma once

#include <nlohmann/json.hpp>

#include "daemon/job_planning.hpp"
#include "daemon/job_request.hpp"
#include "daemon/job_store.hpp"
#include "daemon/model_store.hpp"
#include "geometry/cancellation.hpp"
#include "hal/description/machine_description.hpp"

namespace cmm::daemon {

struct JobReference {
  ReferenceModel model;
  // reference.json's content and "planned_on": "model" (this run made the mesh from the model file)
  // or "stored_mesh" (it read reference.ply); plan.json and result.json record it as reference_mesh.
  nlohmann::json provenance;
};

// A scan report as reference.json and plan.preview give it: geometry::ScanReport's fields by name.
nlohmann::json scan_report_json(const geometry::ScanReport& report);

// Throws what load_reference_model and ModelStore::resolve throw (RpcError model_error, not_found,
// invalid_params; geometry::Cancelled); RpcError model_error, kind "unreadable", when reference.ply no
// longer matches the sha256 reference.json recorded; geometry::FileError when the folder cannot be
// written (a full disk holds the job, docs/api.md).
JobReference job_reference(JobStore& store, int job_id, const ModelStore& models, const JobRequest& request,
                           const description::TravelBox& travel_box, const geometry::CancelCheck& cancel = {});

}  // namespace cmm::daemon
