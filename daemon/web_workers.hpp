// The dashboard server's WorkerPools behind a header free of standalone Asio: Beast brings
// Boost.Asio, and the two Asios cannot be included in one translation unit.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "daemon/client/json_rpc.hpp"
#include "daemon/worker_counts.hpp"

namespace cmm::daemon {

class WorkerPools;

class WebWorkers {
 public:
  explicit WebWorkers(const WorkerCounts& counts);
  ~WebWorkers();

  // As WorkerPools::admit and release.
  std::optional<std::string> admit(Work work, std::size_t requests, std::size_t bytes);
  void release(Work work, std::size_t requests, std::size_t bytes);
  // Runs `task` on the pool of this work for a caller of this role.
  void run(Work work, Role role, std::function<void()> task);
  void stop_and_join();  // drops what waits, lets what runs finish

 private:
  std::unique_ptr<WorkerPools> pools_;
};

}  // namespace cmm::daemon
