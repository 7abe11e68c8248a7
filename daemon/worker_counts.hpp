// How many threads run the slow JSON-RPC methods and how much may wait for them (WorkerPools), in a
// header of its own: the dashboard's server reads it where standalone Asio must not be included.
#pragma once

#include <cstddef>

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

}  // namespace cmm::daemon
