// plan.preview: plan a job and dry-run its program on an in-process simulator whose part is the
// reference mesh itself, so collisions, travel limits and time show before the real machine moves.
#pragma once

#include <nlohmann/json.hpp>

#include "daemon/daemon_config.hpp"
#include "daemon/model_store.hpp"
#include "geometry/cancellation.hpp"
#include "hal/description/machine_description.hpp"

namespace cmm::daemon {

// `params` is a job request; its registration may be left out (T_M_S = identity, said in the notes)
// and a measure_plate registration is previewed from its rough corners. `info` is the real
// machine's, when it can be read (its tips' qualified radii), else null. Throws RpcError, and
// geometry::Cancelled when `cancel` asks (its client gone, cmmd stopping) between steps or touches.
nlohmann::json preview_plan(const nlohmann::json& params, const DaemonConfig& config, const ModelStore& models,
                            const description::MachineDescription* info, const geometry::CancelCheck& cancel = {});

}  // namespace cmm::daemon
