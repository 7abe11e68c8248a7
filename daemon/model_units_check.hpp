// The request's model, and its nominal, against the plate it stands on before anything moves:
// job.submit and plan.preview (and with it the dashboard's form, which shows the call's error) refuse
// a model read in the wrong unit, naming the factor (planner/model_units.hpp), and a nominal that is
// no mesh. The one check of the nominal both calls make before their work.
#pragma once

#include <string>
#include <vector>

#include "daemon/job_request.hpp"
#include "daemon/model_store.hpp"
#include "hal/description/machine_description.hpp"

namespace cmm::daemon {

// Reads the model file for its points (a raw scan's points as they are, never meshed here) and holds
// them, after the request's scale, against the plate's corners in S that the registration gives
// (scan corners, or the given corners' scan side), or against the plate's size when it gives none.
// "units_checked": true or an explicit "scale" lets a model through that would be refused; then
// the notes say what the check found. Returns the notes (what was not checked). Throws what
// ModelStore::resolve throws, at "/model" or "/nominal/model"; invalid_params at "/nominal/model"
// for a nominal that is a point cloud; RpcError model_error, data {"file", "kind": "unreadable"
// ("path" the field), "units" (a factor makes it stand: "factor", "scale" to use) or "off_plate",
// "extent_mm"}; for the nominal the message and data say so ("nominal": true).
// A model longer than the travel box's diagonal is left to the model limits (planner/model_limits.hpp).
std::vector<std::string> check_request_units(const JobRequest& request, const ModelStore& models,
                                             const description::TravelBox& travel_box);

}  // namespace cmm::daemon
