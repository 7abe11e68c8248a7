// The one place that decides what becomes of a JSON-RPC message a transport has framed (a TCP or
// Unix socket line, a WebSocket text frame, an MQTT payload): the size, nesting and batch limits,
// quick methods answered at once, slow ones admitted to the workers within the client's pending
// limit. Each method's role is the dispatcher's, a token's role authenticate()'s (token_book.hpp);
// a transport only frames the message and carries out the decision.
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "daemon/client/json_rpc.hpp"

namespace cmm::daemon {

struct GateLimits {
  std::size_t max_request_bytes = 4u << 20;
  std::size_t max_batch_entries = 128;
  std::size_t max_pending_requests = 64;  // slow requests one client may have running or waiting
};

// How the transport frames messages. Lines (TCP and the Unix socket) have no Origin to check, so
// they take JSON-RPC only: a line that looks like HTTP closes the connection at any time, and before
// authentication so does any line that is not a JSON object or array — a web page in the station's
// browser can reach the port, but never a method.
enum class Framing { lines, messages };

// Whether the workers take `count` requests of `work` with `bytes` of text now; why not, when not.
using AdmitWork = std::function<std::optional<std::string>(Work work, std::size_t count, std::size_t bytes)>;

struct GateDecision {
  enum class Kind {
    nothing,  // a blank message, or notifications only: nothing to send
    answer,   // send `answer`
    run,      // run `message` on the workers (then release `count` and `bytes`), answer with run()
    close,    // send `answer` when there is one, then close the connection for `reason`
  };
  Kind kind = Kind::nothing;
  std::optional<nlohmann::json> answer;
  nlohmann::json message;
  Work work = Work::quick;
  std::size_t count = 0, bytes = 0;
  std::string reason;
};

class RequestGate {
 public:
  RequestGate(const RpcDispatcher& dispatcher, GateLimits limits, Framing framing);

  const GateLimits& limits() const { return limits_; }
  // The answer to a message over max_request_bytes, which closes a stream (its rest cannot be framed).
  nlohmann::json too_large(std::size_t bytes) const;

  // `pending`: the client's requests on the workers now. Quick methods run here, on the caller's thread.
  GateDecision admit(std::string_view text, RpcContext& ctx, std::size_t pending, const AdmitWork& admit_work) const;
  // The line rules above, on the start of a line still coming in: the reason to close now, before
  // the rest arrives (nothing for messages, whose framing has no such rule).
  std::optional<std::string> refuse_partial(std::string_view partial, const RpcContext& ctx) const;
  // The wire text answering a message admit() sent to run, on a worker; nothing for notifications,
  // or when the answer cannot be built (out of memory: logged). Never throws.
  std::optional<std::string> run(const nlohmann::json& message, RpcContext& ctx) const;

 private:
  const RpcDispatcher& dispatcher_;
  GateLimits limits_;
  Framing framing_;
};

// Whether a line starts like an HTTP request line (`POST / HTTP/1.1`) or header (`Origin: …`); reads
// its first 64 bytes at most.
bool looks_like_http(std::string_view line);

}  // namespace cmm::daemon
