// The worker pools requests run on, one per role and one for planning, each with its queue.
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
      planning_slots_(at_least_one(counts.planning_threads) + static_cast<std::size_t>(std::max(0, counts.max_queued_planning))),
      waiting_bytes_(counts.max_waiting_bytes) {}

asio::thread_pool& WorkerPools::pool(Work work, Role role) {
  if (work == Work::planning) return planning_;
  return role == Role::operator_ ? operators_ : observers_;
}

std::optional<std::string> WorkerPools::admit(Work work, std::size_t requests, std::size_t bytes) {
  if (work == Work::planning && !planning_slots_.take(requests))
    return "every planning worker is busy and their queue is full: try again later";
  if (!waiting_bytes_.take(bytes)) {
    if (work == Work::planning) planning_slots_.give(requests);
    return "too many requests wait for the workers: try again later";
  }
  return std::nullopt;
}

void WorkerPools::release(Work work, std::size_t requests, std::size_t bytes) {
  if (work == Work::planning) planning_slots_.give(requests);
  waiting_bytes_.give(bytes);
}

void WorkerPools::stop_and_join() {
  for (asio::thread_pool* pool : {&operators_, &observers_, &planning_}) pool->stop();
  for (asio::thread_pool* pool : {&operators_, &observers_, &planning_}) pool->join();
}

}  // namespace cmm::daemon
