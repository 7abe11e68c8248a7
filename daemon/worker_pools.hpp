// The threads behind RpcServer's slow methods (json_rpc.hpp, Work): one pool per role for calls
// that wait on the machine or the disk, and one for planning, which admits only so many previews
// at once. Observers flooding previews or status calls thus never hold the operator's workers.
#pragma once

#include <cstddef>
#include <optional>
#include <string>

#include <asio/thread_pool.hpp>

#include "daemon/byte_budget.hpp"
#include "daemon/client/json_rpc.hpp"
#include "daemon/worker_counts.hpp"

namespace cmm::daemon {

class WorkerPools {
 public:
  explicit WorkerPools(const WorkerCounts& counts);

  // Where a message of this work runs for a caller of this role (not for Work::quick).
  asio::thread_pool& pool(Work work, Role role);
  // Admits a message of `requests` requests and `bytes` of text, or says why not (the planning
  // threads and their queue are full, or too much request text waits); release() once answered.
  std::optional<std::string> admit(Work work, std::size_t requests, std::size_t bytes);
  void release(Work work, std::size_t requests, std::size_t bytes);

  // Drops what waits, lets what runs finish, joins every thread.
  void stop_and_join();

 private:
  asio::thread_pool operators_, observers_, planning_;
  ByteBudget planning_slots_;  // planning requests running or waiting, one "byte" each
  ByteBudget waiting_bytes_;
};

}  // namespace cmm::daemon
