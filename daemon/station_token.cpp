// The station token's file: read, made, rotated.
#include "daemon/station_token.hpp"

#include <sys/random.h>

#include <array>
#include <cerrno>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <system_error>

#include <spdlog/spdlog.h>

#include "geometry/atomic_file.hpp"
#include "geometry/file_error.hpp"

namespace cmm::daemon {

namespace fs = std::filesystem;

namespace {

bool is_token(const std::string& text) {
  return text.size() == 64 && text.find_first_not_of("0123456789abcdef") == std::string::npos;
}

void write_token(const fs::path& file, const std::string& token) {
  try {
    geometry::write_atomically(file, token + "\n", 0640);
  } catch (const geometry::FileError& e) {
    throw std::runtime_error(std::string("cannot write the station token: ").append(e.what()));
  }
}

}  // namespace

std::string random_token() {
  std::array<unsigned char, 32> bytes{};
  std::size_t got = 0;
  while (got < bytes.size()) {
    const ssize_t n = ::getrandom(bytes.data() + got, bytes.size() - got, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0)
      throw std::runtime_error("cannot make a token: getrandom: " + std::error_code(errno, std::generic_category()).message());
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

StationToken::StationToken(TokenBook& tokens, fs::path file) : tokens_(tokens), file_(std::move(file)) {}

std::string StationToken::set_up() {
  std::lock_guard lock(mutex_);
  std::error_code ec;
  if (tokens_.any_configured()) {
    if (fs::remove(file_, ec)) spdlog::info("removed {}: cmmd.json configures tokens, operators use those", file_.string());
    return {};
  }
  std::string kept;
  if (fs::exists(file_, ec)) {
    std::ifstream in(file_);
    if (!in) throw std::runtime_error("cannot read the station token " + file_.string());
    std::getline(in, kept);
    if (!is_token(kept)) {
      spdlog::warn("{} does not hold a token cmmd made (64 hex digits); making a new one", file_.string());
      kept.clear();
    }
  }
  if (kept.empty()) {
    kept = random_token();
    write_token(file_, kept);
    spdlog::info("made the station's operator token in {}", file_.string());
  } else {
    fs::permissions(file_, fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read, ec);  // 0640, as made
  }
  token_ = kept;
  tokens_.set_station_token(kept);
  return kept;
}

std::string StationToken::rotate() {
  std::lock_guard lock(mutex_);
  // A station token made at start stays in use after SIGHUP brings tokens: it can be rotated still.
  if (token_.empty()) throw std::logic_error("cmmd.json configured tokens at start: there is no station token to rotate");
  std::string next = random_token();
  write_token(file_, next);  // on disk first: a failure leaves the old token valid everywhere
  token_ = next;
  tokens_.set_station_token(next);
  spdlog::warn("the station's operator token was rotated ({}): the old one is refused from now on", file_.string());
  return next;
}

std::string StationToken::current() const {
  std::lock_guard lock(mutex_);
  return token_;
}

void add_station_token_method(RpcDispatcher& dispatcher, StationToken& token,
                              std::function<void(const std::string&)> on_rotated) {
  dispatcher.add("server.rotate_token",
                 {Role::operator_, Work::blocking, [&token, on_rotated](const nlohmann::json&, RpcContext& ctx) {
                    std::string next;
                    try {
                      next = token.rotate();
                    } catch (const std::logic_error& e) {
                      throw RpcError(rpc_code::invalid_state, std::string("server.rotate_token: ").append(e.what()));
                    } catch (const std::runtime_error& e) {
                      throw RpcError(rpc_code::internal_error, std::string("server.rotate_token: ").append(e.what()));
                    }
                    spdlog::info("server.rotate_token from {}", ctx.peer());
                    if (on_rotated) on_rotated(next);
                    return nlohmann::json{{"token", next}};
                  }});
}

}  // namespace cmm::daemon
