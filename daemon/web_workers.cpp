// WebWorkers: WorkerPools, reached without including Asio.
#include "daemon/web_workers.hpp"

#include <asio/post.hpp>

#include "daemon/worker_pools.hpp"

namespace cmm::daemon {

WebWorkers::WebWorkers(const WorkerCounts& counts) : pools_(std::make_unique<WorkerPools>(counts)) {}

WebWorkers::~WebWorkers() = default;

std::optional<std::string> WebWorkers::admit(Work work, std::size_t requests, std::size_t bytes) {
  return pools_->admit(work, requests, bytes);
}

void WebWorkers::release(Work work, std::size_t requests, std::size_t bytes) { pools_->release(work, requests, bytes); }

void WebWorkers::run(Work work, Role role, std::function<void()> task) { asio::post(pools_->pool(work, role), std::move(task)); }

void WebWorkers::stop_and_join() { pools_->stop_and_join(); }

}  // namespace cmm::daemon
