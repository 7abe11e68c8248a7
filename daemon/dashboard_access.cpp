// The dashboard token, its file, the dashboard's URL and server.dashboard.
#include "daemon/dashboard_access.hpp"

#include <fcntl.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdio>
#include <stdexcept>
#include <system_error>

#include <spdlog/spdlog.h>

namespace cmm::daemon {

namespace fs = std::filesystem;

namespace {

std::string errno_text() { return std::error_code(errno, std::generic_category()).message(); }

// Written beside the file and renamed over it: a reader never sees half a token, and the file is
// 0600 from its creation (umask cannot widen it).
void write_secret_file(const fs::path& file, const std::string& text) {
  const fs::path temporary = file.string() + ".tmp";
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) throw std::runtime_error(std::string("cannot write ").append(temporary.string()).append(": ").append(errno_text()));
  const bool written = ::fchmod(fd, 0600) == 0 && ::write(fd, text.data(), text.size()) == static_cast<ssize_t>(text.size()) &&
                       ::fsync(fd) == 0;
  const std::string why = written ? std::string() : errno_text();
  ::close(fd);
  if (!written || ::rename(temporary.c_str(), file.c_str()) != 0) {
    const std::string reason = written ? errno_text() : why;
    ::unlink(temporary.c_str());
    throw std::runtime_error("cannot write " + file.string() + ": " + reason);
  }
}

}  // namespace

std::string random_token() {
  std::array<unsigned char, 32> bytes{};
  std::size_t got = 0;
  while (got < bytes.size()) {
    const ssize_t n = ::getrandom(bytes.data() + got, bytes.size() - got, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw std::runtime_error(std::string("cannot make the dashboard token: getrandom: ").append(errno_text()));
    got += static_cast<std::size_t>(n);
  }
  std::string hex;
  for (const unsigned char b : bytes) {
    char digits[3];
    std::snprintf(digits, sizeof digits, "%02x", b);
    hex += digits;
  }
  return hex;
}

std::string set_up_dashboard_token(TokenBook& tokens, const fs::path& file) {
  if (tokens.any_configured()) {
    std::error_code ignored;
    if (fs::remove(file, ignored)) spdlog::info("removed {}: cmmd.json configures tokens, the dashboard asks for one", file.string());
    return {};
  }
  std::string token = random_token();
  write_secret_file(file, token + "\n");
  tokens.add_generated({token, Role::operator_});
  return token;
}

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
