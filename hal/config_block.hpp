// Reading a driver's JSON config block so that one pass reports every bad key, each by its JSON
// Pointer path ("/faults/reply_delay_s: must be ≥ 0"), unknown keys included: an operator fixes a
// config in one edit, not one error per restart.
#pragma once

#include <filesystem>
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

// A file named in a config: absolute, or relative to the config file's folder; "" stays "".
std::filesystem::path resolve_config_path(const std::string& name, const std::filesystem::path& base_dir);

// An object a config gives inline or as a file name (a machine description, a plate): absent or ""
// gives the fallback; a reading error becomes one problem at the key, and reading goes on.
template <class T, class FromJson, class FromFile>
T described(ConfigBlock& block, const std::string& key, T fallback, const std::filesystem::path& base_dir,
            FromJson from_json, FromFile from_file) {
  const nlohmann::json* j = block.raw(key);
  if (j == nullptr || (j->is_string() && j->get<std::string>().empty())) return fallback;
  try {
    if (j->is_string()) return from_file(resolve_config_path(j->get<std::string>(), base_dir));
    if (j->is_object()) return from_json(*j, block.pointer() + "/" + key);
    block.problem(key, "must be a file name or an object");
  } catch (const std::exception& e) {
    block.problem(key, e.what());
  }
  return fallback;
}

}  // namespace cmm::hal
