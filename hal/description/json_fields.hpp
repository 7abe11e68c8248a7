// Reading a JSON input field by field (machine.json, plate.json, corners.json, a driver's block,
// cmmd.json, a job request): one pass notes every bad field by its JSON Pointer, unknown keys
// included, and then throws them together, so that a user fixes an input in one edit.
#pragma once

#include <filesystem>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

namespace cmm::description {

using Vec3 = Eigen::Vector3d;

struct FieldProblem {
  std::string pointer;  // JSON Pointer of the field ("/tips/0/ball_radius_mm"); "" for the whole input
  std::string message;  // "must be positive, not -1"
  bool unknown_key = false;  // listed first: a misspelt key is often why another one is missing
};

// An input refused for its fields (or, at pointer "", as a whole: a file that is not JSON).
// what() reads "machine.json: /tips/0/id: missing" for one problem, and "machine.json: 3 problems"
// with one indented line per problem for more.
class FieldError : public std::runtime_error {
 public:
  FieldError(std::string source, std::vector<FieldProblem> problems);
  const std::string& source() const { return source_; }
  const std::vector<FieldProblem>& problems() const { return problems_; }
  const std::string& pointer() const { return problems_.front().pointer; }  // the first problem's
  std::vector<std::string> lines() const;  // "pointer: message", one per problem

 private:
  std::string source_;
  std::vector<FieldProblem> problems_;
};

// One value of the input, at its JSON Pointer. Each read returns the value, or the fallback after
// noting a problem, so reading goes on; the problems are shared by every node of one input. The
// first node keeps its own copy of the input, which the nodes read from it share.
// finish() notes the members nobody read (a typo such as "thicknes_mm" would otherwise silently
// keep a default); throw_if_problems() ends the pass. A reader calls expect_object() on the input
// first; object() and objects() check their members themselves.
class JsonFields {
 public:
  // `pointer` places the input inside a larger one ("/machine"), for the problems' paths.
  explicit JsonFields(const nlohmann::json& value, std::string pointer = "");

  // --- this value
  const nlohmann::json& value() const { return *value_; }
  const std::string& pointer() const { return pointer_; }
  bool present() const { return present_; }  // false for a member that is not there
  double as_number(double fallback, double min, double max);
  double as_positive(double fallback);  // finite and above zero
  int as_integer(int fallback, int min, int max);  // compared before narrowing: 4294967297 is not 1
  std::string as_text(const std::string& fallback, const std::set<std::string>& allowed = {});
  // [x, y, z]; with `allow_xy` also [x, y], whose z is 0.
  Vec3 as_vec3(const Vec3& fallback, bool allow_xy = false);
  std::vector<JsonFields> as_items();  // the elements of an array

  // --- members of this object (each read marks its key as known)
  bool expect_object();  // notes a value that is not an object; true when it is one (or is missing)
  bool has(const std::string& key) const;
  JsonFields member(const std::string& key);
  // Notes `key` as missing (with what it should hold) when it is not there; true when it is.
  bool require(const std::string& key, const std::string& what = "");
  double number(const std::string& key, double fallback, double min, double max);
  double positive(const std::string& key, double fallback);
  int integer(const std::string& key, int fallback, int min, int max);
  bool flag(const std::string& key, bool fallback);
  std::string text(const std::string& key, const std::string& fallback, const std::set<std::string>& allowed = {});
  Vec3 vec3(const std::string& key, const Vec3& fallback, bool allow_xy = false);
  JsonFields object(const std::string& key);               // a missing member reads as an empty object
  std::vector<JsonFields> objects(const std::string& key);  // an array of objects; missing reads as empty
  std::vector<JsonFields> items(const std::string& key);    // an array of any values; missing reads as empty

  // --- problems
  void problem(const std::string& message);                           // at this value
  void problem(const std::string& key, const std::string& message);   // at a member of it
  void problems_of(const FieldError& nested, const std::string& key);  // a nested input's, under `key`
  void finish();  // members nobody read are unknown keys
  // Notes every member not in `keys` as unknown at once, before any read: a misspelt key is often
  // why a required one is missing, so the misspelling comes first (and is a −32602's data.path).
  void known(const std::set<std::string>& keys);
  bool ok() const { return problems_->empty(); }  // no problem anywhere in the input so far
  std::size_t problem_count() const { return problems_->size(); }
  void throw_if_problems(const std::string& source) const;  // unknown keys first, else in reading order

 private:
  JsonFields(std::shared_ptr<const nlohmann::json> root, const nlohmann::json* value, std::string pointer,
             std::shared_ptr<std::vector<FieldProblem>> problems);
  std::string path(const std::string& key) const;

  std::shared_ptr<const nlohmann::json> root_;  // the whole input, which value_ points into
  const nlohmann::json* value_;
  std::string pointer_;
  bool present_ = true;
  std::shared_ptr<std::vector<FieldProblem>> problems_;
  std::set<std::string> read_;
};

// Parses a JSON file; FieldError (at pointer "") when it cannot be opened or is not JSON, naming
// the file and, for bad JSON, the byte. `what` says what the file should be ("the plate description").
nlohmann::json read_json_file(const std::filesystem::path& file, const std::string& what);

// A file named in a config: absolute, or relative to the config file's folder; "" stays "".
std::filesystem::path resolve_config_path(const std::string& name, const std::filesystem::path& base_dir);

// An object a config gives inline or as a file name (a machine description, a plate): absent or ""
// gives the fallback; the object's own problems are noted under `key` (an inline one's at their
// pointers inside it, a file's as one problem naming the file), and reading goes on.
template <class T, class FromJson, class FromFile>
T described(JsonFields& block, const std::string& key, T fallback, const std::filesystem::path& base_dir,
            FromJson from_json, FromFile from_file) {
  JsonFields field = block.member(key);
  const nlohmann::json& j = field.value();
  if (!field.present() || (j.is_string() && j.get<std::string>().empty())) return fallback;
  try {
    if (j.is_string()) return from_file(resolve_config_path(j.get<std::string>(), base_dir));
    if (j.is_object()) return from_json(j, field.pointer());
    field.problem("must be a file name or an object");
  } catch (const FieldError& e) {
    if (j.is_object()) block.problems_of(e, key);
    else field.problem(e.what());
  } catch (const std::exception& e) {
    field.problem(e.what());
  }
  return fallback;
}

}  // namespace cmm::description
