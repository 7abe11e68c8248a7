// Fuzzes the job request (daemon/job_request.hpp): job.submit's and plan.preview's params as a
// client sends them, parsed as cmmd parses a line, checked against the default config; the only
// refusal is RpcError (−32602 with the bad field's path).
#include <cstddef>
#include <cstdint>

#include "daemon/daemon_config.hpp"
#include "daemon/job_request.hpp"
#include "daemon/client/json_rpc.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace cmm::daemon;
  static const DaemonConfig config = daemon_config_from_json(nlohmann::json::object(), "<fuzz>", "/nonexistent");
  cmm::fuzz::refusing_with<RpcError>([&] {
    const nlohmann::json params = parse_message(cmm::fuzz::text_of(data, size));
    cmm::fuzz::refusing_with<RpcError>([&] { (void)parse_job_request(params, config, true); });
    const JobRequest r = parse_job_request(params, config);
    if (r.given.has_value() == r.measure.has_value()) __builtin_trap();  // exactly one registration
    // The scan options the front end gets are inside their documented ranges.
    if (r.tolerance_mm && !(*r.tolerance_mm >= 0.001 && *r.tolerance_mm <= 10)) __builtin_trap();
    if (r.bin_size_mm && !(*r.bin_size_mm >= 0.001 && *r.bin_size_mm <= 10)) __builtin_trap();
  });
  return 0;
}
