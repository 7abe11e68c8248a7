// The I++ DME wire protocol (VDMA 8722; docs/ippdme.md) shared by the client driver
// (hal/ippdme_cmm.hpp) and cmm-sim's I++ server (sim/ippdme_server.hpp): tags, the line grammar
// of commands and replies, the error codes we use and their HAL faults.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "hal/fault.hpp"
#include "hal/motion.hpp"

namespace cmm::hal::ippdme {

inline constexpr int kDefaultPort = 1294;
inline constexpr std::size_t kMaxLineChars = 65536;  // without the CRLF
inline constexpr const char* kVersion = "1.4.3";     // the DME version cmm-sim reports

// "00001"–"99999" on the normal queue, "E0001"–"E9999" on the fast queue; "E0000" is the
// server's own (unsolicited events).
struct Tag {
  bool event = false;
  int number = 0;
  friend bool operator==(const Tag&, const Tag&) = default;
};
inline constexpr Tag kServerTag{true, 0};
std::string format_tag(Tag tag);
std::optional<Tag> parse_tag(std::string_view five);

// An argument or a data item: 1.5, "text", MachineCsy, X(), IJK(0,0,1), Tool.PtMeasPar.Speed(5).
struct Term {
  enum class Kind { number, string, name, call };
  Kind kind = Kind::number;
  double number = 0;
  std::string text;        // the string's content, the name, or the call's dotted name
  std::vector<Term> args;  // a call's arguments
};
Term number_term(double value);
Term call_term(std::string name, std::vector<Term> args = {});
std::string format_term(const Term& term);
std::string format_terms(const std::vector<Term>& terms);  // "X(1.000000000), Y(2.000000000)"
// Numbers carry 9 decimals (1 pm), so every path agrees to 1e-6 mm after a radius compensation.
std::string format_number(double value);

// The named value `name(v)` in a list of items, parsed by name: servers may send them in any order.
const Term* find_call(const std::vector<Term>& items, std::string_view name);
std::optional<double> number_of(const std::vector<Term>& items, std::string_view name);  // X(1.5)
std::optional<Vec3> vector_of(const std::vector<Term>& items, std::string_view name);    // IJK(0,0,1)

// A client line: tag, one space, a method call.
struct Command {
  Tag tag;
  std::string name;
  std::vector<Term> args;
};
std::string format_command(const Command& command);  // no CRLF

// Why a line cannot be taken, as the server's error code (see kError* below) and text; `tag` when
// the line's tag was readable.
struct LineError {
  int code = 0;
  std::string text;
  std::optional<Tag> tag;
};
std::variant<Command, LineError> parse_command(std::string_view line);

// A server line: tag, space, one of & (acknowledged), # (data), % (transaction complete),
// ! (error), and for # and ! what follows.
enum class ReplyKind : char { ack = '&', data = '#', done = '%', error = '!' };
struct ServerError {
  int severity = 0;  // 0 info, 1 warning, 2 the client can repair, 3 the user must act, 9 fatal
  int code = 0;
  std::string method;  // the command it happened in
  std::string text;
};
struct Reply {
  Tag tag;
  ReplyKind kind = ReplyKind::ack;
  std::vector<Term> data;  // #
  ServerError error;       // !
};
std::optional<Reply> parse_reply(std::string_view line);  // nullopt: not a well-formed server line
std::string format_reply(const Reply& reply);             // no CRLF

// Error codes. The ones the issue and the spec's text name are marked (spec); the others are our
// choice where we could not check the spec (docs/ippdme.md lists them as assumptions).
inline constexpr int kErrorBufferFull = 0,           // a line over kMaxLineChars
    kErrorIllegalTag = 1,                            //
    kErrorNoSpace = 2,                               // no space after the tag
    kErrorTransactionAborted = 3,                    // a pending transaction ended by AbortE or an error
    kErrorIllegalCharacter = 4,                      // outside ASCII 32–126
    kErrorProtocol = 5,                              // the line does not parse
    kErrorUnknownCommand = 6,                        //
    kErrorTagInUse = 7,                              // the tag of an open transaction
    kErrorSessionStarted = 8,                        // a second StartSession (spec)
    kErrorNoSession = 9,                             // a command before StartSession
    kErrorEStop = 500,                               // (spec)
    kErrorUnsupported = 501,                         // older servers: GetDMEVersion (spec)
    kErrorBadArguments = 502,                        //
    kErrorOutOfRange = 504,                          // SetProp clamps with a warning (spec)
    kErrorNotHomed = 509,                            //
    kErrorToolNotFound = 510,                        //
    kErrorUseClearAllErrors = 514,                   // after AbortE or a severity ≥ 2 error (spec)
    kErrorNoTouch = 1003,                            // (spec)
    kErrorSurfaceNotFound = 1006,                    // (spec)
    kErrorOutOfVolume = 1008,                        // (spec)
    kErrorMachineLimit = 2500,                       // (spec)
    kErrorCollision = 2504;                          // (spec)

std::string error_text(int code);  // the server's text for a code
// The HAL fault a server error stands for: 0500 EStop, 1003/1006 NoContact, 1008 SoftLimit,
// 2500 HardLimit, 2504 EarlyTrigger, 0509 NotHomed, 0003 Aborted, anything else Protocol.
FaultKind fault_from_error(int code);

}  // namespace cmm::hal::ippdme
