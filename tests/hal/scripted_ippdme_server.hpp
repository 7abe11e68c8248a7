// A scripted I++ DME server for the client driver's tests: a loopback TCP listener that answers
// each command line with what the test's script says (a plain, well-behaved server by default),
// records every line it received, and can push unsolicited lines or drop the connection (errors as
// I++ DME 1.4.3 answers them: `&`, `!`, `%`; a script decides what else to leave unanswered). The real
// server (cmm-sim --ippdme) is tested on its own and in the conformance suite.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "hal/ippdme_protocol.hpp"

namespace cmm::testing {

class ScriptedIppDmeServer {
 public:
  // What to answer to a command: the lines after its tag ("&", "# X(1)", "%", "! Error(...)"); an
  // empty optional falls through to the default answer.
  using Script = std::function<std::optional<std::vector<std::string>>(const hal::ippdme::Command&)>;

  ScriptedIppDmeServer() {
    listener_ = ::socket(AF_INET, SOCK_STREAM, 0);
    int one = 1;
    ::setsockopt(listener_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ::bind(listener_, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
    ::listen(listener_, 4);
    socklen_t len = sizeof addr;
    ::getsockname(listener_, reinterpret_cast<sockaddr*>(&addr), &len);
    port_ = ntohs(addr.sin_port);
    thread_ = std::thread([this] { serve(); });
  }
  ~ScriptedIppDmeServer() {
    running_ = false;
    if (thread_.joinable()) thread_.join();
    drop();
    ::close(listener_);
  }

  int port() const { return port_; }
  void script(Script s) {
    std::lock_guard lock(mutex_);
    script_ = std::move(s);
  }
  // Every command line received, in order, and the commands of one method.
  std::vector<std::string> received() const {
    std::lock_guard lock(mutex_);
    return received_;
  }
  int count(const std::string& method) const {
    int n = 0;
    for (const auto& line : received())
      if (line.find(" " + method + "(") == 5) ++n;
    return n;
  }
  void push(const std::string& line) { write(line); }  // unsolicited: "E0000 ! Error(3, 0500, ...)"
  void drop() {
    std::lock_guard lock(write_mutex_);
    if (client_ >= 0) ::close(client_);
    client_ = -1;
  }
  hal::Vec3 position() const {
    std::lock_guard lock(mutex_);
    return position_;
  }
  std::map<std::string, double> props() const {
    std::lock_guard lock(mutex_);
    return props_;
  }
  // Bounds the default SetProp clamps to, with the 0504 warning real servers send.
  void clamp(const std::string& prop, double max) {
    std::lock_guard lock(mutex_);
    clamps_[prop] = max;
  }

 private:
  void serve() {
    std::string partial;
    while (running_) {
      int fd = -1;
      {
        std::lock_guard lock(write_mutex_);
        fd = client_;
      }
      if (fd < 0) {
        pollfd p{listener_, POLLIN, 0};
        if (::poll(&p, 1, 10) > 0) {
          const int c = ::accept(listener_, nullptr, nullptr);
          int one = 1;  // each line goes out at once, as a controller's does: no Nagle delay
          ::setsockopt(c, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
          std::lock_guard lock(write_mutex_);
          client_ = c;
          partial.clear();
        }
        continue;
      }
      pollfd p{fd, POLLIN, 0};
      if (::poll(&p, 1, 10) <= 0) continue;
      char buffer[4096];
      const ssize_t n = ::read(fd, buffer, sizeof buffer);
      if (n <= 0) {
        drop();
        continue;
      }
      for (ssize_t i = 0; i < n; ++i) {
        if (buffer[i] == '\n') {
          if (!partial.empty() && partial.back() == '\r') partial.pop_back();
          answer(partial);
          partial.clear();
        } else {
          partial.push_back(buffer[i]);
        }
      }
    }
  }

  void write(const std::string& line) {
    std::lock_guard lock(write_mutex_);
    if (client_ < 0) return;
    const std::string bytes = line + "\r\n";
    (void)!::send(client_, bytes.data(), bytes.size(), MSG_NOSIGNAL);
  }

  void answer(const std::string& line) {
    namespace ipp = hal::ippdme;
    Script script;
    {
      std::lock_guard lock(mutex_);
      received_.push_back(line);
      script = script_;
    }
    auto parsed = ipp::parse_command(line);
    if (auto* e = std::get_if<ipp::LineError>(&parsed)) {
      write("E0000 ! Error(2, 0005, \"\", \"" + e->text + "\")");
      return;
    }
    const auto& c = std::get<ipp::Command>(parsed);
    const std::string tag = ipp::format_tag(c.tag);
    std::optional<std::vector<std::string>> lines;
    if (script) lines = script(c);
    if (!lines) lines = defaults(c);
    for (const auto& l : *lines) {
      if (l == "DROP") return drop();  // the connection goes, mid-transaction
      write(tag + " " + l);
    }
  }

  std::vector<std::string> defaults(const hal::ippdme::Command& c) {
    namespace ipp = hal::ippdme;
    std::lock_guard lock(mutex_);
    auto axes = [&](const std::vector<ipp::Term>& args) {
      if (auto x = ipp::number_of(args, "X")) position_.x() = *x;
      if (auto y = ipp::number_of(args, "Y")) position_.y() = *y;
      if (auto z = ipp::number_of(args, "Z")) position_.z() = *z;
    };
    auto xyz = [&] {
      return "X(" + ipp::format_number(position_.x()) + "), Y(" + ipp::format_number(position_.y()) + "), Z(" +
             ipp::format_number(position_.z()) + ")";
    };
    if (c.name == "GetDMEVersion") return {"&", "# DMEVersion(\"1.4.3\")", "%"};
    if (c.name == "EnumTools") return {"&", "# \"T1\"", "# \"T2\"", "%"};
    if (c.name == "IsHomed") return {"&", "# IsHomed(1)", "%"};
    // §6.3.2.7: the daemon's command completes at once, its reports follow under its tag.
    if (c.name == "OnMoveReportE") return {"&", "%"};
    if (c.name == "StopAllDaemons") return {"&", "! Error(1, 0512, StopAllDaemons, \"No daemons are active\")", "%"};
    if (c.name == "Get") {
      // A real controller knows no Clock(): cmm-sim's extension is refused.
      if (ipp::find_call(c.args, "Clock")) return {"&", "! Error(2, 0502, Get, \"Incorrect arguments\")"};
      return {"&", "# " + xyz(), "%"};
    }
    if (c.name == "GoTo") {
      axes(c.args);
      return {"&", "%"};
    }
    if (c.name == "SetProp") {
      std::vector<std::string> out = {"&"};
      for (const auto& t : c.args) {
        if (t.args.empty()) continue;
        double v = t.args[0].number;
        if (auto it = clamps_.find(t.text); it != clamps_.end() && v > it->second) {
          out.push_back("! Error(1, 0504, SetProp, \"" + t.text + " out of range: clamped\")");
          v = it->second;
        }
        props_[t.text] = v;
      }
      out.push_back("%");
      return out;
    }
    if (c.name == "GetProp") {
      std::string items;
      for (const auto& t : c.args) {
        const auto it = props_.find(t.text);
        items += (items.empty() ? "" : ", ") + t.text + "(" + ipp::format_number(it == props_.end() ? 1.0 : it->second) + ")";
      }
      return {"&", "# " + items, "%"};
    }
    if (c.name == "PtMeas") {
      // The nominal point itself, touched with a 1 mm ball along the IJK given.
      const hal::Vec3 n = ipp::vector_of(c.args, "IJK").value_or(hal::Vec3::UnitZ());
      axes(c.args);
      const hal::Vec3 surface = position_;
      position_ = surface + n * (1.0 + props_["Tool.PtMeasPar.Retract"]);
      return {"&",
              "# X(" + ipp::format_number(surface.x()) + "), Y(" + ipp::format_number(surface.y()) + "), Z(" +
                  ipp::format_number(surface.z()) + "), IJK(" + ipp::format_number(n.x()) + ", " + ipp::format_number(n.y()) +
                  ", " + ipp::format_number(n.z()) + "), ER(1.000000000)",
              "%"};
    }
    return {"&", "%"};  // StartSession, ChangeTool, SetCoordSystem, OnPtMeasReport, Home, ClearAllErrors, ...
  }

  int listener_ = -1, client_ = -1, port_ = 0;
  std::atomic<bool> running_{true};
  std::thread thread_;
  mutable std::mutex mutex_;
  std::mutex write_mutex_;
  Script script_;
  std::vector<std::string> received_;
  hal::Vec3 position_ = hal::Vec3(100, 100, 100);
  std::map<std::string, double> props_;
  std::map<std::string, double> clamps_;
};

}  // namespace cmm::testing
