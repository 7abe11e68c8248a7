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

// The error list of I++ DME 1.4.3 §8.2: the number, the default severity class (§8.1) and the text
// a server must send with it. Only the entries either side of the wire uses are named here.
inline constexpr int kErrorBufferFull = 0,      // a line over kMaxLineChars
    kErrorIllegalTag = 1,                       // a malformed tag, or the tag of an open transaction
    kErrorNoSpace = 2,                          // no space at column 6
    kErrorTransactionAborted = 6,               // a pending transaction ended by AbortE or an error (§6.2.5)
    kErrorIllegalCharacter = 7,                 // outside ASCII 32–126
    kErrorProtocol = 8,                         // a second StartSession (§6.3.1); a line that does not parse
    kErrorEStop = 500,                          //
    kErrorUnsupported = 501,                    // a method the server does not have (GetDMEVersion, §6.3.1.14)
    kErrorIncorrectArguments = 502,             //
    kErrorOutOfRange = 504,                     // SetProp outside its range: a warning (§6.3.1.11)
    kErrorArgumentNotRecognized = 505,          //
    kErrorIllegalCommand = 507,                 // NIST's server: a motion before Home
    kErrorBadContext = 508,                     //
    kErrorBadArgument = 509,                    //
    kErrorBadProperty = 510,                    // OnMoveReportE with Time < 0.1 (§6.3.2.7)
    kErrorProcessing = 511,                     //
    kErrorNoDaemons = 512,                      // StopAllDaemons with none running: a warning
    kErrorNoSuchDaemon = 513,                   // StopDaemon of a tag that runs none
    kErrorUseClearAllErrors = 514,              // anything but the error methods in an error state
    kErrorDaemonExists = 515,                   // a second OnMoveReportE
    kErrorMachineInError = 1000,                //
    kErrorIllegalTouch = 1001,                  //
    kErrorNoTouch = 1003,                       //
    kErrorHome = 1005,                          //
    kErrorSurfaceNotFound = 1006,               //
    kErrorOutOfVolume = 1008,                   //
    kErrorToolNotFound = 1502,                  // ChangeTool of a name the server does not have
    kErrorToolNotCalibrated = 2000,             //
    kErrorMachineLimit = 2500,                  //
    kErrorCollision = 2504;                     //

// §8.2's text and default severity for a code; "Error <n>" and 3 for one the list does not have.
std::string error_text(int code);
int default_severity(int code);
// The HAL fault a server error stands for: 0500 EStop, 1003/1006 NoContact, 1008 SoftLimit,
// 2500 HardLimit, 2504 EarlyTrigger, 0006 Aborted, anything else Protocol (0507 is "Illegal
// command", which a server may say for more than a missing Home: the driver decides with IsHomed).
FaultKind fault_from_error(int code);

}  // namespace cmm::hal::ippdme
