// See worker_pools.hpp.
#include "daemon/worker_pools.hpp"

#include <algorithm>

namespace cmm::daemon {

namespace {
std::size_t at_least_one(int n) { return static_cast<std::size_t>(std::max(1, n)); }
}  // namespace

WorkerPools::WorkerPools(const WorkerCounts& counts)
    : operators_(at_least_one(counts.operator_threads)),
      observers_(at_least_one(counts.observer_threads)),
      planning_(at_least_one(counts.planning_threads)),
      planning_capacity_(at_least_one(counts.planning_threads) + static_cast<std::size_t>(std::max(0, counts.max_queued_planning))) {}

asio::thread_pool& WorkerPools::pool(Work work, Role role) {
  if (work == Work::planning) return planning_;
  return role == Role::operator_ ? operators_ : observers_;
}

bool WorkerPools::admit_planning(std::size_t requests) {
  std::size_t admitted = planning_admitted_.load();
  do {
    if (admitted + requests > planning_capacity_) return false;
  } while (!planning_admitted_.compare_exchange_weak(admitted, admitted + requests));
  return true;
}

void WorkerPools::release_planning(std::size_t requests) { planning_admitted_ -= requests; }

void WorkerPools::stop_and_join() {
  for (asio::thread_pool* pool : {&operators_, &observers_, &planning_}) pool->stop();
  for (asio::thread_pool* pool : {&operators_, &observers_, &planning_}) pool->join();
}

}  // namespace cmm::daemon
