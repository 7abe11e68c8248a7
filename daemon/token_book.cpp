// Constant-time comparison of guessed tokens behind the shared throttle.
#include "daemon/token_book.hpp"

#include <spdlog/spdlog.h>

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

}  // namespace

TokenBook::TokenBook(std::vector<AccessToken> configured, double guesses_per_s, double guess_burst)
    : configured_(std::move(configured)), throttle_(guesses_per_s, guess_burst) {}

void TokenBook::set_configured(std::vector<AccessToken> tokens) {
  std::lock_guard lock(mutex_);
  configured_ = std::move(tokens);
}

bool TokenBook::any_configured() const {
  std::lock_guard lock(mutex_);
  return !configured_.empty();
}

void TokenBook::add_generated(AccessToken token) {
  std::lock_guard lock(mutex_);
  generated_.push_back(std::move(token));
}

TokenCheck TokenBook::check(const std::string& guess) {
  std::lock_guard lock(mutex_);
  if (!throttle_.allow()) {
    if (!refusing_) spdlog::warn("server.auth: too many failed attempts; refusing server.auth for a while");
    refusing_ = true;
    return {.role = std::nullopt, .throttled = true, .retry_after_s = throttle_.retry_after_s()};
  }
  refusing_ = false;
  std::optional<Role> granted;
  for (const std::vector<AccessToken>* tokens : {&configured_, &generated_})
    for (const AccessToken& known : *tokens)
      if (same_secret(known.token, guess) && (!granted || known.role > *granted)) granted = known.role;
  if (!granted) throttle_.record_failure();
  return {.role = granted};
}

}  // namespace cmm::daemon
