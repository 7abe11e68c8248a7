// Teaching a plate corner: the machine's current position taken as that corner's rough position in
// a measure_plate file ({"scan_corners", "rough_machine"}, as `cmm-scan --plate-corners` writes it).
#pragma once

#include <string>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

namespace cmm::daemon {

struct TaughtCorner {
  nlohmann::json file;                // the whole file with the corner in it
  nlohmann::json replaced = nullptr;  // the corner's position before, if it had one
  std::string summary;                // which corners are taught, and which scan corners still are not
};

// `file` (an object, or null for a new file) with rough_machine's entry for `corner_id` set to
// `machine` (added if missing); every other key and entry is kept. rough_machine follows
// scan_corners' order, as a job request requires, entries scan_corners does not name last.
// Throws std::invalid_argument naming the problem for a file that is not an object or whose
// rough_machine is not a list of {"id", "machine"} objects.
TaughtCorner with_taught_corner(nlohmann::json file, int corner_id, const Eigen::Vector3d& machine);

}  // namespace cmm::daemon
