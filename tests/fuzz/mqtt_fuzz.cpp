// Fuzzes what cmmd and cmmctl read from an MQTT broker, where anyone the broker lets publish can
// write: a station's api/request/<user> (admission by topic, response topic and token, then the
// request gate and the JSON-RPC answer, as MqttStation runs them; replies only under
// cmmd/clients/<user>/), and on cmmctl's side the job topics turned into notifications and the
// statuses `cmmctl fleet` lists. Input: topic, response topic, token, each ended by '\n', then the payload.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "daemon/client/fleet_listing.hpp"
#include "daemon/client/station_link.hpp"
#include "daemon/mqtt_request.hpp"
#include "daemon/request_gate.hpp"
#include "fuzz_support.hpp"

namespace {

using namespace cmm::daemon;
using nlohmann::json;

constexpr std::size_t kMaxRequestBytes = 4096;
const std::string kOperatorToken = "operator-token-0123456789";

struct Harness {
  RpcDispatcher dispatcher;
  // Wrong guesses from earlier inputs must not throttle the later ones.
  TokenBook tokens{{{"observer-token-0123456789", Role::observer}, {kOperatorToken, Role::operator_}}, 1e15, 1e15};
  RequestGate gate{dispatcher, {.max_request_bytes = kMaxRequestBytes, .max_batch_entries = 128, .max_pending_requests = 16},
                   Framing::messages};

  Harness() {
    spdlog::set_level(spdlog::level::off);
    const auto role_echo = [](const json&, RpcContext& ctx) { return json{{"role", to_string(ctx.role())}}; };
    dispatcher.add("server.info", {Role::none, Work::quick, role_echo});
    dispatcher.add("job.list", {Role::observer, Work::quick, role_echo});
    dispatcher.add("job.submit", {Role::operator_, Work::blocking, role_echo});
  }
};

std::string_view next_field(std::string_view& rest) {
  const std::size_t end = rest.find('\n');
  const std::string_view field = rest.substr(0, end);
  rest = end == std::string_view::npos ? std::string_view() : rest.substr(end + 1);
  return field;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static Harness harness;
  std::string_view rest = cmm::fuzz::text_of(data, size);
  MqttMessage m;
  m.topic = next_field(rest);
  m.response_topic = next_field(rest);
  if (const std::string_view token = next_field(rest); !token.empty()) m.user_properties.emplace_back("token", token);
  m.payload = rest;

  const MqttAdmission a = admit_mqtt_request(m, "cmmd/alpha/api/request/", "cmmd/clients/", harness.tokens);
  // Answered only under the requesting user's replies, never on a wildcard: nothing a requester
  // names makes the station write onto its own status or results, or into another user's replies.
  if (a.kind != MqttAdmission::Kind::ignore &&
      (!m.topic.starts_with("cmmd/alpha/api/request/") || a.user.empty() ||
       m.topic != "cmmd/alpha/api/request/" + a.user || a.user.find_first_of("/+#") != std::string::npos ||
       !m.response_topic.starts_with("cmmd/clients/" + a.user + "/") ||
       m.response_topic.find_first_of("+#") != std::string::npos))
    __builtin_trap();
  if (a.kind == MqttAdmission::Kind::run) {
    // A role comes only from a configured token.
    const Role role = a.context->role();
    const bool operator_token = !m.user_properties.empty() && m.user_properties[0].second == kOperatorToken;
    if (role == Role::operator_ && !operator_token) __builtin_trap();
    if (role != Role::none && m.user_properties.empty()) __builtin_trap();
    const GateDecision d = harness.gate.admit(m.payload, *a.context, 0, [](Work, std::size_t, std::size_t) {
      return std::optional<std::string>();
    });
    if (d.kind == GateDecision::Kind::run) {
      if (m.payload.size() > kMaxRequestBytes) __builtin_trap();
      (void)harness.gate.run(d.message, *a.context);
    } else if (d.answer) {
      (void)to_wire(*d.answer);
    }
  } else if (a.kind == MqttAdmission::Kind::refuse) {
    if (!a.refusal.contains("error")) __builtin_trap();
  }

  if (const auto line = job_notification(m.topic, m.payload)) {
    const json n = json::parse(*line);  // must be JSON a client reads back
    if (!n.at("params").is_object() || (n.at("method") != "job.state" && n.at("method") != "job.progress")) __builtin_trap();
  }
  if (const auto status = fleet_entry(m.topic, "cmmd", m.payload)) {
    if (status->at("station").get<std::string>().find('/') != std::string::npos) __builtin_trap();
    (void)fleet_line(*status);
  }
  return 0;
}
