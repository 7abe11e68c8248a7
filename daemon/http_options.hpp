// cmmd.json's "http" block: the dashboard's HTTP and WebSocket server (WebServer), which listens on
// server.tcp_bind and shares the server block's limits and tokens.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace cmm::daemon {

struct HttpOptions {
  bool enabled = true;
  int port = 7621;                           // 0: ephemeral (see WebServer::port)
  // Origins besides http://<the request's Host> whose pages may open the WebSocket, e.g.
  // "http://station.example:7621"; their host:port is also accepted as a Host header.
  std::vector<std::string> allowed_origins;
  std::filesystem::path web_root;            // the dashboard's files (static_files.hpp: default_web_root)
  bool operator==(const HttpOptions&) const = default;
};

}  // namespace cmm::daemon
