// A hostile controller for the driver's tests: a TCP proxy between cmmd's I++ DME client and
// cmm-sim's I++ server that passes every line on, and once armed falsifies (or swallows) the report
// of the next PtMeas: what a controller nobody here wrote might send.
#pragma once

#include <atomic>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "hal/ippdme_protocol.hpp"

namespace cmm::testing {

class IppDmeProxy {
 public:
  // How the next PtMeas's report is falsified: it gets the report's items and the command's IJK
  // (the search runs along −IJK) and changes the items in place.
  using Falsify = std::function<void(std::vector<hal::ippdme::Term>& items, const hal::Vec3& ijk)>;

  explicit IppDmeProxy(int server_port);  // listens on 127.0.0.1, an ephemeral port
  ~IppDmeProxy();
  IppDmeProxy(const IppDmeProxy&) = delete;
  IppDmeProxy& operator=(const IppDmeProxy&) = delete;

  int port() const { return port_; }
  int connections() const { return connections_.load(); }

  // The next PtMeas's data line goes through `falsify`; with `silence` its data and completion are
  // swallowed instead (the acknowledgement passes: the controller took the command and says nothing).
  void arm(Falsify falsify);
  void arm_silence();
  // The ball centre the falsified report claims (its X, Y, Z + IJK·ER), once the armed PtMeas was
  // answered; std::nullopt until then (and for silence).
  std::optional<hal::Vec3> wait_falsified(double timeout_s);

 private:
  void accept_loop();
  void serve(int client);
  void client_to_server(int client, int server);
  void server_to_client(int server, int client);
  std::optional<std::string> pass(const std::string& line);  // server → client; nullopt: swallowed

  int listener_ = -1;
  int port_ = 0;
  int server_port_ = 0;
  std::atomic<int> connections_{0};
  std::atomic<bool> closing_{false};
  std::thread acceptor_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<std::thread> pumps_;
  std::vector<int> sockets_;
  std::optional<Falsify> falsify_;
  bool silence_ = false;
  bool armed_ = false;
  std::optional<std::string> target_tag_;  // the armed PtMeas's tag once it was sent
  hal::Vec3 target_ijk_ = hal::Vec3::UnitZ();
  std::optional<hal::Vec3> falsified_;
};

// Falsifications of a PtMeas report ({X, Y, Z, IJK, ER}).
IppDmeProxy::Falsify shifted_along(double mm);     // the point moved along the search line
IppDmeProxy::Falsify shifted_sideways(double mm);  // moved across it
IppDmeProxy::Falsify with_radius(double er);       // ER replaced

}  // namespace cmm::testing
