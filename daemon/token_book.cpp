// Constant-time comparison of guessed tokens, failures throttled per source.
#include "daemon/token_book.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <mutex>

#include "daemon/client/json_rpc.hpp"

namespace cmm::daemon {

namespace {

// Compares without stopping at the first difference, so the time taken does not tell how much
// of a guessed token was right.
bool same_secret(const std::string& secret, const std::string& guess) {
  unsigned diff = secret.size() != guess.size();
  for (std::size_t i = 0; i < secret.size(); ++i)
    diff |= static_cast<unsigned char>(secret[i]) ^ static_cast<unsigned char>(i < guess.size() ? guess[i] : 0);
  return diff == 0;
}

// Sources remembered at once: a client that makes up a new source per guess (new connections)
// costs a bounded map; those whose allowance is full again are forgotten first.
constexpr std::size_t kMaxSources = 4096;

// A connection that guesses wrong this often is closed after the last answer.
constexpr int kMaxFailedAuthPerConnection = 3;

// Wrong tokens are logged at most once a second, with how many came since: a guesser opening
// connections by the thousand costs a line a second, not one per guess.
void log_wrong_token(const RpcContext& ctx, int failures) {
  using Clock = std::chrono::steady_clock;
  static std::mutex mutex;
  static Clock::time_point last{};
  static long unlogged = 0;
  std::lock_guard lock(mutex);
  const Clock::time_point now = Clock::now();
  if (now - last < std::chrono::seconds(1)) {
    ++unlogged;
    return;
  }
  spdlog::warn("server.auth: an unknown token from connection {} ({}; {} on it){}", ctx.connection_id(), ctx.peer(),
               failures, unlogged > 0 ? " and " + std::to_string(unlogged) + " more since the last such line" : "");
  last = now;
  unlogged = 0;
}

}  // namespace

TokenBook::TokenBook(std::vector<AccessToken> configured, double guesses_per_s, double guess_burst)
    : configured_(std::move(configured)), guesses_per_s_(guesses_per_s), guess_burst_(guess_burst) {}

void TokenBook::set_configured(std::vector<AccessToken> tokens) {
  std::lock_guard lock(mutex_);
  configured_ = std::move(tokens);
}

bool TokenBook::any_configured() const {
  std::lock_guard lock(mutex_);
  return !configured_.empty();
}

void TokenBook::set_station_token(std::string token) {
  std::lock_guard lock(mutex_);
  station_ = AccessToken{std::move(token), Role::operator_};
}

TokenCheck TokenBook::check(const std::string& guess, const std::string& source) {
  std::lock_guard lock(mutex_);
  std::optional<Role> granted;
  for (const AccessToken& known : configured_)
    if (same_secret(known.token, guess) && (!granted || known.role > *granted)) granted = known.role;
  if (station_ && same_secret(station_->token, guess)) granted = Role::operator_;
  if (granted) return {.role = granted};

  if (sources_.size() >= kMaxSources && !sources_.contains(source)) {
    std::erase_if(sources_, [](const auto& entry) { return entry.second.throttle.full(); });
    if (sources_.size() >= kMaxSources)  // all of them guessing: the one quiet longest goes
      sources_.erase(std::min_element(sources_.begin(), sources_.end(), [](const auto& a, const auto& b) {
        return a.second.last < b.second.last;
      }));
  }
  Source& from = sources_.try_emplace(source, Source{AuthThrottle(guesses_per_s_, guess_burst_)}).first->second;
  from.last = AuthThrottle::Clock::now();
  if (from.throttle.allow()) {
    // Logged again only once the source has been quiet long enough to earn its whole allowance
    // back: a guesser kept at the edge of it is one line, not one per refill.
    if (from.throttle.full()) from.refusing = false;
    from.throttle.record_failure();
    return {};
  }
  if (!from.refusing) spdlog::warn("server.auth: too many wrong tokens from {}; answered as throttled for a while", source);
  from.refusing = true;
  return {.role = std::nullopt, .throttled = true, .retry_after_s = from.throttle.retry_after_s()};
}

std::string auth_source(const std::string& peer) {
  const std::size_t scheme = peer.find("://");
  const std::size_t colon = peer.rfind(':');
  if (scheme == std::string::npos || colon <= scheme + 3 || peer.find_first_not_of("0123456789", colon + 1) != std::string::npos)
    return peer;
  return peer.substr(0, colon);
}

Role authenticate(TokenBook& tokens, const std::string& token, RpcContext& ctx, const std::string& source) {
  const TokenCheck checked = tokens.check(token, source);
  if (checked.role) {
    if (*checked.role > ctx.role()) ctx.set_role(*checked.role);  // a token never lowers what the transport gave
    ctx.mark_authenticated();
    return ctx.role();
  }
  const int failures = ctx.count_failed_auth();
  if (checked.throttled) {
    ctx.close_after_reply();
    throw RpcError(rpc_code::auth_failed, "too many wrong tokens from " + source + ": try again later",
                   {{"retry_after_s", checked.retry_after_s}});
  }
  log_wrong_token(ctx, failures);
  if (failures >= kMaxFailedAuthPerConnection) ctx.close_after_reply();
  throw RpcError(rpc_code::auth_failed, "unknown token");
}

}  // namespace cmm::daemon
