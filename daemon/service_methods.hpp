// The application methods of docs/api.md (machine.*, model.*, plan.*, registration.*, job.*) on a
// dispatcher: each checks its params, calls the part of cmmd that does the work, and says what role it needs.
#pragma once

#include <string>

#include "daemon/daemon_config.hpp"
#include "daemon/job_manager.hpp"
#include "daemon/client/json_rpc.hpp"
#include "daemon/machine_link.hpp"
#include "daemon/model_store.hpp"

namespace cmm::daemon {

struct Service {
  const DaemonConfig& config;
  MachineLink& machine;
  ModelStore& models;
  JobManager& jobs;
  std::string version;
};

// Adds server.info and every application method; the transport adds server.auth and server.subscribe.
void add_service_methods(RpcDispatcher& dispatcher, Service& service);

}  // namespace cmm::daemon
