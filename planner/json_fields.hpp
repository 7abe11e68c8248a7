// Reading the planner's JSON inputs (machine.json, plate.json, corners.json) field by field: every
// refusal is a geometry::FileError that names the file and the field ("plate.json: fiducial.corner: …").
#pragma once

#include <set>
#include <string>

#include <nlohmann/json.hpp>

namespace cmm::planner {

[[noreturn]] void fail_field(const std::string& source, const std::string& field, const std::string& message);

// A finite number, and one above zero.
double number(const nlohmann::json& j, const std::string& source, const std::string& field);
double positive(const nlohmann::json& j, const std::string& source, const std::string& field);
// An integer in [min, max], compared before narrowing: 4294967297 is not corner 1.
int integer(const nlohmann::json& j, const std::string& source, const std::string& field, int min, int max);

// Refuses any key of object `j` (at `field`, "" for the top level) not in `known`: a typo such as
// "thicknes_mm" would otherwise silently keep a default.
void only_known_keys(const nlohmann::json& j, const std::string& source, const std::string& field,
                     const std::set<std::string>& known);

}  // namespace cmm::planner
