// Numbers in the planner's messages and files: fixed-point with a stated number of digits, so a
// message reads the same on every machine and a golden file does not depend on stream state.
#pragma once

#include <cstdio>
#include <string>

namespace cmm::planner {

inline std::string fixed(double value, int digits = 2) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", digits, value);
  return buffer;
}

}  // namespace cmm::planner
