// Reading a driver's JSON config block so that one pass reports every bad key, each by its JSON
// Pointer path ("/faults/reply_delay_s: must be ≥ 0"), unknown keys included: an operator fixes a
// config in one edit, not one error per restart.
#pragma once

#include <memory>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "hal/motion.hpp"

namespace cmm::hal {

class ConfigError : public std::runtime_error {
 public:
  ConfigError(const std::string& source, std::vector<std::string> problems);
  const std::vector<std::string>& problems() const { return problems_; }

 private:
  std::vector<std::string> problems_;
};

// Each getter returns the value, or the fallback after noting a problem, so reading goes on.
// finish() notes the keys nobody asked for; throw_if_problems() ends the pass.
class ConfigBlock {
 public:
  // `j` should be an object; anything else is itself a problem at `pointer`.
  explicit ConfigBlock(const nlohmann::json& j, std::string pointer = "",
                       std::shared_ptr<std::vector<std::string>> problems = nullptr);

  bool has(const std::string& key) const;
  double number(const std::string& key, double fallback, double min, double max);
  int integer(const std::string& key, int fallback, int min, int max);
  bool flag(const std::string& key, bool fallback);
  std::string text(const std::string& key, const std::string& fallback, const std::set<std::string>& allowed = {});
  Vec3 vec3(const std::string& key, const Vec3& fallback);
  ConfigBlock object(const std::string& key);  // a missing key reads as an empty block
  // An array of objects, one block per element ("/tips/0"); a missing key reads as empty.
  std::vector<ConfigBlock> objects(const std::string& key);
  const nlohmann::json* raw(const std::string& key);  // for a value read elsewhere; marks it known

  void problem(const std::string& key, const std::string& message);
  void finish();  // unknown keys
  void throw_if_problems(const std::string& source) const;
  const std::string& pointer() const { return pointer_; }

 private:
  const nlohmann::json* find(const std::string& key);
  std::string path(const std::string& key) const { return pointer_ + "/" + key; }

  nlohmann::json object_;
  std::string pointer_;
  std::shared_ptr<std::vector<std::string>> problems_;
  std::set<std::string> read_;
};

}  // namespace cmm::hal
