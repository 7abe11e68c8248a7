// The Host and Origin rules of the dashboard's server.
#include "daemon/host_origin_check.hpp"

#include <arpa/inet.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <optional>

namespace cmm::daemon {

namespace {

std::string lower(std::string_view text) {
  std::string out(text);
  std::transform(out.begin(), out.end(), out.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return out;
}

struct HostPort {
  std::string host;  // lower case, an IPv6 address without its brackets
  int port = 80;  // a Host header without one
};

// "Name:7621", "[::1]:7621", "127.0.0.1" → its parts; nullopt when malformed.
std::optional<HostPort> split_host(std::string_view text) {
  HostPort out;
  std::string_view name = text, port;
  bool has_port = false;
  if (!text.empty() && text.front() == '[') {
    const std::size_t close = text.find(']');
    if (close == std::string_view::npos) return std::nullopt;
    name = text.substr(1, close - 1);
    const std::string_view rest = text.substr(close + 1);
    if (!rest.empty() && rest.front() != ':') return std::nullopt;
    has_port = !rest.empty();
    if (has_port) port = rest.substr(1);
  } else if (const std::size_t colon = text.find(':'); colon != std::string_view::npos) {
    name = text.substr(0, colon);
    port = text.substr(colon + 1);
    has_port = true;
  }
  out.host = lower(name);
  if (out.host.empty()) return std::nullopt;
  if (has_port) {
    const auto [end, ec] = std::from_chars(port.data(), port.data() + port.size(), out.port);
    if (port.empty() || ec != std::errc() || end != port.data() + port.size() || out.port < 0 || out.port > 65535)
      return std::nullopt;
  }
  return out;
}

bool is_ipv4(const std::string& host, in_addr* address = nullptr) {
  in_addr a{};
  const bool ok = inet_pton(AF_INET, host.c_str(), &a) == 1;
  if (address != nullptr) *address = a;
  return ok;
}

bool is_ipv6(const std::string& host) {
  in6_addr a{};
  return inet_pton(AF_INET6, host.c_str(), &a) == 1;
}

bool is_loopback(const std::string& host) {
  in_addr v4{};
  if (is_ipv4(host, &v4)) return (ntohl(v4.s_addr) >> 24) == 127;
  in6_addr v6{};
  return inet_pton(AF_INET6, host.c_str(), &v6) == 1 && IN6_IS_ADDR_LOOPBACK(&v6);
}

// "http://name:port/" → "http://name:port": how browsers write an Origin.
std::string normalized_origin(std::string_view origin) {
  std::string out = lower(origin);
  while (!out.empty() && out.back() == '/') out.pop_back();
  return out;
}

}  // namespace

bool host_allowed(std::string_view host, const HostRules& rules) {
  const std::optional<HostPort> h = split_host(host);
  if (!h) return false;
  // An allowed origin's host[:port] as browsers write both headers (a default port left out), e.g.
  // a reverse proxy's name, whatever our own port.
  for (const std::string& origin : rules.allowed_origins) {
    const std::string o = normalized_origin(origin);
    if (const std::size_t scheme = o.find("://"); scheme != std::string::npos && o.substr(scheme + 3) == lower(host)) return true;
  }
  if (h->port != rules.port) return false;
  if (h->host == "localhost" || is_loopback(h->host)) return true;
  const std::string bind = lower(rules.bind);
  if (h->host == bind) return true;
  return (bind == "0.0.0.0" || bind == "::") && (is_ipv4(h->host) || is_ipv6(h->host));
}

bool origin_allowed(std::string_view origin, std::string_view host, const HostRules& rules) {
  const std::string o = normalized_origin(origin);
  if (!host.empty() && o == std::string("http://").append(lower(host))) return true;
  return std::any_of(rules.allowed_origins.begin(), rules.allowed_origins.end(),
                     [&](const std::string& allowed) { return normalized_origin(allowed) == o; });
}

}  // namespace cmm::daemon
