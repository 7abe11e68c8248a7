// A collecting JSON config reader: every problem is noted with its JSON Pointer, then thrown at once.
#include "hal/config_block.hpp"

#include <cmath>
#include <sstream>

namespace cmm::hal {

namespace {
std::string join(const std::string& source, const std::vector<std::string>& problems) {
  std::ostringstream out;
  out << source << ": " << problems.size() << (problems.size() == 1 ? " problem" : " problems");
  for (const auto& p : problems) out << "\n  " << p;
  return out.str();
}

std::string range_text(double min, double max) {
  std::ostringstream out;
  out << "[" << min << ", " << max << "]";
  return out.str();
}
}  // namespace

ConfigError::ConfigError(const std::string& source, std::vector<std::string> problems)
    : std::runtime_error(join(source, problems)), problems_(std::move(problems)) {}

ConfigBlock::ConfigBlock(const nlohmann::json& j, std::string pointer,
                         std::shared_ptr<std::vector<std::string>> problems)
    : object_(j.is_object() ? j : nlohmann::json::object()),
      pointer_(std::move(pointer)),
      problems_(problems ? std::move(problems) : std::make_shared<std::vector<std::string>>()) {
  if (!j.is_object() && !j.is_null())
    problems_->push_back((pointer_.empty() ? "/" : pointer_) + ": must be an object, not " + j.type_name());
}

bool ConfigBlock::has(const std::string& key) const { return object_.contains(key); }

const nlohmann::json* ConfigBlock::find(const std::string& key) {
  read_.insert(key);
  auto it = object_.find(key);
  return it == object_.end() ? nullptr : &*it;
}

const nlohmann::json* ConfigBlock::raw(const std::string& key) { return find(key); }

void ConfigBlock::problem(const std::string& key, const std::string& message) {
  problems_->push_back(path(key) + ": " + message);
}

double ConfigBlock::number(const std::string& key, double fallback, double min, double max) {
  const auto* v = find(key);
  if (!v) return fallback;
  if (!v->is_number()) {
    problem(key, std::string("must be a number, not ") + v->type_name());
    return fallback;
  }
  double x = v->get<double>();
  if (!std::isfinite(x) || x < min || x > max) {
    problem(key, "must be in " + range_text(min, max) + ", not " + v->dump());
    return fallback;
  }
  return x;
}

int ConfigBlock::integer(const std::string& key, int fallback, int min, int max) {
  const auto* v = find(key);
  if (!v) return fallback;
  if (!v->is_number_integer()) {
    problem(key, std::string("must be an integer, not ") + v->dump());
    return fallback;
  }
  auto x = v->get<long long>();
  if (x < min || x > max) {
    problem(key, "must be in " + range_text(min, max) + ", not " + v->dump());
    return fallback;
  }
  return static_cast<int>(x);
}

bool ConfigBlock::flag(const std::string& key, bool fallback) {
  const auto* v = find(key);
  if (!v) return fallback;
  if (!v->is_boolean()) {
    problem(key, std::string("must be true or false, not ") + v->dump());
    return fallback;
  }
  return v->get<bool>();
}

std::string ConfigBlock::text(const std::string& key, const std::string& fallback, const std::set<std::string>& allowed) {
  const auto* v = find(key);
  if (!v) return fallback;
  if (!v->is_string()) {
    problem(key, std::string("must be a string, not ") + v->dump());
    return fallback;
  }
  auto s = v->get<std::string>();
  if (!allowed.empty() && !allowed.count(s)) {
    std::string list;
    for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
    problem(key, "must be one of " + list + ", not \"" + s + "\"");
    return fallback;
  }
  return s;
}

Vec3 ConfigBlock::vec3(const std::string& key, const Vec3& fallback) {
  const auto* v = find(key);
  if (!v) return fallback;
  if (!v->is_array() || v->size() != 3) {
    problem(key, "must be [x, y, z], not " + v->dump());
    return fallback;
  }
  Vec3 out;
  for (int i = 0; i < 3; ++i) {
    const auto& c = (*v)[static_cast<std::size_t>(i)];
    if (!c.is_number() || !std::isfinite(c.get<double>())) {
      problem(key, "must be three finite numbers, not " + v->dump());
      return fallback;
    }
    out[i] = c.get<double>();
  }
  return out;
}

ConfigBlock ConfigBlock::object(const std::string& key) {
  const auto* v = find(key);
  return ConfigBlock(v ? *v : nlohmann::json(), path(key), problems_);
}

std::vector<ConfigBlock> ConfigBlock::objects(const std::string& key) {
  std::vector<ConfigBlock> out;
  const auto* v = find(key);
  if (!v) return out;
  if (!v->is_array()) {
    problem(key, "must be an array of objects, not " + v->dump());
    return out;
  }
  for (std::size_t i = 0; i < v->size(); ++i) out.emplace_back((*v)[i], path(key) + "/" + std::to_string(i), problems_);
  return out;
}

void ConfigBlock::finish() {
  for (const auto& [key, value] : object_.items())
    if (!read_.count(key)) problem(key, "unknown key");
}

void ConfigBlock::throw_if_problems(const std::string& source) const {
  if (!problems_->empty()) throw ConfigError(source, *problems_);
}

std::filesystem::path resolve_config_path(const std::string& name, const std::filesystem::path& base_dir) {
  if (name.empty()) return {};
  const std::filesystem::path p(name);
  return p.is_absolute() ? p : base_dir / p;
}

}  // namespace cmm::hal
