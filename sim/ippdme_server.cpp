// The I++ DME server: a receiving thread that reads lines, refuses what cannot be accepted, runs the
// fast queue itself and hands the normal queue to a worker that runs it on the machine in order;
// a reporter thread for OnMoveReportE; and, under a reply delay, an outbox thread that writes the
// lines on numeric tags late.
#include "sim/ippdme_server.hpp"

#include <poll.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <initializer_list>
#include <stdexcept>
#include <system_error>
#include <variant>

#include <asio.hpp>

namespace cmm::sim {

namespace ipp = hal::ippdme;
using ipp::ReplyKind;
using ipp::Tag;
using ipp::Term;

namespace {

using SteadyClock = std::chrono::steady_clock;
constexpr int kPollMs = 20;                                // how soon serve() sees shutdown()
constexpr auto kReportTick = std::chrono::milliseconds(10);  // the move-report daemon's look at the machine
constexpr double kMinReportPeriodS = 0.1;  // §6.3.2.7: at most 10 reports a second, Time ≥ 0.1
constexpr double kMinPositive = 0.001;  // what a property with an open lower bound 0 is clamped up to

enum class Queue { normal, fast };
struct CommandInfo {
  std::string_view name;
  Queue queue;
  bool counted;  // a link-fault command: motion and state changes, not queries
  bool moves;    // runs a motion: accept_command() before it, so that a stop() from then on stops it
};
constexpr CommandInfo kCommands[] = {
    {"StartSession", Queue::normal, false, false},  {"EndSession", Queue::normal, false, false},
    {"ClearAllErrors", Queue::normal, true, false}, {"GetDMEVersion", Queue::normal, false, false},
    {"IsHomed", Queue::normal, false, false},       {"Home", Queue::normal, true, true},
    {"EnumTools", Queue::normal, false, false},     {"ChangeTool", Queue::normal, false, false},
    {"GetProp", Queue::normal, false, false},       {"SetProp", Queue::normal, false, false},
    {"SetCoordSystem", Queue::normal, false, false}, {"GoTo", Queue::normal, true, true},
    {"OnPtMeasReport", Queue::normal, false, false}, {"PtMeas", Queue::normal, true, true},
    {"Get", Queue::normal, false, false},           {"AbortE", Queue::fast, false, false},
    {"GetErrStatusE", Queue::fast, false, false},   {"GetPropE", Queue::fast, false, false},
    {"OnMoveReportE", Queue::fast, false, false},   {"StopDaemon", Queue::fast, false, false},
    {"StopAllDaemons", Queue::fast, false, false},
};
const CommandInfo* find_command(std::string_view name) {
  for (const CommandInfo& c : kCommands)
    if (c.name == name) return &c;
  return nullptr;
}

// The properties SetProp and GetProp know, and the range each is clamped to.
constexpr const char* kProbeSpeed = "Tool.PtMeasPar.Speed";
constexpr const char* kApproach = "Tool.PtMeasPar.Approach";
constexpr const char* kSearch = "Tool.PtMeasPar.Search";
constexpr const char* kRetract = "Tool.PtMeasPar.Retract";
constexpr const char* kGoToSpeed = "Tool.GoToPar.Speed";
constexpr const char* kGoToAccel = "Tool.GoToPar.Accel";
struct Range {
  double low, high;
  bool open_low;  // (low, high]: a value ≤ low is clamped to low + kMinPositive
};
std::optional<Range> range_of(std::string_view name, const description::MachineDescription& m) {
  if (name == kProbeSpeed) return Range{0, 20, true};
  if (name == kApproach) return Range{0, 50, false};
  if (name == kSearch) return Range{0, 100, true};
  if (name == kRetract) return Range{0, 50, false};
  if (name == kGoToSpeed) return Range{0, m.max_speed_mm_s, true};
  if (name == kGoToAccel) return Range{0, m.max_accel_mm_s2, true};
  return std::nullopt;
}
double clamp_to(const Range& r, double v) {
  if (v > r.high) return r.high;
  if (r.open_low ? v <= r.low : v < r.low) return r.open_low ? r.low + kMinPositive : r.low;
  return v;
}

// A command's arguments that do not fit it: answered after the ack, 0502 unless the specification
// names another error for the case (0510 for a bad OnMoveReportE property).
class ArgumentError : public std::runtime_error {
 public:
  explicit ArgumentError(const std::string& what, int code = ipp::kErrorIncorrectArguments)
      : std::runtime_error(what), code_(code) {}
  int code() const { return code_; }

 private:
  int code_;
};

// Error texts are "strings" on the wire: printable ASCII, no quote (the grammar has no escapes),
// and short. The machine's messages carry a few UTF-8 signs; each becomes one ASCII stand-in.
std::string wire_text(std::string_view text) {
  std::string out;
  for (std::size_t i = 0; i < text.size() && out.size() < 300; ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c == '"') out += '\'';
    else if (c >= 32 && c <= 126) out += static_cast<char>(c);
    else if (c < 0x80) out += ' ';
    else if (c >= 0xC0) out += text.substr(i, 3) == "\u2013" ? "-" : text.substr(i, 3) == "\u2265" ? ">=" : "?";
    // 0x80–0xBF: the rest of a sign already written
  }
  return out;
}

// "50", "0.5": the value as the client wrote it, for the clamp warning.
std::string shortest(double v) {
  char text[32];
  const auto end = std::to_chars(text, text + sizeof text, v).ptr;
  return std::string(text, end);
}

Term string_term(std::string text) {
  Term t;
  t.kind = Term::Kind::string;
  t.text = std::move(text);
  return t;
}
// Flags are integers on the wire, IsHomed(1), not 1.000000000: a bare word prints as it is.
Term flag_term(bool on) {
  Term t;
  t.kind = Term::Kind::name;
  t.text = on ? "1" : "0";
  return t;
}

ipp::Reply reply_of(Tag tag, ReplyKind kind, std::vector<Term> data = {}) {
  ipp::Reply r;
  r.tag = tag;
  r.kind = kind;
  r.data = std::move(data);
  return r;
}
ipp::Reply error_of(Tag tag, int severity, int code, const std::string& method, const std::string& text) {
  ipp::Reply r = reply_of(tag, ReplyKind::error);
  r.error = {severity, code, method, wire_text(text)};
  return r;
}
ipp::Reply aborted_reply(const std::string& method, Tag tag) {
  return error_of(tag, ipp::default_severity(ipp::kErrorTransactionAborted), ipp::kErrorTransactionAborted, method,
                  ipp::error_text(ipp::kErrorTransactionAborted));
}

// The line corrupt_reply_at_command sends instead: its marker replaced and its end cut off, so no
// client can take it for an I++ line.
std::string garbled(std::string line) {
  if (line.size() > 6) line[6] = '?';
  line.resize(std::max<std::size_t>(7, line.size() / 2));
  return line;
}

int axis_index(std::string_view name) { return name == "X" ? 0 : name == "Y" ? 1 : name == "Z" ? 2 : -1; }

std::string joined(std::initializer_list<std::string_view> names) {
  std::string out;
  for (std::string_view n : names) out += (out.empty() ? "" : ", ") + std::string(n) + "()";
  return out;
}

// The names of empty items, as in Get(X(), Y()) or OnPtMeasReport(X(), IJK()): each one of
// `allowed`, once, and at least one.
std::vector<std::string> item_names(const std::vector<Term>& args, std::initializer_list<std::string_view> allowed) {
  std::vector<std::string> names;
  for (const Term& t : args) {
    const bool known = std::find(allowed.begin(), allowed.end(), t.text) != allowed.end();
    if (t.kind != Term::Kind::call || !t.args.empty() || !known)
      throw ArgumentError("expected items among " + joined(allowed) + ", not " + ipp::format_term(t));
    if (std::find(names.begin(), names.end(), t.text) != names.end()) throw ArgumentError(t.text + "() asked twice");
    names.push_back(t.text);
  }
  if (names.empty()) throw ArgumentError("no items; expected some of " + joined(allowed));
  return names;
}

// An item with one number, as in X(12.5) or Time(0.1).
double number_in(const Term& t) {
  if (t.kind != Term::Kind::call || t.args.size() != 1 || t.args[0].kind != Term::Kind::number)
    throw ArgumentError(t.text + " takes one number, as in " + t.text + "(1.5), not " + ipp::format_term(t));
  return t.args[0].number;
}

// The daemon's items: axes, and cmm-sim's Clock() (the machine clock, s).
std::vector<Term> position_terms(const std::vector<std::string>& items, const hal::MachineStatus& s) {
  std::vector<Term> out;
  for (const std::string& a : items)
    out.push_back(ipp::call_term(a, {ipp::number_term(a == "Clock" ? s.t_s : s.position[axis_index(a)])}));
  return out;
}

int code_of(hal::FaultKind kind) {
  switch (kind) {
    case hal::FaultKind::soft_limit: return ipp::kErrorOutOfVolume;
    case hal::FaultKind::early_trigger: return ipp::kErrorCollision;
    case hal::FaultKind::hard_limit: return ipp::kErrorMachineLimit;
    case hal::FaultKind::not_homed: return ipp::kErrorIllegalCommand;
    case hal::FaultKind::aborted: return ipp::kErrorTransactionAborted;
    case hal::FaultKind::no_contact: return ipp::kErrorNoTouch;
    case hal::FaultKind::estop: return ipp::kErrorEStop;
    default: return ipp::kErrorProtocol;  // a link fault: the simulated machine has none
  }
}

}  // namespace

struct IppDmeServer::Link {
  asio::io_context io;
  asio::ip::tcp::acceptor acceptor{io};
  asio::ip::tcp::socket socket{io};
};

IppDmeServer::IppDmeServer(SimulatedMachine& machine, const FaultInjection& faults, const IppDmeEndpoint& endpoint,
                           hal::ProtocolLog* log, IppDmeOptions options)
    : machine_(machine),
      faults_(faults),
      log_(log),
      options_(options),
      description_(machine.info()),
      link_(std::make_unique<Link>()) {
  const std::string where = endpoint.host + " port " + std::to_string(endpoint.port);
  try {
    asio::ip::tcp::resolver resolver(link_->io);
    const auto found = resolver.resolve(endpoint.host, std::to_string(endpoint.port),
                                        asio::ip::resolver_base::passive | asio::ip::resolver_base::numeric_service);
    const asio::ip::tcp::endpoint at = found.begin()->endpoint();
    link_->acceptor.open(at.protocol());
    link_->acceptor.set_option(asio::socket_base::reuse_address(true));
    link_->acceptor.bind(at);
    link_->acceptor.listen();
    link_->acceptor.non_blocking(true);  // serve() polls: a client gone before accept() must not block it
    port_ = link_->acceptor.local_endpoint().port();
  } catch (const std::system_error& e) {
    throw std::runtime_error("cannot serve I++ DME on " + where + ": " + e.what());
  }
  reset_session_settings_locked();  // no thread yet
  worker_ = std::thread([this] { worker_loop(); });
  reporter_ = std::thread([this] { report_loop(); });
  if (faults_.reply_delay_s > 0) outbox_thread_ = std::thread([this] { outbox_loop(); });
}

IppDmeServer::~IppDmeServer() {
  shutdown();
  {
    std::lock_guard lock(mutex_);
    queue_.clear();
    if (current_) machine_.stop();  // the worker must not wait for a long motion to end
  }
  for (std::thread* t : {&worker_, &reporter_, &outbox_thread_})
    if (t->joinable()) t->join();
}

void IppDmeServer::shutdown() {
  running_ = false;
  std::lock_guard lock(mutex_);
  work_wake_.notify_all();
  report_wake_.notify_all();
  outbox_wake_.notify_all();
}

void IppDmeServer::note(const std::string& text) {
  if (log_) log_->note(text);
}

// ---------------------------------------------------------------------------------------------
// The receiving thread

void IppDmeServer::serve() {
  std::array<char, 4096> buffer;
  while (running_) {
    pollfd fds[2] = {{link_->socket.is_open() ? link_->socket.native_handle() : -1, POLLIN, 0},
                     {link_->acceptor.native_handle(), POLLIN, 0}};
    const int ready = ::poll(fds, 2, kPollMs);
    if (ready < 0 && errno != EINTR)
      throw std::runtime_error(std::string("I++ DME: waiting for the client failed: ") + std::strerror(errno));
    if (ready <= 0) continue;
    if (fds[0].revents != 0) {
      asio::error_code ec;
      const std::size_t n = link_->socket.read_some(asio::buffer(buffer), ec);
      if (ec) end_connection(ec == asio::error::eof ? "the client closed the connection" : "reading failed: " + ec.message());
      else receive(std::string_view(buffer.data(), n));
      // A new connection waits until the client has no more to read: one that sent its last bytes
      // and hung up just before the next one connected is gone by then, and the next one is served,
      // not turned away.
      continue;
    }
    if (fds[1].revents != 0) accept_client();
  }
  end_connection("cmm-sim is shutting down");
}

void IppDmeServer::accept_client() {
  asio::error_code ec;
  asio::ip::tcp::socket client(link_->io);
  link_->acceptor.accept(client, ec);
  if (ec) return;  // gone before we took it; the next poll tries again
  const auto peer = client.remote_endpoint(ec);
  const std::string who = ec ? std::string("an unknown peer") : peer.address().to_string() + ":" + std::to_string(peer.port());
  if (link_->socket.is_open()) {
    note("refused a second connection from " + who + ": one session at a time");
    client.close(ec);
    return;
  }
  client.non_blocking(false, ec);
  client.set_option(asio::ip::tcp::no_delay(true), ec);
  {
    std::lock_guard lock(mutex_);
    std::lock_guard write_lock(write_mutex_);
    link_->socket = std::move(client);
    ++connection_;
    session_open_ = error_state_ = false;
  }
  note("client " + who + " connected");
}

void IppDmeServer::end_connection(const std::string& why) {
  if (!link_->socket.is_open()) return;
  asio::error_code ec;
  link_->socket.shutdown(asio::socket_base::shutdown_both, ec);  // wakes a writer blocked on a client that stopped reading
  {
    std::lock_guard lock(mutex_);
    {
      std::lock_guard write_lock(write_mutex_);
      link_->socket.close(ec);
      ++connection_;
    }
    // Everything of the session goes; the machine keeps its state.
    queue_.clear();
    outbox_.clear();
    if (current_) current_->ended = true;
    machine_.stop();  // the running motion, if any; an idle machine ignores it
    daemon_.reset();
    session_open_ = error_state_ = false;
    report_wake_.notify_all();
  }
  if (!partial_.empty() && !discarding_)
    note("dropped a half line of " + std::to_string(partial_.size()) + " characters: " + partial_.substr(0, 80));
  std::string().swap(partial_);
  discarding_ = drop_now_ = false;
  note("client disconnected: " + why);
}

void IppDmeServer::receive(std::string_view bytes) {
  for (const char c : bytes) {
    if (discarding_) {
      discarding_ = c != '\n';
      continue;
    }
    if (c != '\n') {
      partial_.push_back(c);
      // kMaxLineChars and a CR may still make a line; one more byte cannot.
      if (partial_.size() > ipp::kMaxLineChars + 1) {
        line_too_long(partial_);
        std::string().swap(partial_);
        discarding_ = true;
      }
      continue;
    }
    std::string line;
    line.swap(partial_);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.size() > ipp::kMaxLineChars) line_too_long(line);
    else take_line(line);
    if (drop_now_) {
      end_connection("drop_link_after_commands: the link is cut");
      return;
    }
  }
}

void IppDmeServer::line_too_long(std::string_view head) {
  note("a line over " + std::to_string(ipp::kMaxLineChars) + " characters, starting \"" +
       std::string(head.substr(0, 40)) + "\": answered 0000 and discarded up to its LF");
  const auto tag = ipp::parse_tag(head.substr(0, 5));
  std::lock_guard lock(mutex_);
  refuse_locked(tag.value_or(ipp::kServerTag), "", ipp::kErrorBufferFull,
                ipp::error_text(ipp::kErrorBufferFull) + ": a line over " + std::to_string(ipp::kMaxLineChars) +
                    " characters, discarded");
}

void IppDmeServer::take_line(std::string_view line) {
  if (log_) log_->received(line);
  if (line.empty()) return;  // a stray CRLF asks nothing
  const auto parsed = ipp::parse_command(line);
  std::lock_guard lock(mutex_);
  if (const auto* e = std::get_if<ipp::LineError>(&parsed))
    return refuse_locked(e->tag.value_or(ipp::kServerTag), "", e->code, ipp::error_text(e->code) + ": " + e->text);
  const ipp::Command& c = std::get<ipp::Command>(parsed);
  const CommandInfo* info = find_command(c.name);
  if (!info) return refuse_locked(c.tag, c.name, ipp::kErrorUnsupported, ipp::error_text(ipp::kErrorUnsupported));
  const bool fast = info->queue == Queue::fast;
  if (c.tag == ipp::kServerTag || c.tag.event != fast)
    return refuse_locked(c.tag, c.name, ipp::kErrorIllegalTag,
                         ipp::error_text(ipp::kErrorIllegalTag) + ": " + c.name +
                             (fast ? " is a fast-queue command, its tag E0001-E9999" : " takes a tag 00001-99999"));
  if (tag_open_locked(c.tag))
    return refuse_locked(c.tag, c.name, ipp::kErrorIllegalTag, ipp::error_text(ipp::kErrorIllegalTag) + ": " +
                         ipp::format_tag(c.tag) + " is the tag of an open transaction", false);
  if (!session_open_ && c.name != "StartSession")
    return refuse_locked(c.tag, c.name, ipp::kErrorProtocol, ipp::error_text(ipp::kErrorProtocol) + ": StartSession first");
  if (session_open_ && c.name == "StartSession")
    return refuse_locked(c.tag, c.name, ipp::kErrorProtocol,
                         ipp::error_text(ipp::kErrorProtocol) + ": a session is active; EndSession first");
  if (error_state_ && !fast && c.name != "ClearAllErrors" && c.name != "StartSession") {
    send_locked(reply_of(c.tag, ReplyKind::ack));
    error_locked(c.tag, ipp::default_severity(ipp::kErrorUseClearAllErrors), ipp::kErrorUseClearAllErrors, c.name,
                 ipp::error_text(ipp::kErrorUseClearAllErrors));
    return send_locked(reply_of(c.tag, ReplyKind::done));
  }

  int number = 0;
  if (info->counted) {
    number = ++commands_;
    if (faults_.drop_link_after_commands > 0 && number > faults_.drop_link_after_commands && !dropped_) {
      dropped_ = drop_now_ = true;  // once: the cable is pulled, and this command is lost with it
      note("drop_link_after_commands: command " + std::to_string(number) + " (" + c.name + ") is lost with the link");
      return;
    }
  }
  if (fast) return run_fast_locked(c);
  // The session and the error state change as the commands are accepted, so that the commands a
  // client sends right behind them are judged as it means them.
  if (c.name == "StartSession") session_open_ = true, error_state_ = false;
  else if (c.name == "EndSession") session_open_ = false;
  else if (c.name == "ClearAllErrors") error_state_ = false;
  send_locked(reply_of(c.tag, ReplyKind::ack), number > 0);
  queue_.push_back(Transaction{c.tag, c.name, c.args, number, connection_, false});
  work_wake_.notify_all();
}

void IppDmeServer::run_fast_locked(const ipp::Command& c) {
  const auto ack = [&] { send_locked(reply_of(c.tag, ReplyKind::ack)); };
  const auto done = [&] { send_locked(reply_of(c.tag, ReplyKind::done)); };
  try {
    if (c.name == "AbortE") {
      if (!c.args.empty()) throw ArgumentError("AbortE takes no arguments");
      // §6.3.1.5: acknowledged, the running and pending transactions aborted, then its own `%`.
      ack();
      machine_.stop();  // a controlled stop: the position and homing are kept
      if (current_ && !current_->ended) abort_locked(*current_);
      enter_error_state_locked(true);
      return done();
    }
    if (c.name == "GetErrStatusE") {
      if (!c.args.empty()) throw ArgumentError("GetErrStatusE takes no arguments");
      ack();
      send_locked(reply_of(c.tag, ReplyKind::data, {ipp::call_term("ErrStatus", {flag_term(error_state_)})}));
      return done();
    }
    if (c.name == "GetPropE") {
      std::vector<Term> items = read_properties_locked(c.args);
      ack();
      send_locked(reply_of(c.tag, ReplyKind::data, std::move(items)));
      return done();
    }
    if (c.name == "OnMoveReportE") return start_daemon_locked(c);
    return stop_daemon_locked(c);
  } catch (const ArgumentError& e) {
    // Accepted, then refused: the arguments are the command's business, not the line's.
    ack();
    error_locked(c.tag, ipp::default_severity(e.code()), e.code(), c.name, ipp::error_text(e.code()) + ": " + e.what());
    done();
    if (ipp::default_severity(e.code()) >= 2) enter_error_state_locked();
  }
}

void IppDmeServer::start_daemon_locked(const ipp::Command& c) {
  Daemon d;
  d.tag = c.tag;
  for (const Term& t : c.args) {
    if (t.text == "Time" && t.kind == Term::Kind::call) {
      const double s = number_in(t);
      if (!(s >= kMinReportPeriodS))
        throw ArgumentError("Time(" + shortest(s) + "): at least 0.1 s, at most 10 reports a second", ipp::kErrorBadProperty);
      d.every_s = s;
    } else if (t.text == "Dis" && t.kind == Term::Kind::call) {
      const double mm = number_in(t);
      if (!(mm > 0)) throw ArgumentError("Dis(" + shortest(mm) + "): a distance above 0", ipp::kErrorBadProperty);
      d.beyond_mm = mm;
    } else if (t.kind == Term::Kind::call && t.args.empty() && (axis_index(t.text) >= 0 || t.text == "Clock") &&
               std::find(d.axes.begin(), d.axes.end(), t.text) == d.axes.end()) {
      d.axes.push_back(t.text);
    } else {
      throw ArgumentError("OnMoveReportE takes Time(s), Dis(d), X(), Y(), Z(), Clock(), not " + ipp::format_term(t),
                          ipp::kErrorBadProperty);
    }
  }
  if (daemon_)
    throw ArgumentError("a daemon runs on " + ipp::format_tag(daemon_->tag) + "; StopDaemon or StopAllDaemons first",
                        ipp::kErrorDaemonExists);
  if (std::none_of(d.axes.begin(), d.axes.end(), [](const std::string& a) { return a != "Clock"; }))
    d.axes.insert(d.axes.begin(), {"X", "Y", "Z"});
  d.id = ++daemons_;
  // Complete at once: the reports that follow carry its tag (§6.2.4's example).
  send_locked(reply_of(c.tag, ReplyKind::ack));
  send_locked(reply_of(c.tag, ReplyKind::done));
  daemon_ = d;
  report_wake_.notify_all();
}

void IppDmeServer::stop_daemon_locked(const ipp::Command& c) {
  if (c.name == "StopDaemon") {
    const bool word = c.args.size() == 1 && (c.args[0].kind == Term::Kind::name || c.args[0].kind == Term::Kind::string);
    const auto tag = word ? ipp::parse_tag(c.args[0].text) : std::nullopt;
    if (!tag || !tag->event) throw ArgumentError("StopDaemon takes the daemon's tag, as in StopDaemon(E0001)");
    if (!daemon_ || !(daemon_->tag == *tag))
      throw ArgumentError("no daemon runs on tag " + ipp::format_tag(*tag), ipp::kErrorNoSuchDaemon);
  } else if (!c.args.empty()) {
    throw ArgumentError("StopAllDaemons takes no arguments");
  }
  send_locked(reply_of(c.tag, ReplyKind::ack));
  if (!daemon_)
    error_locked(c.tag, ipp::default_severity(ipp::kErrorNoDaemons), ipp::kErrorNoDaemons, c.name,
                 ipp::error_text(ipp::kErrorNoDaemons));
  daemon_.reset();  // no report follows this command's `%` (§6.3.1.4)
  report_wake_.notify_all();
  send_locked(reply_of(c.tag, ReplyKind::done));
}

// ---------------------------------------------------------------------------------------------
// The worker

void IppDmeServer::worker_loop() {
  for (;;) {
    Transaction tx;
    {
      std::unique_lock lock(mutex_);
      work_wake_.wait(lock, [&] { return !running_ || !queue_.empty(); });
      if (!running_) return;
      tx = std::move(queue_.front());
      queue_.pop_front();
      current_ = tx;
      if (find_command(tx.method)->moves) machine_.accept_command();  // an AbortE from now on stops it
    }
    execute(tx);
    std::lock_guard lock(mutex_);
    current_.reset();
  }
}

void IppDmeServer::execute(const Transaction& tx) {
  try {
    run_normal(tx);
  } catch (const ArgumentError& e) {
    reply_error(e.code(), ipp::error_text(e.code()) + ": " + e.what());
  } catch (const hal::EStop&) {
    // The event first, so a client hears of the e-stop whatever it is waiting for.
    std::lock_guard lock(mutex_);
    if (tx.connection != connection_) return;
    const std::string text = ipp::error_text(ipp::kErrorEStop);
    report_end_of_motion_locked();
    send_locked(error_of(ipp::kServerTag, ipp::default_severity(ipp::kErrorEStop), ipp::kErrorEStop, tx.method, text));
    if (current_ && !current_->ended) fail_locked(*current_, ipp::kErrorEStop, text);
  } catch (const hal::Fault& f) {
    const int code = code_of(f.kind());
    if (code == ipp::kErrorTransactionAborted) return reply_error(code, ipp::error_text(code));
    // The machine's message without its kind's name ("SoftLimit: "): the code says that.
    std::string_view detail = f.what();
    if (const std::string kind = std::string(hal::to_string(f.kind())) + ": "; detail.starts_with(kind))
      detail.remove_prefix(kind.size());
    reply_error(code, ipp::error_text(code) + ": " + std::string(detail));
  } catch (const std::exception& e) {
    // The machine refused a value the grammar let through (a non-finite target, say).
    reply_error(ipp::kErrorIncorrectArguments, ipp::error_text(ipp::kErrorIncorrectArguments) + ": " + e.what());
  }
}

void IppDmeServer::run_normal(const Transaction& tx) {
  const std::string& m = tx.method;
  const std::vector<Term>& args = tx.args;
  const auto no_arguments = [&] {
    if (!args.empty()) throw ArgumentError(m + " takes no arguments");
  };
  if (m == "StartSession") {
    no_arguments();
    {
      std::lock_guard lock(mutex_);
      reset_session_settings_locked();
    }
    clear_machine_errors();  // StartSession implies ClearAllErrors
    return reply_done();
  }
  if (m == "EndSession") {
    no_arguments();
    {
      // §6.3.1.2: no daemon survives the session.
      std::lock_guard lock(mutex_);
      if (current_ && !current_->ended) {
        daemon_.reset();
        report_wake_.notify_all();
      }
    }
    return reply_done();
  }
  if (m == "ClearAllErrors") {
    no_arguments();
    clear_machine_errors();
    return reply_done();
  }
  if (m == "GetDMEVersion") {
    no_arguments();
    reply_data({ipp::call_term("DMEVersion", {string_term(ipp::kVersion)})});
    return reply_done();
  }
  if (m == "IsHomed") {
    no_arguments();
    reply_data({ipp::call_term("IsHomed", {flag_term(machine_.status().homed)})});
    return reply_done();
  }
  if (m == "Home") {
    no_arguments();
    machine_.home();
    return reply_done();
  }
  if (m == "EnumTools") {
    no_arguments();
    for (const auto& tip : machine_.info().tips) reply_data({string_term(tip.id)});
    return reply_done();
  }
  if (m == "ChangeTool") {
    if (args.size() != 1 || (args[0].kind != Term::Kind::string && args[0].kind != Term::Kind::name))
      throw ArgumentError("ChangeTool takes one tool name, as in ChangeTool(\"T1\")");
    const std::string& id = args[0].text;
    const auto tips = machine_.info().tips;
    if (std::none_of(tips.begin(), tips.end(), [&](const auto& t) { return t.id == id; }))
      return reply_error(ipp::kErrorToolNotFound,
                         ipp::error_text(ipp::kErrorToolNotFound) + ": no tool " + id + " (EnumTools lists them)");
    machine_.select_tip(id);
    return reply_done();
  }
  if (m == "GetProp") {
    std::vector<Term> items;
    {
      std::lock_guard lock(mutex_);
      items = read_properties_locked(args);
    }
    reply_data(std::move(items));
    return reply_done();
  }
  if (m == "SetProp") return set_properties(args);
  if (m == "SetCoordSystem") {
    // PartCsy equals MachineCsy here: no alignment is ever defined.
    if (args.size() != 1 || args[0].kind != Term::Kind::name || (args[0].text != "MachineCsy" && args[0].text != "PartCsy"))
      throw ArgumentError("SetCoordSystem takes MachineCsy or PartCsy");
    return reply_done();
  }
  if (m == "GoTo") return go_to(args);
  if (m == "OnPtMeasReport") {
    std::vector<std::string> items = item_names(args, {"X", "Y", "Z", "IJK", "ER", "Clock"});
    {
      std::lock_guard lock(mutex_);
      pt_report_ = std::move(items);
    }
    return reply_done();
  }
  if (m == "PtMeas") return pt_meas(args);
  if (m == "Get") {
    const std::vector<std::string> items = item_names(args, {"X", "Y", "Z", "Clock"});
    const hal::MachineStatus s = machine_.status();
    std::vector<Term> data;
    for (const std::string& item : items)
      data.push_back(ipp::call_term(item, {ipp::number_term(item == "Clock" ? s.t_s : s.position[axis_index(item)])}));
    reply_data(std::move(data));
    return reply_done();
  }
  throw std::logic_error("IppDmeServer: the command table names " + m + " but nothing runs it");
}

void IppDmeServer::set_properties(const std::vector<Term>& args) {
  // Every item is checked before any is set: a refused SetProp changes nothing.
  for (const Term& t : args) {
    if (t.kind != Term::Kind::call || t.args.size() != 1 || t.args[0].kind != Term::Kind::number)
      throw ArgumentError("SetProp takes Name(value) items, as in SetProp(Tool.PtMeasPar.Speed(5)), not " + ipp::format_term(t));
    if (!range_of(t.text, description_))
      throw ArgumentError("no property " + t.text + "; SetProp knows Tool.PtMeasPar.Speed, Approach, Search, Retract, "
                          "Tool.GoToPar.Speed, Accel");
  }
  if (args.empty()) throw ArgumentError("SetProp needs at least one property");
  std::vector<std::string> warnings;
  {
    std::lock_guard lock(mutex_);
    for (const Term& t : args) {
      const double asked = t.args[0].number, value = clamp_to(*range_of(t.text, description_), asked);
      properties_[t.text] = value;
      if (value != asked) warnings.push_back(t.text + " " + shortest(asked) + " out of range: clamped to " + shortest(value));
    }
  }
  // Real servers clamp with a warning: the transaction still ends with %.
  for (const std::string& w : warnings) reply_warning(ipp::kErrorOutOfRange, w);
  reply_done();
}

void IppDmeServer::go_to(const std::vector<Term>& args) {
  Vec3 target = machine_.status().position;  // the axes not named keep their value
  for (const Term& t : args) {
    const int axis = axis_index(t.text);
    if (t.kind != Term::Kind::call || axis < 0) throw ArgumentError("GoTo takes X(x), Y(y), Z(z), not " + ipp::format_term(t));
    target[axis] = number_in(t);
  }
  if (args.empty()) throw ArgumentError("GoTo needs at least one of X(), Y(), Z()");
  double speed = 0;
  {
    std::lock_guard lock(mutex_);
    speed = properties_.at(kGoToSpeed);
  }
  machine_.move({target, speed});
  reply_done();
}

void IppDmeServer::pt_meas(const std::vector<Term>& args) {
  Vec3 nominal = machine_.status().position;
  std::optional<Vec3> ijk;
  for (const Term& t : args) {
    if (t.kind == Term::Kind::call && t.text == "IJK") {
      ijk = ipp::vector_of({t}, "IJK");
      if (!ijk) throw ArgumentError("IJK takes three numbers, as in IJK(0, 0, 1), not " + ipp::format_term(t));
      continue;
    }
    const int axis = axis_index(t.text);
    if (t.kind != Term::Kind::call || axis < 0)
      throw ArgumentError("PtMeas takes X(x), Y(y), Z(z), IJK(i, j, k), not " + ipp::format_term(t));
    nominal[axis] = number_in(t);
  }
  if (!ijk) throw ArgumentError("PtMeas needs IJK(i, j, k), the surface normal out of the material");
  if (!(ijk->norm() > 1e-9)) throw ArgumentError("IJK(0, 0, 0) is no direction");
  const Vec3 n = ijk->normalized();

  const description::MachineDescription info = machine_.info();
  double radius = 0;
  for (const auto& tip : info.tips)
    if (tip.id == info.active_tip) radius = tip.ball_radius_mm;
  hal::ProbeMove move;
  std::vector<std::string> report;
  {
    std::lock_guard lock(mutex_);
    const double approach = properties_.at(kApproach);
    move.start = nominal + n * (approach + radius);
    move.max_travel_mm = approach + properties_.at(kSearch);
    move.speed_mm_s = properties_.at(kProbeSpeed);
    move.retract_mm = properties_.at(kRetract);
    report = pt_report_;
  }
  move.direction = -n;
  move.min_travel_mm = 0;
  move.fail_on_miss = true;
  const hal::TouchResult touch = machine_.probe(move);

  // The surface point, radius-compensated along the nominal normal: a client rebuilds the ball
  // centre as X/Y/Z + IJK · ER.
  const Vec3 surface = touch.centre - n * radius;
  std::vector<Term> data;
  for (const std::string& item : report) {
    if (item == "IJK")
      data.push_back(ipp::call_term("IJK", {ipp::number_term(n.x()), ipp::number_term(n.y()), ipp::number_term(n.z())}));
    else if (item == "ER") data.push_back(ipp::call_term("ER", {ipp::number_term(radius)}));
    else if (item == "Clock") data.push_back(ipp::call_term("Clock", {ipp::number_term(touch.t_s)}));
    else data.push_back(ipp::call_term(item, {ipp::number_term(surface[axis_index(item)])}));
  }
  reply_data(std::move(data));
  reply_done();
}

void IppDmeServer::clear_machine_errors() {
  const hal::MachineStatus s = machine_.status();
  if (s.estop || s.aborted) machine_.reset();  // releases our simulated e-stop
}

void IppDmeServer::reset_session_settings_locked() {
  const Range probe = *range_of(kProbeSpeed, description_);
  properties_ = {{kProbeSpeed, clamp_to(probe, description_.probe_speed_mm_s)},
                 {kApproach, 2},
                 {kSearch, 5},
                 {kRetract, 1},
                 {kGoToSpeed, description_.max_speed_mm_s},
                 {kGoToAccel, description_.max_accel_mm_s2}};
  pt_report_ = {"X", "Y", "Z"};
}

std::vector<Term> IppDmeServer::read_properties_locked(const std::vector<Term>& args) const {
  std::vector<Term> out;
  for (const Term& t : args) {
    if (t.kind != Term::Kind::call || !t.args.empty())
      throw ArgumentError("GetProp takes Name() items, as in GetProp(Tool.PtMeasPar.Speed()), not " + ipp::format_term(t));
    if (t.text == "Tool.Name") {
      out.push_back(ipp::call_term(t.text, {string_term(machine_.status().tip_id)}));
      continue;
    }
    const auto it = properties_.find(t.text);
    if (it == properties_.end()) throw ArgumentError("no property " + t.text);
    out.push_back(ipp::call_term(t.text, {ipp::number_term(it->second)}));
  }
  if (out.empty()) throw ArgumentError("GetProp needs at least one property");
  return out;
}

// ---------------------------------------------------------------------------------------------
// The move-report daemon and the reply delay

void IppDmeServer::report_loop() {
  std::uint64_t seen = 0;  // the daemon the state below belongs to
  bool was_moving = false;
  Vec3 last = Vec3::Zero();
  SteadyClock::time_point last_time;
  std::unique_lock lock(mutex_);
  while (running_) {
    if (!daemon_) {
      report_wake_.wait(lock, [&] { return !running_ || daemon_; });
      continue;
    }
    const Daemon d = *daemon_;
    lock.unlock();
    const hal::MachineStatus s = machine_.status();
    const auto now = SteadyClock::now();
    lock.lock();
    if (!daemon_ || daemon_->id != d.id) continue;  // stopped or replaced meanwhile
    if (d.id != seen) {
      seen = d.id;
      was_moving = false;
      last = s.position;
      last_time = now - std::chrono::hours(1);  // the first look at a motion reports it
    }
    const bool every = d.every_s && s.moving && now - last_time >= std::chrono::duration<double>(*d.every_s);
    if (s.moving) end_reported_ = false;
    const bool ended = was_moving && !s.moving && !end_reported_;  // unless the worker has reported it
    const bool moved = d.beyond_mm && (s.position - last).norm() > *d.beyond_mm &&
                       now - last_time >= std::chrono::duration<double>(kMinReportPeriodS);
    was_moving = s.moving;
    if (every || ended || moved) {
      send_locked(reply_of(d.tag, ReplyKind::data, position_terms(d.axes, s)));
      last = s.position;
      last_time = now;
    }
    report_wake_.wait_for(lock, kReportTick, [&] { return !running_ || !daemon_ || daemon_->id != d.id; });
  }
}

void IppDmeServer::outbox_loop() {
  std::unique_lock lock(mutex_);
  while (running_) {
    if (outbox_.empty()) {
      outbox_wake_.wait(lock);
      continue;
    }
    if (SteadyClock::now() < outbox_.front().due) {
      outbox_wake_.wait_until(lock, outbox_.front().due);
      continue;  // the front may have gone with its connection meanwhile
    }
    const Delayed d = std::move(outbox_.front());
    outbox_.pop_front();
    lock.unlock();
    write_line(d.line, d.connection);
    lock.lock();
  }
}

// ---------------------------------------------------------------------------------------------
// Lines out

void IppDmeServer::send_locked(const ipp::Reply& reply, bool delayed) {
  send_line_locked(ipp::format_reply(reply), delayed);
}

void IppDmeServer::send_line_locked(std::string line, bool delayed) {
  // reply_delay_s holds back the lines of the commands that change the machine (as on the Grbl and
  // Modbus sides), their acks too, so a client waiting for one times out; a session's set-up, the
  // queries, the fast queue and the server's events stay on time.
  if (delayed && faults_.reply_delay_s > 0) {
    const auto due = SteadyClock::now() + std::chrono::duration_cast<SteadyClock::duration>(
                                              std::chrono::duration<double>(faults_.reply_delay_s));
    outbox_.push_back({due, std::move(line), connection_});
    outbox_wake_.notify_all();
    return;
  }
  write_line(line, connection_);
}

void IppDmeServer::error_locked(Tag tag, int severity, int code, const std::string& method, const std::string& text) {
  send_locked(error_of(tag, severity, code, method, text));
}

void IppDmeServer::refuse_locked(Tag tag, const std::string& method, int code, const std::string& text, bool complete) {
  // A line we could not take is an error the client must clear, whatever §8.2's default (0000's is
  // 0); §8.1 lets a server adapt the severity.
  error_locked(tag, std::max(2, ipp::default_severity(code)), code, method, text);
  if (complete && !(tag == ipp::kServerTag)) send_locked(reply_of(tag, ReplyKind::done));
  enter_error_state_locked();
}

void IppDmeServer::fail_locked(Transaction& tx, int code, const std::string& text) {
  const int severity = ipp::default_severity(code);
  if (tx.connection == connection_) send_locked(error_of(tx.tag, severity, code, tx.method, text), tx.command > 0);
  end_locked(tx, reply_of(tx.tag, ReplyKind::done));
  if (severity >= 2) enter_error_state_locked();
}

void IppDmeServer::end_locked(Transaction& tx, ipp::Reply reply) {
  tx.ended = true;
  if (tx.connection != connection_) return;
  std::string line = ipp::format_reply(reply);
  if (tx.command > 0 && tx.command == faults_.corrupt_reply_at_command) line = garbled(std::move(line));
  send_line_locked(std::move(line), tx.command > 0);
}

void IppDmeServer::enter_error_state_locked(bool aborting) {
  error_state_ = true;
  const bool answer = aborting || options_.pending_on_error == PendingOnError::answer;
  for (Transaction& tx : queue_) {
    if (!answer) {
      tx.ended = true;
      continue;
    }
    abort_locked(tx);
  }
  queue_.clear();
}

void IppDmeServer::abort_locked(Transaction& tx) {
  if (tx.connection == connection_) send_locked(aborted_reply(tx.method, tx.tag), tx.command > 0);
  end_locked(tx, reply_of(tx.tag, ReplyKind::done));
}

bool IppDmeServer::tag_open_locked(Tag tag) const {
  if (current_ && !current_->ended && current_->tag == tag) return true;
  if (daemon_ && daemon_->tag == tag) return true;
  return std::any_of(queue_.begin(), queue_.end(), [&](const Transaction& tx) { return tx.tag == tag; });
}

void IppDmeServer::reply_data(std::vector<Term> data) {
  std::lock_guard lock(mutex_);
  if (current_ && !current_->ended) send_locked(reply_of(current_->tag, ReplyKind::data, std::move(data)), current_->command > 0);
}

void IppDmeServer::reply_warning(int code, const std::string& text) {
  std::lock_guard lock(mutex_);
  if (current_ && !current_->ended) send_locked(error_of(current_->tag, 1, code, current_->method, text), current_->command > 0);
}

void IppDmeServer::reply_done() {
  std::lock_guard lock(mutex_);
  if (!current_ || current_->ended) return;
  report_end_of_motion_locked();
  end_locked(*current_, reply_of(current_->tag, ReplyKind::done));
}

void IppDmeServer::report_end_of_motion_locked() {
  // The daemon reports where a motion ended before the motion's last line: a client reading the
  // stream knows where the machine stopped (and with time_scale 0, when nothing is ever seen
  // moving, this is the only report it gets).
  if (!daemon_ || !current_ || !find_command(current_->method)->moves) return;
  end_reported_ = true;
  send_locked(reply_of(daemon_->tag, ReplyKind::data, position_terms(daemon_->axes, machine_.status())));
}

void IppDmeServer::reply_error(int code, const std::string& text) {
  std::lock_guard lock(mutex_);
  if (!current_ || current_->ended) return;
  report_end_of_motion_locked();
  fail_locked(*current_, code, text);
}

void IppDmeServer::write_line(const std::string& line, std::uint64_t connection) {
  std::lock_guard lock(write_mutex_);
  if (connection != connection_ || !link_->socket.is_open()) return;  // a line of a session that has ended
  const std::string out = line + "\r\n";
  asio::error_code ec;
  asio::write(link_->socket, asio::buffer(out), ec);  // one line, one write
  if (ec) return note("could not send \"" + line + "\": " + ec.message());  // the receiving thread sees the drop
  if (log_) log_->sent(line);
}

}  // namespace cmm::sim
