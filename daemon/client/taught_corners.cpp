// with_taught_corner: one rough_machine entry set, the rest of the file as it was, in scan_corners' order.
#include "daemon/client/taught_corners.hpp"

#include <algorithm>
#include <stdexcept>
#include <vector>

namespace cmm::daemon {

namespace {

std::string id_list(const std::vector<int>& ids) {
  std::string text;
  for (const int id : ids) text.append(text.empty() ? "" : ", ").append(std::to_string(id));
  return text.empty() ? "none" : text;
}

// The integer ids of a corner list ("scan_corners" or "rough_machine"); throws for a malformed one.
std::vector<int> ids_of(const nlohmann::json& list, const char* key) {
  if (!list.is_array()) throw std::invalid_argument(std::string(key) + " must be a list of corners");
  std::vector<int> ids;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const nlohmann::json& c = list[i];
    if (!c.is_object() || !c.contains("id") || !c["id"].is_number_integer())
      throw std::invalid_argument(std::string(key) + "[" + std::to_string(i) + "] must be an object with an integer \"id\"");
    ids.push_back(c["id"].get<int>());
  }
  return ids;
}

}  // namespace

TaughtCorner with_taught_corner(nlohmann::json file, int corner_id, const Eigen::Vector3d& machine) {
  if (file.is_null()) file = nlohmann::json::object();
  if (!file.is_object()) throw std::invalid_argument("must be a JSON object ({\"scan_corners\", \"rough_machine\"})");
  TaughtCorner out;
  nlohmann::json& rough = file["rough_machine"];
  if (rough.is_null()) rough = nlohmann::json::array();
  const std::vector<int> rough_ids = ids_of(rough, "rough_machine");
  const nlohmann::json position = {machine.x(), machine.y(), machine.z()};
  const auto it = std::find(rough_ids.begin(), rough_ids.end(), corner_id);
  if (it != rough_ids.end()) {
    nlohmann::json& entry = rough[static_cast<std::size_t>(it - rough_ids.begin())];
    out.replaced = entry.value("machine", nlohmann::json(nullptr));
    entry["machine"] = position;
  } else {
    rough.push_back({{"id", corner_id}, {"machine", position}});
  }

  std::vector<int> scan_ids;
  if (file.contains("scan_corners")) scan_ids = ids_of(file["scan_corners"], "scan_corners");
  const auto rank = [&scan_ids](const nlohmann::json& c) {
    const auto at = std::find(scan_ids.begin(), scan_ids.end(), c["id"].get<int>());
    return at - scan_ids.begin();  // not named: scan_ids.size(), after every named one
  };
  std::stable_sort(rough.begin(), rough.end(), [&](const nlohmann::json& a, const nlohmann::json& b) { return rank(a) < rank(b); });

  std::vector<int> taught = ids_of(rough, "rough_machine"), missing;
  for (const int id : scan_ids)
    if (std::find(taught.begin(), taught.end(), id) == taught.end()) missing.push_back(id);
  out.summary = std::string("rough_machine has corners ").append(id_list(taught));
  if (!scan_ids.empty())
    out.summary.append(missing.empty() ? std::string("; every scan corner is taught")
                                       : std::string("; still to teach: ").append(id_list(missing)));
  out.file = std::move(file);
  return out;
}

}  // namespace cmm::daemon
