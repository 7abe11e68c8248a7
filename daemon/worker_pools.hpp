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

namespace cmm::daemon {

struct WorkerCounts {
  int operator_threads = 4;     // blocking calls of operator connections
  int observer_threads = 2;     // blocking calls of observer (and role none) connections
  int planning_threads = 1;     // plan.preview from anyone
  int max_queued_planning = 4;  // previews waiting for a planning thread; beyond, server_busy
  // Request text waiting for or on the workers, all connections together (a line's JSON value takes
  // up to 16 times its text); beyond, server_busy.
  std::size_t max_waiting_bytes = 32u << 20;
  bool operator==(const WorkerCounts&) const = default;
};

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
