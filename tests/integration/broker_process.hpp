// A real mosquitto on loopback for the fleet tests: users with passwords and the documented ACL
// (config/mosquitto/cmmd.acl), on a port that stays the same across kill9() and start().
#pragma once

#include <filesystem>
#include <map>
#include <memory>
#include <string>

#include "child_process.hpp"

namespace cmm::testing {

struct BrokerOptions {
  // The listener takes TLS only, with a certificate for 127.0.0.1 signed by the CA of tls_ca().
  bool tls = false;
  // The persistence and autosave lines of config/mosquitto/mosquitto.conf, the database in the
  // folder. Without: nothing is saved, and each start() begins with no retained message at all.
  bool shipped_persistence = false;
};

class BrokerProcess {
 public:
  // users: name → password; the ACL file is used as docs/fleet.md documents it.
  BrokerProcess(std::filesystem::path folder, const std::map<std::string, std::string>& users,
                BrokerOptions options = {});
  void start();  // returns once it accepts connections
  void kill9();
  int port() const { return port_; }
  std::filesystem::path tls_ca() const { return folder_ / "ca.crt"; }

 private:
  std::filesystem::path folder_;
  int port_ = 0;
  std::unique_ptr<ChildProcess> process_;
};

// A CA (ca.crt, ca.key) in `folder` and a certificate for 127.0.0.1 and localhost signed by it
// (`name`.crt, `name`.key), made with the openssl command.
void make_test_certificates(const std::filesystem::path& folder, const std::string& name);

// A port nobody listens on now (bound and closed).
int free_tcp_port();

}  // namespace cmm::testing
