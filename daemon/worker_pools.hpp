// The threads behind RpcServer's slow methods (json_rpc.hpp, Work): one pool per role for calls
// that wait on the machine or the disk, and one for planning, which admits only so many previews
// at once. Observers flooding previews or status calls thus never hold the operator's workers.
#pragma once

#include <atomic>
#include <cstddef>

#include <asio/thread_pool.hpp>

#include "daemon/json_rpc.hpp"

namespace cmm::daemon {

struct WorkerCounts {
  int operator_threads = 4;     // blocking calls of operator connections
  int observer_threads = 2;     // blocking calls of observer (and role none) connections
  int planning_threads = 1;     // plan.preview from anyone
  int max_queued_planning = 4;  // previews waiting for a planning thread; beyond, server_busy
  bool operator==(const WorkerCounts&) const = default;
};

class WorkerPools {
 public:
  explicit WorkerPools(const WorkerCounts& counts);

  // Where a message of this work runs for a caller of this role (not for Work::quick).
  asio::thread_pool& pool(Work work, Role role);
  // Admits `requests` more planning requests unless the planning threads and their queue are
  // full; each admitted one is released once answered.
  bool admit_planning(std::size_t requests);
  void release_planning(std::size_t requests);

  // Drops what waits, lets what runs finish, joins every thread.
  void stop_and_join();

 private:
  asio::thread_pool operators_, observers_, planning_;
  std::size_t planning_capacity_;
  std::atomic<std::size_t> planning_admitted_{0};
};

}  // namespace cmm::daemon
