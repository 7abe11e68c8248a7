// Fuzzes cmmd's JSON-RPC entry: a connection's bytes framed into lines as daemon/rpc_session.cpp does
// ('\n', a '\r' before it dropped, blank lines skipped, a last line without '\n' dropped), each line
// through the request gate of the line protocol (RequestGate, Framing::lines: HTTP and, before
// server.auth, anything but a JSON object or array close the connection) as RpcSession::on_line
// does, slow methods run at once as a worker would, with the real server.auth and
// server.subscribe of an RpcServer that is never started, and the application methods' request
// parsing (job.submit, plan.preview, registration.fit, machine.jog, model.upload's base64) behind their roles. The framing itself is
// private to RpcSession and needs a socket, so it is mirrored here, not called.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

#include <asio/io_context.hpp>
#include <spdlog/spdlog.h>

#include "daemon/client/base64.hpp"
#include "daemon/daemon_config.hpp"
#include "daemon/job_request.hpp"
#include "daemon/machine_jog.hpp"
#include "daemon/client/json_rpc.hpp"
#include "daemon/request_gate.hpp"
#include "daemon/rpc_server.hpp"
#include "fuzz_support.hpp"
#include "planner/registration.hpp"

namespace {

using namespace cmm::daemon;
using nlohmann::json;

// The methods of docs/api.md with the roles and slowness service_methods.cpp gives them; what needs
// a machine or the state folder fails as a handler does (−32603), what parses a request parses it.
struct Harness {
  asio::io_context io;
  RpcDispatcher dispatcher;
  DaemonConfig config = daemon_config_from_json(json::object(), "<fuzz>", "/nonexistent");
  std::optional<RpcServer> server;
  std::optional<RequestGate> gate;

  Harness() {
    spdlog::set_level(spdlog::level::off);
    const auto no_machine = [](const json&, RpcContext&) -> json { throw std::runtime_error("no machine in the harness"); };
    const auto empty = [](const json&, RpcContext&) { return json::object(); };
    dispatcher.add("server.info", {Role::none, Work::quick, [this](const json&, RpcContext& ctx) {
                     return json{{"name", "cmmd"}, {"role", to_string(ctx.role())}, {"methods", dispatcher.methods()}};
                   }});
    for (const char* m : {"machine.status", "job.result", "job.report", "job.view"})
      dispatcher.add(m, {Role::observer, Work::blocking, no_machine});
    for (const char* m : {"machine.home", "machine.reset", "machine.qualify"})
      dispatcher.add(m, {Role::operator_, Work::blocking, no_machine});
    for (const char* m : {"machine.stop", "machine.abort", "machine.jog_stop", "server.dashboard", "job.pause", "job.resume",
                          "job.cancel"})
      dispatcher.add(m, {Role::operator_, Work::quick, empty});
    for (const char* m : {"job.get", "job.list"}) dispatcher.add(m, {Role::observer, Work::quick, empty});
    dispatcher.add("job.submit", {Role::operator_, Work::blocking, [this](const json& p, RpcContext&) {
                     const JobRequest r = parse_job_request(p, config);
                     return json{{"model", r.model}, {"name", r.name}};
                   }});
    // As machine_jog.cpp's machine.jog up to the machine: the params checked against the config's limits.
    dispatcher.add("machine.jog", {Role::operator_, Work::blocking, [this](const json& p, RpcContext&) -> json {
                     const JogRequest r = jog_request_from_json(p, config.jog);
                     if (!(r.speed_mm_s > 0 && r.speed_mm_s <= config.jog.max_speed_mm_s)) __builtin_trap();
                     if (r.distance_mm && !(*r.distance_mm > 0 && std::isfinite(*r.distance_mm))) __builtin_trap();
                     if (!(std::abs(r.direction.norm() - 1) < 1e-9)) __builtin_trap();
                     throw std::runtime_error("no machine in the harness");
                   }});
    dispatcher.add("plan.preview", {Role::observer, Work::planning, [this](const json& p, RpcContext&) {
                     const JobRequest r = parse_job_request(p, config, true);
                     return json{{"model", r.model}};
                   }});
    // As service_methods.cpp's registration.fit: the config's plate unless the params give one.
    dispatcher.add("registration.fit", {Role::observer, Work::blocking, [this](const json& p, RpcContext&) {
                     try {
                       json input = p;
                       if (!input.contains("plate")) input["plate"] = cmm::description::to_json(config.plate);
                       return cmm::planner::to_json(
                           cmm::planner::fit_registration(cmm::planner::registration_from_json(input, "registration.fit")));
                     } catch (const cmm::planner::RegistrationError& e) {
                       throw RpcError(rpc_code::registration_error, e.what(), {{"corners", e.corners()}});
                     } catch (const RpcError&) {
                       throw;
                     } catch (const std::exception& e) {
                       throw RpcError(rpc_code::invalid_params, e.what());
                     }
                   }});
    // ModelStore::upload's first step, without the state folder: the chunk's base64, which must
    // decode to bytes that encode back to the same text (the alphabet and padding are strict).
    dispatcher.add("model.upload", {Role::operator_, Work::blocking, [](const json& p, RpcContext&) -> json {
                     if (p.is_object() && p.contains("data") && p["data"].is_string()) {
                       const auto& text = p["data"].get_ref<const std::string&>();
                       std::string bytes;
                       try {
                         bytes = decode_base64(text);
                       } catch (const std::invalid_argument& e) {
                         throw_invalid_param("/data", e.what());
                       }
                       if (encode_base64(bytes) != text) __builtin_trap();
                     }
                     throw std::runtime_error("no state folder in the harness");
                   }});
    dispatcher.add("fuzz.nonstandard", {Role::none, Work::quick, [](const json&, RpcContext&) -> json { throw 7; }});
    ServerOptions options;
    options.tcp_enabled = false;
    options.tokens = {{"observer-token-0123456789", Role::observer}, {"operator-token-0123456789", Role::operator_}};
    // Wrong guesses from earlier inputs must not throttle server.auth for the later ones.
    options.auth_guess_burst = 1e15;
    server.emplace(io, dispatcher, options);
    gate.emplace(dispatcher, GateLimits{}, Framing::lines);
  }

  // RpcSession::on_line: the gate's decision carried out, the reply turned into its wire text; false
  // once the connection would be closed.
  bool on_line(std::string_view line, RpcContext& ctx) const {
    if (gate->refuse_partial(line.substr(0, line.size() / 2), ctx)) {
      // What closes a line's first half closes the whole line.
      if (gate->admit(line, ctx, 0, admit_all).kind != GateDecision::Kind::close) __builtin_trap();
    }
    const GateDecision d = gate->admit(line, ctx, 0, admit_all);
    if (d.kind == GateDecision::Kind::close) {
      // A line that looks like HTTP never reaches a method, whatever the role.
      if (!looks_like_http(line) && ctx.authenticated() && !d.answer) __builtin_trap();
      return false;
    }
    if (d.answer) (void)to_wire(*d.answer);
    if (d.kind == GateDecision::Kind::run) (void)gate->run(d.message, ctx);
    return !ctx.close_requested();
  }
  static std::optional<std::string> admit_all(Work, std::size_t, std::size_t) { return std::nullopt; }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const Harness harness;
  // A socket peer with tokens configured starts with no role; server.auth raises it.
  RpcContext ctx(1, "fuzz", Role::none);
  const std::string_view bytes = cmm::fuzz::text_of(data, size);
  std::size_t begin = 0;
  for (auto end = bytes.find('\n'); end != std::string_view::npos; end = bytes.find('\n', begin)) {
    std::string_view line = bytes.substr(begin, end - begin);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    begin = end + 1;
    if (!harness.on_line(line, ctx)) return 0;
  }
  // The bytes after the last newline: RpcSession drops them at EOF; handle_line is the other entry.
  if (begin < bytes.size()) (void)harness.dispatcher.handle_line(bytes.substr(begin), ctx);
  return 0;
}
