// BrokerProcess: mosquitto -c with a config of the test's, its password file made by mosquitto_passwd.
#include "broker_process.hpp"

#include <pwd.h>
#include <unistd.h>

#include <csignal>
#include <fstream>
#include <stdexcept>
#include <thread>

#include <asio/io_context.hpp>
#include <asio/ip/tcp.hpp>

#include "tests/tools/run_command.hpp"

namespace cmm::testing {

int free_tcp_port() {
  asio::io_context io;
  asio::ip::tcp::acceptor acceptor(io, asio::ip::tcp::endpoint(asio::ip::make_address("127.0.0.1"), 0));
  return acceptor.local_endpoint().port();
}

void make_test_certificates(const std::filesystem::path& folder, const std::string& name) {
  std::filesystem::create_directories(folder);
  const std::string d = folder.string() + "/";
  std::ofstream(folder / "san.ext") << "subjectAltName=IP:127.0.0.1,DNS:localhost\n";
  for (const std::string& command :
       {"openssl req -x509 -newkey rsa:2048 -nodes -days 2 -subj /CN=cmmd-test-ca -keyout " + d + "ca.key -out " + d + "ca.crt",
        "openssl req -newkey rsa:2048 -nodes -subj /CN=localhost -keyout " + d + name + ".key -out " + d + name + ".csr",
        "openssl x509 -req -days 2 -in " + d + name + ".csr -CA " + d + "ca.crt -CAkey " + d + "ca.key -CAcreateserial -out " +
            d + name + ".crt -extfile " + d + "san.ext"}) {
    const auto r = cmm::test::run_command(command + " 2>&1");
    if (r.exit_code != 0) throw std::runtime_error(command + ": " + r.output);
  }
}

namespace {

// The lines of the shipped broker config that decide what reaches its disk, and when.
std::string shipped_persistence_lines() {
  const std::filesystem::path shipped = CMMD_SOURCE_DIR "/config/mosquitto/mosquitto.conf";
  std::ifstream in(shipped);
  if (!in) throw std::runtime_error("cannot read " + shipped.string());
  std::string lines;
  for (std::string line; std::getline(in, line);)
    if (line.starts_with("persistence ") || line.starts_with("autosave_")) lines += line + "\n";
  return lines;
}

}  // namespace

BrokerProcess::BrokerProcess(std::filesystem::path folder, const std::map<std::string, std::string>& users,
                             BrokerOptions options)
    : folder_(std::move(folder)), port_(free_tcp_port()) {
  std::filesystem::create_directories(folder_);
  const std::filesystem::path passwords = folder_ / "passwd";
  std::ofstream(passwords).close();
  for (const auto& [user, password] : users) {
    const auto r = cmm::test::run_command("mosquitto_passwd -b " + passwords.string() + " " + user + " " + password);
    if (r.exit_code != 0) throw std::runtime_error("mosquitto_passwd: " + r.output);
  }
  std::ofstream(folder_ / "mosquitto.conf") << "per_listener_settings false\n"
                                            << "allow_anonymous false\n"
                                            << "password_file " << passwords.string() << "\n"
                                            << "acl_file " << CMMD_SOURCE_DIR << "/config/mosquitto/cmmd.acl\n"
                                            << "listener " << port_ << " 127.0.0.1\n"
                                            << (options.shipped_persistence
                                                    ? shipped_persistence_lines() + "persistence_location " +
                                                          folder_.string() + "/\n"
                                                    : "persistence false\n")
                                            << "max_packet_size 8388608\n"
                                            << "log_dest file " << (folder_ / "mosquitto.log").string() << "\n"
                                            // Started as root it would become "mosquitto", who cannot write here.
                                            << "user " << getpwuid(geteuid())->pw_name << "\n";
  if (options.tls) {
    make_test_certificates(folder_, "broker");
    std::ofstream(folder_ / "mosquitto.conf", std::ios::app) << "cafile " << tls_ca().string() << "\n"
                                                              << "certfile " << (folder_ / "broker.crt").string() << "\n"
                                                              << "keyfile " << (folder_ / "broker.key").string() << "\n";
  }
}

void BrokerProcess::start() {
  process_ = std::make_unique<ChildProcess>(
      std::vector<std::string>{"/usr/sbin/mosquitto", "-c", (folder_ / "mosquitto.conf").string()});
  for (int i = 0; i < 500; ++i) {
    asio::io_context io;
    asio::ip::tcp::socket socket(io);
    asio::error_code ec;
    socket.connect(asio::ip::tcp::endpoint(asio::ip::make_address("127.0.0.1"), static_cast<unsigned short>(port_)), ec);
    if (!ec) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  throw std::runtime_error("mosquitto did not listen on port " + std::to_string(port_) + " within 5 s");
}

void BrokerProcess::kill9() {
  if (!process_) return;
  process_->signal(SIGKILL);
  process_->wait();
  process_.reset();
}

}  // namespace cmm::testing
