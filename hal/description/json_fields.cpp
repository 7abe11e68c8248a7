// The field checker: typed reads that note a problem and go on, paths as JSON Pointers.
#include "hal/description/json_fields.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <sstream>

namespace cmm::description {

namespace {

const nlohmann::json& missing_value() {
  static const nlohmann::json null;
  return null;
}

std::string what_of(const std::string& source, const std::vector<FieldProblem>& problems) {
  auto line = [](const FieldProblem& p) { return (p.pointer.empty() ? "" : p.pointer + ": ") + p.message; };
  if (problems.size() == 1) return source + ": " + line(problems.front());
  std::ostringstream out;
  out << source << ": " << problems.size() << " problems";
  for (const FieldProblem& p : problems) out << "\n  " << line(p);
  return out.str();
}

std::string number_text(double x) {
  std::ostringstream out;
  out << x;
  return out.str();
}

// A JSON Pointer token: '~' and '/' escaped (RFC 6901).
std::string token(const std::string& key) {
  std::string out;
  for (const char c : key) {
    if (c == '~') out += "~0";
    else if (c == '/') out += "~1";
    else out += c;
  }
  return out;
}

std::string list(const std::set<std::string>& names) {
  std::string out;
  for (const std::string& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

}  // namespace

FieldError::FieldError(std::string source, std::vector<FieldProblem> problems)
    : std::runtime_error(what_of(source, problems.empty() ? std::vector<FieldProblem>{{"", "refused"}} : problems)),
      source_(std::move(source)),
      problems_(problems.empty() ? std::vector<FieldProblem>{{"", "refused"}} : std::move(problems)) {}

std::vector<std::string> FieldError::lines() const {
  std::vector<std::string> out;
  for (const FieldProblem& p : problems_) out.push_back((p.pointer.empty() ? "" : p.pointer + ": ") + p.message);
  return out;
}

JsonFields::JsonFields(const nlohmann::json& value, std::string pointer)
    : root_(std::make_shared<const nlohmann::json>(value)),
      value_(root_.get()),
      pointer_(std::move(pointer)),
      problems_(std::make_shared<std::vector<FieldProblem>>()) {}

JsonFields::JsonFields(std::shared_ptr<const nlohmann::json> root, const nlohmann::json* value, std::string pointer,
                       std::shared_ptr<std::vector<FieldProblem>> problems)
    : root_(std::move(root)),
      value_(value ? value : &missing_value()),
      pointer_(std::move(pointer)),
      present_(value != nullptr),
      problems_(std::move(problems)) {}

std::string JsonFields::path(const std::string& key) const { return pointer_ + "/" + token(key); }

void JsonFields::problem(const std::string& message) { problems_->push_back({pointer_, message}); }

void JsonFields::problem(const std::string& key, const std::string& message) {
  problems_->push_back({path(key), message});
}

void JsonFields::problems_of(const FieldError& nested, const std::string& key) {
  read_.insert(key);
  for (const FieldProblem& p : nested.problems()) problems_->push_back({path(key) + p.pointer, p.message, p.unknown_key});
}

// --- this value

double JsonFields::as_number(double fallback, double min, double max) {
  if (!value_->is_number()) {
    problem(std::string("must be a number, not ") + value_->dump());
    return fallback;
  }
  const double x = value_->get<double>();
  if (!std::isfinite(x) || x < min || x > max) {
    problem("must be in [" + number_text(min) + ", " + number_text(max) + "], not " + value_->dump());
    return fallback;
  }
  return x;
}

double JsonFields::as_positive(double fallback) {
  if (!value_->is_number()) {
    problem(std::string("must be a number, not ") + value_->dump());
    return fallback;
  }
  const double x = value_->get<double>();
  if (!std::isfinite(x) || !(x > 0)) {
    problem("must be positive, not " + value_->dump());
    return fallback;
  }
  return x;
}

int JsonFields::as_integer(int fallback, int min, int max) {
  const std::string range = "an integer in [" + std::to_string(min) + ", " + std::to_string(max) + "]";
  if (!value_->is_number_integer()) {
    problem("must be " + range + ", not " + value_->dump());
    return fallback;
  }
  bool fits = false;
  if (value_->is_number_unsigned()) {
    const std::uint64_t u = value_->get<std::uint64_t>();
    fits = max >= 0 && u <= static_cast<std::uint64_t>(max) && static_cast<std::int64_t>(u) >= min;
  } else {
    const std::int64_t i = value_->get<std::int64_t>();
    fits = i >= min && i <= max;
  }
  if (!fits) {
    problem("must be " + range + ", not " + value_->dump());
    return fallback;
  }
  return static_cast<int>(value_->get<std::int64_t>());
}

std::string JsonFields::as_text(const std::string& fallback, const std::set<std::string>& allowed) {
  if (!value_->is_string()) {
    problem(std::string("must be a string, not ") + value_->dump());
    return fallback;
  }
  const std::string s = value_->get<std::string>();
  if (!allowed.empty() && !allowed.contains(s)) {
    problem("must be one of " + list(allowed) + ", not \"" + s + "\"");
    return fallback;
  }
  return s;
}

Vec3 JsonFields::as_vec3(const Vec3& fallback, bool allow_xy) {
  const char* shape = allow_xy ? "[x, y] or [x, y, z]" : "[x, y, z]";
  if (!value_->is_array() || value_->size() > 3 || value_->size() < (allow_xy ? 2u : 3u)) {
    problem(std::string("must be ") + shape + ", not " + value_->dump());
    return fallback;
  }
  Vec3 v = Vec3::Zero();
  for (std::size_t i = 0; i < value_->size(); ++i) {
    const nlohmann::json& c = (*value_)[i];
    if (!c.is_number() || !std::isfinite(c.get<double>())) {
      problems_->push_back({pointer_ + "/" + std::to_string(i), "must be a finite number, not " + c.dump()});
      return fallback;
    }
    v[static_cast<Eigen::Index>(i)] = c.get<double>();
  }
  return v;
}

std::vector<JsonFields> JsonFields::as_items() {
  std::vector<JsonFields> out;
  if (!value_->is_array()) {
    problem(std::string("must be an array, not ") + value_->dump());
    return out;
  }
  for (std::size_t i = 0; i < value_->size(); ++i)
    out.push_back(JsonFields(root_, &(*value_)[i], pointer_ + "/" + std::to_string(i), problems_));
  return out;
}

// --- members

bool JsonFields::has(const std::string& key) const { return value_->is_object() && value_->contains(key); }

JsonFields JsonFields::member(const std::string& key) {
  read_.insert(key);
  const nlohmann::json* found = nullptr;
  if (value_->is_object())
    if (const auto it = value_->find(key); it != value_->end()) found = &*it;
  return JsonFields(root_, found, path(key), problems_);
}

bool JsonFields::require(const std::string& key, const std::string& what) {
  if (has(key)) return true;
  read_.insert(key);
  if (present_ && !value_->is_object()) return false;  // expect_object() has said what is wrong here
  problem(key, what.empty() ? "missing" : "missing (" + what + ")");
  return false;
}

double JsonFields::number(const std::string& key, double fallback, double min, double max) {
  JsonFields f = member(key);
  return f.present() ? f.as_number(fallback, min, max) : fallback;
}

double JsonFields::positive(const std::string& key, double fallback) {
  JsonFields f = member(key);
  return f.present() ? f.as_positive(fallback) : fallback;
}

int JsonFields::integer(const std::string& key, int fallback, int min, int max) {
  JsonFields f = member(key);
  return f.present() ? f.as_integer(fallback, min, max) : fallback;
}

bool JsonFields::flag(const std::string& key, bool fallback) {
  JsonFields f = member(key);
  if (!f.present()) return fallback;
  if (!f.value().is_boolean()) {
    f.problem("must be true or false, not " + f.value().dump());
    return fallback;
  }
  return f.value().get<bool>();
}

std::string JsonFields::text(const std::string& key, const std::string& fallback, const std::set<std::string>& allowed) {
  JsonFields f = member(key);
  return f.present() ? f.as_text(fallback, allowed) : fallback;
}

Vec3 JsonFields::vec3(const std::string& key, const Vec3& fallback, bool allow_xy) {
  JsonFields f = member(key);
  return f.present() ? f.as_vec3(fallback, allow_xy) : fallback;
}

bool JsonFields::expect_object() {
  if (value_->is_object() || !present_) return true;
  problem(std::string("must be an object, not ") + value_->dump());
  return false;
}

JsonFields JsonFields::object(const std::string& key) {
  JsonFields f = member(key);
  f.expect_object();
  return f;
}

std::vector<JsonFields> JsonFields::objects(const std::string& key) {
  std::vector<JsonFields> out;
  for (JsonFields& item : items(key)) {
    item.expect_object();
    out.push_back(std::move(item));
  }
  return out;
}

std::vector<JsonFields> JsonFields::items(const std::string& key) {
  JsonFields f = member(key);
  if (!f.present()) return {};
  return f.as_items();
}

void JsonFields::finish() {
  if (!value_->is_object()) return;  // expect_object() said so
  for (const auto& [key, v] : value_->items())
    if (!read_.contains(key))
      problems_->push_back({path(key), read_.empty() ? "unknown key" : "unknown key (known: " + list(read_) + ")", true});
}

void JsonFields::known(const std::set<std::string>& keys) {
  if (!value_->is_object()) return;
  for (const auto& [key, v] : value_->items())
    if (!keys.contains(key)) problems_->push_back({path(key), "unknown key (known: " + list(keys) + ")", true});
  for (const auto& [key, v] : value_->items()) read_.insert(key);  // noted once, not again by finish()
}

void JsonFields::throw_if_problems(const std::string& source) const {
  if (problems_->empty()) return;
  std::vector<FieldProblem> problems = *problems_;
  std::stable_partition(problems.begin(), problems.end(), [](const FieldProblem& p) { return p.unknown_key; });
  throw FieldError(source, std::move(problems));
}

// --- files

nlohmann::json read_json_file(const std::filesystem::path& file, const std::string& what) {
  std::ifstream in(file);
  if (!in) throw FieldError(file.string(), {{"", "cannot open " + what}});
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    throw FieldError(file.string(), {{"", "not valid JSON at byte " + std::to_string(e.byte)}});
  } catch (const nlohmann::json::exception& e) {  // out_of_range too: a number like 1e400
    throw FieldError(file.string(), {{"", std::string("not valid JSON (") + e.what() + ")"}});
  }
}

std::filesystem::path resolve_config_path(const std::string& name, const std::filesystem::path& base_dir) {
  if (name.empty()) return {};
  const std::filesystem::path p(name);
  return p.is_absolute() ? p : base_dir / p;
}

}  // namespace cmm::description
