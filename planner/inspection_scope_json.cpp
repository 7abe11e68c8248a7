// What a job inspects, from and to JSON; see inspection_scope_json.hpp.
#include "planner/inspection_scope_json.hpp"

namespace cmm::planner {

namespace {

using description::JsonFields;
using nlohmann::json;

constexpr int max_feature_id = 100000000;

// [id, …] of distinct feature ids.
std::set<int> read_ids(JsonFields& list) {
  std::set<int> ids;
  if (!list.value().is_array()) {
    list.problem("must be an array of feature ids");
    return ids;
  }
  for (JsonFields& item : list.as_items()) {
    const int id = item.as_integer(-1, 0, max_feature_id);
    if (id >= 0 && !ids.insert(id).second) item.problem("names feature " + std::to_string(id) + " twice");
  }
  return ids;
}

// "all" (nullopt), "none" (no id) or [id, …].
std::optional<std::set<int>> read_choice(JsonFields& f, const std::string& key, std::optional<std::set<int>> fallback) {
  if (!f.has(key)) return fallback;
  JsonFields choice = f.member(key);
  if (choice.value().is_string()) {
    const std::string word = choice.as_text("all", {"all", "none"});
    return word == "none" ? std::optional<std::set<int>>(std::set<int>()) : std::nullopt;
  }
  if (!choice.value().is_array()) {
    choice.problem("must be \"all\", \"none\" or an array of feature ids");
    return fallback;
  }
  return read_ids(choice);
}

std::set<int> read_list(JsonFields& f, const std::string& key) {
  if (!f.has(key)) return {};
  JsonFields list = f.member(key);
  return read_ids(list);
}

json choice_json(const std::optional<std::set<int>>& ids) { return ids ? json(*ids) : json("all"); }

}  // namespace

InspectionScope read_inspection_scope(JsonFields& f) {
  InspectionScope scope;
  if (!f.expect_object() || !f.present()) return scope;
  f.known({"edge_points", "curves", "holes", "exclude"});
  scope.curves = read_list(f, "curves");
  // Curves alone ask for their points only; "edge_points" says otherwise when given.
  scope.edge_points = read_choice(f, "edge_points", f.has("curves") ? std::optional<std::set<int>>(std::set<int>()) : std::nullopt);
  scope.holes = read_choice(f, "holes", std::nullopt);
  if (f.has("exclude")) {
    JsonFields exclude = f.object("exclude");
    if (exclude.value().is_object()) {
      exclude.known({"not_probeable", "edge_points", "curves", "holes", "reason"});
      scope.exclude_not_probeable = exclude.flag("not_probeable", false);
      scope.excluded_edge_points = read_list(exclude, "edge_points");
      scope.excluded_curves = read_list(exclude, "curves");
      scope.excluded_holes = read_list(exclude, "holes");
      scope.exclude_reason = exclude.text("reason", "");
      // A feature left out is counted apart with its reason, and no reason is none.
      const bool listed = exclude.has("edge_points") || exclude.has("curves") || exclude.has("holes");
      if (listed && scope.exclude_reason.empty()) exclude.problem("reason", "must say why the listed features are left out");
      if (!listed && exclude.has("reason")) exclude.problem("reason", "names no feature: list edge_points, curves or holes");
      exclude.finish();
    }
  }
  f.finish();
  return scope;
}

json to_json(const InspectionScope& scope) {
  json exclude = {{"not_probeable", scope.exclude_not_probeable}};
  if (!scope.excluded_edge_points.empty()) exclude["edge_points"] = scope.excluded_edge_points;
  if (!scope.excluded_curves.empty()) exclude["curves"] = scope.excluded_curves;
  if (!scope.excluded_holes.empty()) exclude["holes"] = scope.excluded_holes;
  if (!scope.exclude_reason.empty()) exclude["reason"] = scope.exclude_reason;
  json j = {{"edge_points", choice_json(scope.edge_points)}, {"holes", choice_json(scope.holes)}, {"exclude", exclude}};
  if (!scope.curves.empty()) j["curves"] = scope.curves;
  return j;
}

}  // namespace cmm::planner
