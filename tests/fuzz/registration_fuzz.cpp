// Fuzzes corners.json (planner/registration.hpp): registration_from_json on any JSON, then the fit
// that cmm-plan --registration and registration.fit run on what it accepts. Refusals:
// description::FieldError from the reader, RegistrationError from the fit.
#include <cstddef>
#include <cstdint>

#include "fuzz_support.hpp"
#include "hal/description/json_fields.hpp"
#include "planner/registration.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto j = cmm::fuzz::json_of(cmm::fuzz::text_of(data, size));
  if (!j || cmm::fuzz::names_special_file(*j)) return 0;
  cmm::fuzz::refusing_with<cmm::description::FieldError, cmm::planner::RegistrationError>([&] {
    const cmm::planner::RegistrationInput input = cmm::planner::registration_from_json(*j, "corners.json", "/nonexistent");
    (void)cmm::planner::to_json(cmm::planner::fit_registration(input));
  });
  return 0;
}
