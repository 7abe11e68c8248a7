// See ippdme_proxy.hpp. Plain blocking sockets, one thread per direction: the proxy carries a
// handful of lines a second.
#include "ippdme_proxy.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <stdexcept>

#include <Eigen/Geometry>

namespace cmm::testing {

namespace ipp = hal::ippdme;

namespace {

// Lines go out one by one and each waits for its answer: without this, Nagle's algorithm holds
// every small write for the peer's delayed ACK (40 ms a line).
void no_delay(int fd) {
  const int one = 1;
  ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
}

int listen_loopback(int* port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t length = sizeof a;
  if (fd < 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 || ::listen(fd, 4) != 0 ||
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &length) != 0)
    throw std::runtime_error("IppDmeProxy: cannot listen on loopback");
  *port = ntohs(a.sin_port);
  return fd;
}

int connect_loopback(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  if (fd < 0 || ::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    if (fd >= 0) ::close(fd);
    return -1;
  }
  return fd;
}

// Reads one CRLF- or LF-ended line (without its end) into `line`; false at the end of the stream.
bool read_line(int fd, std::string& buffer, std::string& line) {
  for (;;) {
    if (const auto end = buffer.find('\n'); end != std::string::npos) {
      line = buffer.substr(0, end);
      if (!line.empty() && line.back() == '\r') line.pop_back();
      buffer.erase(0, end + 1);
      return true;
    }
    char chunk[4096];
    const ssize_t n = ::recv(fd, chunk, sizeof chunk, 0);
    if (n <= 0) return false;
    buffer.append(chunk, static_cast<std::size_t>(n));
  }
}

bool write_line(int fd, const std::string& line) {
  const std::string out = line + "\r\n";
  return ::send(fd, out.data(), out.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(out.size());
}

ipp::Term* item(std::vector<ipp::Term>& items, const char* name) {
  for (ipp::Term& t : items)
    if (t.kind == ipp::Term::Kind::call && t.text == name) return &t;
  throw std::runtime_error(std::string("IppDmeProxy: the PtMeas report has no ") + name + "()");
}

void move_point(std::vector<ipp::Term>& items, const hal::Vec3& by) {
  item(items, "X")->args.at(0).number += by.x();
  item(items, "Y")->args.at(0).number += by.y();
  item(items, "Z")->args.at(0).number += by.z();
}

}  // namespace

IppDmeProxy::IppDmeProxy(int server_port) : server_port_(server_port) {
  listener_ = listen_loopback(&port_);
  acceptor_ = std::thread([this] { accept_loop(); });
}

IppDmeProxy::~IppDmeProxy() {
  closing_ = true;
  ::shutdown(listener_, SHUT_RDWR);
  ::close(listener_);
  acceptor_.join();
  std::vector<std::thread> pumps;
  {
    const std::lock_guard lock(mutex_);
    for (int fd : sockets_) ::shutdown(fd, SHUT_RDWR);
    pumps.swap(pumps_);
  }
  for (std::thread& t : pumps) t.join();
  for (int fd : sockets_) ::close(fd);
}

void IppDmeProxy::accept_loop() {
  while (!closing_) {
    const int client = ::accept(listener_, nullptr, nullptr);
    if (client < 0) return;
    const int server = connect_loopback(server_port_);
    if (server < 0) {
      ::close(client);
      continue;
    }
    no_delay(client);
    no_delay(server);
    ++connections_;
    const std::lock_guard lock(mutex_);
    sockets_.push_back(client);
    sockets_.push_back(server);
    pumps_.emplace_back([this, client, server] { client_to_server(client, server); });
    pumps_.emplace_back([this, client, server] { server_to_client(server, client); });
  }
}

void IppDmeProxy::client_to_server(int client, int server) {
  std::string buffer, line;
  while (read_line(client, buffer, line)) {
    {
      const std::lock_guard lock(mutex_);
      if (armed_ && !target_tag_ && line.size() > 6 && line.compare(6, 7, "PtMeas(") == 0) {
        const auto command = ipp::parse_command(line);
        if (const auto* c = std::get_if<ipp::Command>(&command)) {
          target_tag_ = line.substr(0, 5);
          if (const auto ijk = ipp::vector_of(c->args, "IJK")) target_ijk_ = *ijk;
        }
      }
    }
    if (!write_line(server, line)) break;
  }
  ::shutdown(server, SHUT_RDWR);
}

void IppDmeProxy::server_to_client(int server, int client) {
  std::string buffer, line;
  while (read_line(server, buffer, line)) {
    const std::optional<std::string> out = pass(line);
    if (out && !write_line(client, *out)) break;
  }
  ::shutdown(client, SHUT_RDWR);
}

std::optional<std::string> IppDmeProxy::pass(const std::string& line) {
  const std::lock_guard lock(mutex_);
  if (!target_tag_ || line.compare(0, 5, *target_tag_) != 0) return line;
  std::optional<ipp::Reply> reply = ipp::parse_reply(line);
  if (!reply || reply->kind == ipp::ReplyKind::ack) return line;
  const bool done = reply->kind == ipp::ReplyKind::done || reply->kind == ipp::ReplyKind::error;
  std::optional<std::string> out = line;
  if (silence_) {
    out.reset();
  } else if (reply->kind == ipp::ReplyKind::data) {
    (*falsify_)(reply->data, target_ijk_);
    const hal::Vec3 point{*ipp::number_of(reply->data, "X"), *ipp::number_of(reply->data, "Y"),
                          *ipp::number_of(reply->data, "Z")};
    const hal::Vec3 ijk = ipp::vector_of(reply->data, "IJK").value_or(target_ijk_);
    falsified_ = point + ijk * ipp::number_of(reply->data, "ER").value_or(0);
    out = ipp::format_reply(*reply);
  }
  if (done) {
    armed_ = false;
    silence_ = false;
    falsify_.reset();
    target_tag_.reset();
    changed_.notify_all();
  }
  return out;
}

void IppDmeProxy::arm(Falsify falsify) {
  const std::lock_guard lock(mutex_);
  falsify_ = std::move(falsify);
  silence_ = false;
  armed_ = true;
  target_tag_.reset();
  falsified_.reset();
}

void IppDmeProxy::arm_silence() {
  const std::lock_guard lock(mutex_);
  falsify_.reset();
  silence_ = true;
  armed_ = true;
  target_tag_.reset();
  falsified_.reset();
}

std::optional<hal::Vec3> IppDmeProxy::wait_falsified(double timeout_s) {
  std::unique_lock lock(mutex_);
  changed_.wait_for(lock, std::chrono::duration<double>(timeout_s), [&] { return !armed_; });
  return falsified_;
}

IppDmeProxy::Falsify shifted_along(double mm) {
  return [mm](std::vector<ipp::Term>& items, const hal::Vec3& ijk) { move_point(items, ijk * mm); };
}

IppDmeProxy::Falsify shifted_sideways(double mm) {
  return [mm](std::vector<ipp::Term>& items, const hal::Vec3& ijk) {
    const hal::Vec3 across = ijk.unitOrthogonal();
    move_point(items, across * mm);
  };
}

IppDmeProxy::Falsify with_radius(double er) {
  return [er](std::vector<ipp::Term>& items, const hal::Vec3&) { item(items, "ER")->args.at(0).number = er; };
}

}  // namespace cmm::testing
