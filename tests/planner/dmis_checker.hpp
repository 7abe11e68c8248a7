// Test support: a strict checker of the DMIS subset planner/dmis_export writes (docs/dmis.md). It
// stops at the first violation and names its line, so a test can say which rule a file breaks.
#pragma once

#include <cstddef>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>

#include "hal/description/machine_description.hpp"
#include "planner/move_program.hpp"

namespace cmm::planner::testing {

struct DmisCheckOptions {
  std::optional<description::TravelBox> travel_box;  // every GOTO and every PTMEAS ball centre (xyz + r·ijk) inside
  // When set: each PTMEAS is one of its touches (same surface point), measured once, with ijk =
  // −direction, reached from the touch's start under the planned SNSET/APPRCH and SEARCH; and every
  // touch is measured.
  const MoveProgram* program = nullptr;
};

struct DmisCheckResult {
  std::size_t line = 0;  // 1-based line of the first violation; 0 when the text passes
  std::string message;
  bool ok() const { return line == 0; }
};

std::ostream& operator<<(std::ostream& out, const DmisCheckResult& result);

DmisCheckResult check_dmis(std::string_view text, const DmisCheckOptions& options = {});

}  // namespace cmm::planner::testing
