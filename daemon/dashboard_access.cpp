// The dashboard's URL and server.dashboard.
#include "daemon/dashboard_access.hpp"

#include <string>

namespace cmm::daemon {

std::string dashboard_url(const std::string& bind, int port, const std::string& token) {
  std::string host = bind;
  if (host.empty() || host == "0.0.0.0" || host == "::") host = "127.0.0.1";
  else if (host.find(':') != std::string::npos) host = "[" + host + "]";
  std::string url = "http://";
  url.append(host).append(":").append(std::to_string(port)).append("/");
  if (!token.empty()) url.append("#token=").append(token);
  return url;
}

void DashboardLink::set(std::string url) {
  std::lock_guard lock(mutex_);
  url_ = std::move(url);
}

std::optional<std::string> DashboardLink::url() const {
  std::lock_guard lock(mutex_);
  return url_;
}

void add_dashboard_method(RpcDispatcher& dispatcher, const DashboardLink& link) {
  dispatcher.add("server.dashboard", {Role::operator_, Work::quick, [&link](const nlohmann::json&, RpcContext&) {
                   const std::optional<std::string> url = link.url();
                   if (!url)
                     throw RpcError(rpc_code::invalid_state, "cmmd serves no dashboard: http.enabled is false in cmmd.json");
                   return nlohmann::json{{"url", *url}};
                 }});
}

}  // namespace cmm::daemon
