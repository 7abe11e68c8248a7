// The I++ DME client: an Asio TCP socket read by the threads that wait on it (replies matched to
// their transactions by tag, move reports and the server's own events to the status), commands
// written from the calling thread one acknowledgement at a time.
#include "hal/ippdme_cmm.hpp"

#include <poll.h>
#include <sys/socket.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <thread>

#include <asio.hpp>

#include "hal/description/json_fields.hpp"
#include "hal/probe_move_check.hpp"
#include "hal/qualification.hpp"

namespace cmm::hal {

using Clock = std::chrono::steady_clock;
using ippdme::Term;
namespace {
std::chrono::duration<double> seconds(double s) { return std::chrono::duration<double>(s); }
std::string text(const Vec3& p) {
  return "(" + ippdme::format_number(p.x()) + ", " + ippdme::format_number(p.y()) + ", " + ippdme::format_number(p.z()) + ")";
}
Term axis(const char* name, double v) { return ippdme::call_term(name, {ippdme::number_term(v)}); }
Term ask(const char* name) { return ippdme::call_term(name); }
std::vector<Term> xyz(const Vec3& p) { return {axis("X", p.x()), axis("Y", p.y()), axis("Z", p.z())}; }
const auto kStartTime = Clock::now();
std::string code_text(int code) {
  char out[8];
  std::snprintf(out, sizeof out, "%04d", code);
  return out;
}
// §6.3.2.7: OnMoveReportE's Time is at least 0.1 s (at most 10 reports a second).
constexpr double kMinMoveReportS = 0.1;
// What a motion may take beyond twice its path's time and response_s: the controller's own set-up
// and settling, which no description states.
constexpr double kMotionSlackS = 3;
// A reported ER within this of the radius the server's tool has is that radius: servers print µm or
// finer, and a µm on ER moves the ball centre by as much, below a trigger's repeatability.
constexpr double kRadiusToleranceMm = 0.001;
// Time for `length` at up to `speed` with `accel` from rest to rest: a trapezoid, or a triangle
// when the path is too short to reach the speed.
double path_time_s(double length, double speed, double accel) {
  if (length <= 0) return 0;
  const double ramp = speed * speed / accel;  // both ramps' length together
  if (length < ramp) return 2 * std::sqrt(length / accel);
  return length / speed + speed / accel;
}
}  // namespace

IppDmeSettings ippdme_settings_from_json(const nlohmann::json& j, const std::string& base_dir) {
  description::JsonFields b(j);
  b.expect_object();
  IppDmeSettings s;
  b.text("driver", "ippdme", {"ippdme"});
  s.host = b.text("host", s.host);
  if (s.host.empty()) b.problem("host", "the controller's address is required");
  s.port = b.integer("port", s.port, 1, 65535);
  s.tool = b.text("tool", s.tool);
  if (b.has("tools")) {
    description::JsonFields tools = b.member("tools");
    if (!tools.value().is_object()) tools.problem("must map tip ids to the controller's tool names");
    else
      for (const auto& [tip, name] : tools.value().items()) {
        if (!name.is_string() || name.get<std::string>().empty()) tools.problem(tip, "must be a tool name");
        else s.tools[tip] = name.get<std::string>();
      }
  }
  description::JsonFields t = b.object("timeouts");
  s.connect_timeout_s = t.number("connect_s", s.connect_timeout_s, 0.01, 600);
  s.response_timeout_s = t.number("response_s", s.response_timeout_s, 0.01, 600);
  s.motion_timeout_s = t.number("motion_s", s.motion_timeout_s, 0, 86400);
  if (s.motion_timeout_s > 0 && s.motion_timeout_s < 0.1)
    t.problem("motion_s", "must be 0 (no cap) or at least 0.1 s, not " + std::to_string(s.motion_timeout_s));
  t.finish();
  if (b.has("move_report_s") && b.member("move_report_s").value().is_number() &&
      b.member("move_report_s").value().get<double>() < kMinMoveReportS)
    b.problem("move_report_s", "must be at least 0.1 s: I++ DME 1.4.3 §6.3.2.7 allows at most 10 move reports a second");
  else
    s.move_report_s = b.number("move_report_s", s.move_report_s, kMinMoveReportS, 10);
  s.connect_attempts = b.integer("connect_attempts", s.connect_attempts, 1, 100);
  s.connect_backoff_s = b.number("connect_backoff_s", s.connect_backoff_s, 0, 60);
  s.protocol_log = b.text("protocol_log", s.protocol_log);
  // The I++ server reports neither the travel box nor our tips' qualification: the description is
  // required, as for Grbl (a sample's travel box enforced on a real machine is worse than none).
  if (b.require("machine", "the machine description: machine.json's schema, inline or a file name")) {
    if (b.member("machine").value() == "")
      b.problem("machine", "must name a file or hold the description");
    else
      s.machine = description::described(b, "machine", s.machine, base_dir, description::machine_from_json,
                                         description::read_machine);
  }
  for (const auto& [tip, name] : s.tools) {
    bool known = false;
    for (const auto& t : s.machine.tips) known = known || t.id == tip;
    if (!known) b.member("tools").problem(tip, "no tip \"" + tip + "\" in the machine description");
  }
  b.finish();
  b.throw_if_problems("ippdme driver config");
  if (!s.protocol_log.empty() && s.protocol_log.front() != '/') s.protocol_log = base_dir + "/" + s.protocol_log;
  return s;
}

struct IppDmeCmm::Link {
  asio::io_context io;
  asio::ip::tcp::socket socket{io};
  std::string partial;  // the line being received (under io_mutex_)
};

IppDmeCmm::IppDmeCmm(std::string base_dir) : CmmDriver("the I++ DME machine"), base_dir_(std::move(base_dir)) {}
IppDmeCmm::~IppDmeCmm() { disconnect(); }

std::optional<description::MachineDescription> IppDmeCmm::configured_machine() const { return settings_.machine; }

std::string IppDmeCmm::server_version() const {
  std::lock_guard lock(mutex_);
  return version_;
}

CmmDriver::ConnectPolicy IppDmeCmm::connect_policy() const {
  return {settings_.connect_attempts, settings_.connect_backoff_s};
}

std::string IppDmeCmm::where() const {
  return "the I++ DME server at " + settings_.host + ":" + std::to_string(settings_.port);
}

void IppDmeCmm::on_configure(const nlohmann::json& block) {
  settings_ = ippdme_settings_from_json(block, base_dir_);
  const auto& tips = settings_.machine.tips;
  server_offsets_.clear();
  server_radii_.clear();
  active_ = 0;
  for (std::size_t i = 0; i < tips.size(); ++i) {
    server_offsets_.push_back(tips[i].offset);
    server_radii_.push_back(tips[i].ball_radius_mm);
    const std::string wanted = settings_.tool.empty() ? settings_.machine.active_tip : settings_.tool;
    if (tips[i].id == wanted || tool_of(tips[i].id) == wanted) active_ = i;
  }
  log_.reset();  // opened by connect(): configure does no I/O
}

const description::StylusTip& IppDmeCmm::active() const { return settings_.machine.tips.at(active_); }

std::string IppDmeCmm::tool_of(const std::string& tip_id) const {
  auto it = settings_.tools.find(tip_id);
  return it == settings_.tools.end() ? tip_id : it->second;
}

Vec3 IppDmeCmm::correction() const {
  std::lock_guard lock(mutex_);
  return settings_.machine.tips.at(active_).offset - server_offsets_.at(active_);
}

Vec3 IppDmeCmm::theirs_inside(const Vec3& ball) const {
  // The controller checks its travel box against its own tool data. After a qualification our ball
  // centre differs from its by the correction (µm), so a target on a face of our box (the program's
  // park corner) may lie that far outside its: put it back on the face. Our box check has passed.
  const description::TravelBox& box = settings_.machine.travel_box;
  return theirs(ball).cwiseMax(box.min).cwiseMin(box.max);
}

double IppDmeCmm::host_clock() const { return std::chrono::duration<double>(Clock::now() - kStartTime).count(); }

// ---- the link -------------------------------------------------------------------------------

void IppDmeCmm::close_link() {
  // Nobody reads or writes the socket being closed.
  std::scoped_lock lock(io_mutex_, write_mutex_);
  if (!link_) return;
  asio::error_code ignored;
  link_->socket.close(ignored);
  link_.reset();
}

void IppDmeCmm::on_disconnect() {
  if (link_ && link_up()) {
    try {
      // A polite goodbye ends the session on the server; a dead link just closes.
      auto tx = send(Kind::query, "EndSession", {}, "disconnect");
      wait(tx, std::min(settings_.response_timeout_s, 0.5), "disconnect", "EndSession");
    } catch (const std::exception&) {
    }
  }
  close_link();
}

void IppDmeCmm::on_connect() {
  close_link();
  if (!log_ && !settings_.protocol_log.empty()) log_ = std::make_unique<ProtocolLog>(settings_.protocol_log);
  {
    std::lock_guard lock(mutex_);
    open_.clear();
    link_down_ = false;
    garbled_.clear();
    report_tag_.reset();
    reported_clock_.reset();
  }
  auto link = std::make_unique<Link>();
  asio::error_code ec = asio::error::would_block;
  asio::ip::tcp::resolver resolver(link->io);
  const auto endpoints = resolver.resolve(settings_.host, std::to_string(settings_.port), ec);
  if (ec) throw CommLost("cannot resolve " + settings_.host + ": " + ec.message());
  ec = asio::error::would_block;
  asio::async_connect(link->socket, endpoints, [&](const asio::error_code& e, const auto&) { ec = e; });
  link->io.run_for(std::chrono::duration_cast<std::chrono::milliseconds>(seconds(settings_.connect_timeout_s)));
  if (ec == asio::error::would_block) throw Timeout("no TCP connection within " + std::to_string(settings_.connect_timeout_s) + " s");
  if (ec) throw CommLost(ec.message());
  link->socket.set_option(asio::ip::tcp::no_delay(true));  // one short line per round trip
  if (log_) log_->note("connected to " + where());
  link_ = std::move(link);
  start_session();
}

void IppDmeCmm::start_session() {
  // StartSession implies ClearAllErrors: whatever the last session left is gone.
  transact(Kind::query, "StartSession", {}, "connect");
  {
    std::lock_guard lock(mutex_);
    version_.clear();
    estop_ = false;
  }
  try {
    const Outcome v = transact(Kind::query, "GetDMEVersion", {}, "connect");
    for (const auto& items : v.data)
      if (const Term* t = ippdme::find_call(items, "DMEVersion"); t && !t->args.empty()) {
        std::lock_guard lock(mutex_);
        version_ = t->args[0].kind == Term::Kind::number ? ippdme::format_number(t->args[0].number) : t->args[0].text;
      }
  } catch (const Protocol&) {
    // Older servers do not know GetDMEVersion (0501); transact has cleared the error.
  }
  try {
    std::optional<double> clock;
    has_clock_ = true;
    query_position(&clock);
  } catch (const Protocol&) {
    has_clock_ = false;  // a real controller: TouchResult and status carry this host's clock
  }
  // The tools the controller has must include ours.
  const Outcome tools = transact(Kind::query, "EnumTools", {}, "connect");
  std::string names;
  auto has = [&](const std::string& tool) {
    for (const auto& items : tools.data)
      for (const Term& t : items)
        if ((t.kind == Term::Kind::string || t.kind == Term::Kind::name) && t.text == tool) return true;
    return false;
  };
  for (const auto& items : tools.data)
    for (const Term& t : items) names += (names.empty() ? "" : ", ") + t.text;
  if (!has(tool_of(active().id)))
    throw Protocol("connect: the controller has no tool \"" + tool_of(active().id) + "\" for tip " + active().id +
                   " (it has: " + names + "); map it with \"tools\" in the driver's block");
  transact(Kind::query, "ChangeTool", {[&] {
             Term t;
             t.kind = Term::Kind::string;
             t.text = tool_of(active().id);
             return t;
           }()},
           "connect");
  Term machine_csy;
  machine_csy.kind = Term::Kind::name;
  machine_csy.text = "MachineCsy";
  transact(Kind::query, "SetCoordSystem", {machine_csy}, "connect");
  Items report = {ask("X"), ask("Y"), ask("Z"), ask("IJK"), ask("ER")};
  if (has_clock_) report.push_back(ask("Clock"));
  transact(Kind::query, "OnPtMeasReport", report, "connect");
  const Outcome homed = transact(Kind::query, "IsHomed", {}, "connect");
  bool is_homed = false;
  for (const auto& items : homed.data)
    if (auto h = ippdme::number_of(items, "IsHomed")) is_homed = *h != 0;
  // What the tool's parameters are now, so that a SetProp is sent only when one changes.
  const Outcome props = transact(Kind::query, "GetProp",
                                 {ask("Tool.PtMeasPar.Speed"), ask("Tool.PtMeasPar.Approach"), ask("Tool.PtMeasPar.Search"),
                                  ask("Tool.PtMeasPar.Retract"), ask("Tool.GoToPar.Speed")},
                                 "connect");
  probe_speed_ = approach_ = search_ = retract_ = goto_speed_ = -1;
  for (const auto& items : props.data) {
    if (auto v = ippdme::number_of(items, "Tool.PtMeasPar.Speed")) probe_speed_ = *v;
    if (auto v = ippdme::number_of(items, "Tool.PtMeasPar.Approach")) approach_ = *v;
    if (auto v = ippdme::number_of(items, "Tool.PtMeasPar.Search")) search_ = *v;
    if (auto v = ippdme::number_of(items, "Tool.PtMeasPar.Retract")) retract_ = *v;
    if (auto v = ippdme::number_of(items, "Tool.GoToPar.Speed")) goto_speed_ = *v;
  }
  start_move_reports();
  std::optional<double> clock;
  const Vec3 at = query_position(&clock);
  std::lock_guard lock(mutex_);
  reported_ = at;
  reported_clock_ = clock;
  homed_ = is_homed;
}

void IppDmeCmm::start_move_reports() {
  // §6.3.2.7: the client stops a daemon before it starts one; a server that kept one from a
  // session that never ended answers a second with 0515. None running is warning 0512 (§8.2); a
  // server that raises it to an error has had it cleared by transact, and there is still none.
  try {
    transact(Kind::fast, "StopAllDaemons", {}, "connect");
  } catch (const Protocol&) {
  }
  // status() while a motion runs (a Get would wait behind the motion). The command ends at once;
  // its reports follow under its tag.
  Items daemon = {ippdme::call_term("Time", {ippdme::number_term(settings_.move_report_s)}), ask("X"), ask("Y"), ask("Z")};
  if (has_clock_) daemon.push_back(ask("Clock"));
  auto tx = send(Kind::fast, "OnMoveReportE", daemon, "connect", true);
  try {
    wait(tx, settings_.response_timeout_s, "connect", "OnMoveReportE");
  } catch (...) {
    std::lock_guard lock(mutex_);
    report_tag_.reset();
    throw;
  }
}

void IppDmeCmm::write_line(const std::string& line, const char* what) {
  // Written from the calling thread straight to the descriptor, as the Grbl driver does: the
  // reader's pending read is on the same socket, which POSIX allows.
  std::lock_guard lock(write_mutex_);
  if (!link_) throw CommLost(std::string(what) + ": the I++ link is down");
  if (log_) log_->sent(line);
  const std::string bytes = line + "\r\n";
  const int fd = link_->socket.native_handle();
  const auto deadline = Clock::now() + seconds(settings_.response_timeout_s);
  for (std::size_t done = 0; done < bytes.size();) {
    const ssize_t n = ::send(fd, bytes.data() + done, bytes.size() - done, MSG_NOSIGNAL);
    if (n > 0) {
      done += static_cast<std::size_t>(n);
    } else if (n < 0 && errno == EINTR) {
      continue;
    } else if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      pollfd writable{fd, POLLOUT, 0};
      if (left <= 0 || ::poll(&writable, 1, static_cast<int>(left)) <= 0)
        throw CommLost(std::string(what) + ": the I++ server does not take bytes");
    } else {
      throw CommLost(std::string(what) + ": " + std::strerror(errno));
    }
  }
}

void IppDmeCmm::pump(std::chrono::milliseconds max_wait) {
  // Called with io_mutex_ held. Whoever waits reads: the thread that waits for an answer takes the
  // lines off the socket itself and hands out what is for others, so an answer costs no hop
  // through a reader thread (a third of a round trip on two cores; docs/PERFORMANCE.md).
  if (!link_) return;
  const int fd = link_->socket.native_handle();
  char buffer[4096];
  // What is there already is taken without a poll (a syscall less per line on a busy link).
  ssize_t n = ::recv(fd, buffer, sizeof buffer, MSG_DONTWAIT);
  if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
    pollfd readable{fd, POLLIN, 0};
    if (max_wait.count() == 0 || ::poll(&readable, 1, static_cast<int>(max_wait.count())) <= 0) return;
    n = ::recv(fd, buffer, sizeof buffer, MSG_DONTWAIT);
  }
  if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) return;
  if (n <= 0) return on_link_down();
  std::string& partial = link_->partial;
  for (ssize_t i = 0; i < n; ++i) {
    if (buffer[i] != '\n') {
      partial.push_back(buffer[i]);
      if (partial.size() > ippdme::kMaxLineChars + 1) {  // a server that never ends a line
        on_line(partial.substr(0, 200) + "...");
        partial.clear();
      }
      continue;
    }
    if (!partial.empty() && partial.back() == '\r') partial.pop_back();
    on_line(partial);
    partial.clear();
  }
}

bool IppDmeCmm::await(const std::function<bool()>& ready, double timeout_s) {
  const auto deadline = Clock::now() + seconds(timeout_s);
  for (;;) {
    {
      std::lock_guard lock(mutex_);
      if (ready() || link_down_ || !garbled_.empty()) return true;
    }
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
    if (left.count() <= 0) return false;
    if (std::unique_lock io(io_mutex_, std::try_to_lock); io) {
      pump(std::min(left, std::chrono::milliseconds(20)) + std::chrono::milliseconds(1));
      continue;
    }
    // Another thread reads: it wakes us when our line comes, or we take over when it is done.
    std::unique_lock lock(mutex_);
    wake_.wait_for(lock, std::chrono::milliseconds(1), [&] { return ready() || link_down_ || !garbled_.empty(); });
  }
}

void IppDmeCmm::on_link_down() {
  if (log_) log_->note("the connection closed");
  std::lock_guard lock(mutex_);
  link_down_ = true;
  wake_.notify_all();
}

void IppDmeCmm::link_out_of_step() { drop_link(); }

void IppDmeCmm::on_line(const std::string& line) {
  if (log_) log_->received(line);
  std::lock_guard lock(mutex_);
  const auto reply = ippdme::parse_reply(line);
  if (!reply) {
    garbled_ = line.substr(0, 200);
    wake_.notify_all();
    return;
  }
  if (reply->tag == ippdme::kServerTag) {
    // The server's own event: an e-stop pressed, or any error it wants us to know of.
    if (reply->kind == ippdme::ReplyKind::error && reply->error.code == ippdme::kErrorEStop) {
      estop_ = true;
      homed_ = false;
      estop_text_ = reply->error.text;
    }
    if (reply->kind == ippdme::ReplyKind::error) end_pending_locked(*reply);
    wake_.notify_all();
    return;
  }
  if (report_tag_ && reply->tag == *report_tag_ && reply->kind == ippdme::ReplyKind::data) {
    // Parsed by name: a server may send the items in any order, or only the axes that moved.
    if (auto x = ippdme::number_of(reply->data, "X")) reported_.x() = *x;
    if (auto y = ippdme::number_of(reply->data, "Y")) reported_.y() = *y;
    if (auto z = ippdme::number_of(reply->data, "Z")) reported_.z() = *z;
    if (auto c = ippdme::number_of(reply->data, "Clock")) reported_clock_ = *c;
    return;
  }
  auto it = open_.find(ippdme::format_tag(reply->tag));
  if (it == open_.end()) return;  // a late answer to a transaction given up on; the link was dropped then
  Transaction& tx = *it->second;
  bool wake = true;
  switch (reply->kind) {
    case ippdme::ReplyKind::ack:
      tx.acked = true;
      wake = tx.wake_on_ack;
      break;
    case ippdme::ReplyKind::data: tx.data.push_back(reply->data); break;
    case ippdme::ReplyKind::done: tx.done = true; break;
    case ippdme::ReplyKind::error:
      if (reply->error.severity < 2) {
        tx.warnings.push_back(reply->error);
      } else {
        // It ends here whether or not a `%` follows (§6.2.3's example sends one; a late `%` finds
        // no open transaction and is dropped).
        tx.error = reply->error;
        tx.done = true;
        if (reply->error.code == ippdme::kErrorEStop) {
          estop_ = true;
          homed_ = false;
          estop_text_ = reply->error.text;
        }
      }
      break;
  }
  if (reply->kind == ippdme::ReplyKind::data || (reply->kind == ippdme::ReplyKind::error && !tx.done)) wake = false;
  const bool failed = tx.done && tx.error;
  if (tx.done) open_.erase(it);
  if (failed) end_pending_locked(*reply);
  if (wake) wake_.notify_all();
}

void IppDmeCmm::end_pending_locked(const ippdme::Reply& cause) {
  // §6.2.5: a severity ≥ 2 error aborts every pending transaction. The specification answers each
  // 0006 (§6.3.1.5); NIST's server drops them without a word. Either way none will run: they end
  // now, and whatever the server still says on their tags is dropped. 0006 and 0514 are the
  // consequences of an error already seen (or of our own AbortE), never a cause; the fast queue is
  // answered at once, never pending.
  const int code = cause.error.code;
  if (cause.error.severity < 2 || code == ippdme::kErrorTransactionAborted || code == ippdme::kErrorUseClearAllErrors)
    return;
  const std::string by = ippdme::format_tag(cause.tag) + " (" + cause.error.method + ", error " +
                         code_text(cause.error.code) + ": " + cause.error.text + ")";
  for (auto it = open_.begin(); it != open_.end();) {
    Transaction& tx = *it->second;
    if (tx.tag.event) {
      ++it;
      continue;
    }
    tx.error = cause.error;
    tx.ended_by = by;
    tx.done = true;
    it = open_.erase(it);
  }
}

ippdme::Tag IppDmeCmm::next_tag(bool event) {
  // Tags of open transactions are unique: skip the ones still open (and the daemon's).
  for (;;) {
    ippdme::Tag tag{event, 0};
    if (event) tag.number = next_event_ = next_event_ % 9999 + 1;
    else tag.number = next_number_ = next_number_ % 99999 + 1;
    if (!open_.count(ippdme::format_tag(tag)) && !(report_tag_ && *report_tag_ == tag)) return tag;
  }
}

std::shared_ptr<IppDmeCmm::Transaction> IppDmeCmm::send(Kind kind, const std::string& method, const Items& args,
                                                        const char* what, bool daemon) {
  std::lock_guard send_lock(send_mutex_);
  auto tx = std::make_shared<Transaction>();
  {
    std::unique_lock lock(mutex_);
    if (link_down_) {
      // The server closed the connection while nobody waited on it: down until connect().
      lock.unlock();
      link_out_of_step();
      throw CommLost(std::string(what) + ": the I++ server closed the connection");
    }
    tx->tag = next_tag(kind == Kind::fast);
    tx->wake_on_ack = kind != Kind::query;
    tx->line = ippdme::format_command({tx->tag, method, args});
    open_[ippdme::format_tag(tx->tag)] = tx;
    if (daemon) report_tag_ = tx->tag;  // its reports may come before its `%` (§6.2.4)
  }
  write_line(tx->line, what);
  // The next command goes out once this one is acknowledged (or refused before it was). A query
  // holds the line to its end, which is quick, so that its sender wakes once, not twice.
  const bool query = kind == Kind::query;
  if (!await([&] { return query ? tx->done : tx->acked || tx->done; }, settings_.response_timeout_s)) {
    link_out_of_step();  // its answer may still come, and would answer the next command
    throw Timeout(std::string(what) + (query ? ": no answer to \"" : ": no acknowledgement of \"") + tx->line + "\" within " +
                  std::to_string(settings_.response_timeout_s) + " s; the link is down until connect()");
  }
  return tx;
}

IppDmeCmm::Outcome IppDmeCmm::wait(const std::shared_ptr<Transaction>& tx, double timeout_s, const char* what,
                                   const std::string& method) {
  const bool ended = await([&] { return tx->done; }, timeout_s);
  std::unique_lock lock(mutex_);
  if (!garbled_.empty()) {
    const std::string line = garbled_;
    lock.unlock();
    link_out_of_step();
    throw Protocol(std::string(what) + ": the I++ server sent \"" + line + "\", which is not an I++ line, during \"" +
                   tx->line + "\"; the link is down until connect()");
  }
  if (!tx->done && link_down_) {
    lock.unlock();
    link_out_of_step();
    throw CommLost(std::string(what) + ": the I++ connection closed during \"" + tx->line + "\"");
  }
  if (!ended) {
    lock.unlock();
    link_out_of_step();
    throw Timeout(std::string(what) + ": \"" + tx->line + "\" did not end within " + std::to_string(timeout_s) +
                  " s; the link is down until connect()");
  }
  const std::optional<ippdme::ServerError> error = tx->error;
  const bool unanswered = !tx->ended_by.empty();
  Outcome out{tx->data, tx->warnings};
  lock.unlock();
  if (unanswered) fail_unanswered(*tx, what);
  if (error) fail(*error, what, method);
  return out;
}

void IppDmeCmm::fail_unanswered(const Transaction& tx, const char* what) {
  bool estop = false;
  {
    std::lock_guard lock(mutex_);
    estop = estop_;
  }
  if (estop) throw EStop(std::string(what) + ": the machine's emergency stop (" + tx.ended_by + "); reset() after releasing it");
  // The transaction that failed clears the server's error state; this one never ran.
  throw Protocol(std::string(what) + ": \"" + tx.line + "\" was never run: the server aborted it when " + tx.ended_by +
                 " failed (I++ DME 1.4.3 §6.2.5)");
}

void IppDmeCmm::fail(const ippdme::ServerError& e, const char* what, const std::string& method) {
  const std::string message =
      std::string(what) + ": the machine answered error " + code_text(e.code) + " (" + e.text + ") to " + method;
  bool estop = false;
  {
    std::lock_guard lock(mutex_);
    estop = estop_;  // an e-stop event came before this error (its 0514, say): never cleared here
  }
  if (e.code == ippdme::kErrorEStop || estop)
    throw EStop(std::string(what) + ": the machine's emergency stop (I++ error 0500: " + e.text + "); reset() after releasing it");
  if (e.code == ippdme::kErrorTransactionAborted) {
    // Our own AbortE (stop or abort); the stopping thread clears the server's error state.
    throw Aborted(std::string(what) + (abort_requested_ ? ": aborted" : ": stopped by stop()"));
  }
  if (e.severity >= 9) {
    link_out_of_step();
    throw Protocol(message + ", a fatal error; the link is down until connect()");
  }
  clear_errors(what);  // the server refuses everything else until it is cleared
  // 0507 "Illegal command" is what NIST's server says to a motion before Home, but not only that:
  // the machine's own word decides.
  const bool motion = method == "GoTo" || method == "PtMeas";
  if (e.code == ippdme::kErrorIllegalCommand && motion && !server_homed(what))
    throw NotHomed(message + "; the machine is not homed");
  throw_fault(ippdme::fault_from_error(e.code), message);
}

bool IppDmeCmm::server_homed(const char* what) {
  const Outcome homed = transact(Kind::query, "IsHomed", {}, what);
  bool is_homed = false;
  for (const auto& items : homed.data)
    if (auto h = ippdme::number_of(items, "IsHomed")) is_homed = *h != 0;
  std::lock_guard lock(mutex_);
  homed_ = is_homed;
  return is_homed;
}

void IppDmeCmm::clear_errors(const char* what) {
  auto tx = send(Kind::query, "ClearAllErrors", {}, what);
  wait(tx, settings_.response_timeout_s, what, "ClearAllErrors");
}

IppDmeCmm::Outcome IppDmeCmm::transact(Kind kind, const std::string& method, Items args, const char* what,
                                       double bound_s) {
  if (kind != Kind::motion) {
    auto tx = send(kind, method, args, what);
    return wait(tx, settings_.response_timeout_s, what, method);
  }
  std::shared_ptr<Transaction> tx;
  {
    // A stop or abort between the commands of one call ends the call here.
    std::lock_guard q(query_mutex_);
    if (abort_requested_ || stop_requested_)
      throw Aborted(std::string(what) + (abort_requested_ ? ": aborted" : ": stopped by stop()") + " before " + method);
    in_motion_ = true;
    try {
      tx = send(kind, method, args, what);
    } catch (...) {
      in_motion_ = false;
      throw;
    }
  }
  struct Done {
    std::atomic<bool>& flag;
    ~Done() { flag = false; }
  } done{in_motion_};
  return wait(tx, bound_s, what, method);
}

double IppDmeCmm::motion_bound_s(double length_mm, double speed_mm_s) const {
  const double accel = settings_.machine.max_accel_mm_s2;
  const double speed = speed_mm_s > 0 ? speed_mm_s : settings_.machine.max_speed_mm_s;
  const double bound = 2 * path_time_s(length_mm, speed, accel) + settings_.response_timeout_s + kMotionSlackS;
  return settings_.motion_timeout_s > 0 ? std::min(bound, settings_.motion_timeout_s) : bound;
}

double IppDmeCmm::home_bound_s() const {
  // Homing's path is the controller's: at worst each axis the box's length, one after the other, at
  // a tenth of the top speed (machines seek their reference marks slowly).
  const Vec3 extent = settings_.machine.travel_box.max - settings_.machine.travel_box.min;
  return motion_bound_s(extent.sum(), settings_.machine.max_speed_mm_s / 10);
}

// ---- status ---------------------------------------------------------------------------------

Vec3 IppDmeCmm::query_position(std::optional<double>* clock) {
  Items asked = {ask("X"), ask("Y"), ask("Z")};
  if (has_clock_) asked.push_back(ask("Clock"));
  const Outcome out = transact(Kind::query, "Get", asked, "status");
  for (const auto& items : out.data) {
    auto x = ippdme::number_of(items, "X"), y = ippdme::number_of(items, "Y"), z = ippdme::number_of(items, "Z");
    if (x && y && z) {
      if (clock) *clock = ippdme::number_of(items, "Clock");
      if (has_clock_ && clock && !*clock) throw Protocol("status: Get(...) answered without the Clock() asked for");
      return Vec3(*x, *y, *z);
    }
  }
  throw Protocol("status: the answer to Get(X(), Y(), Z()) lacks an axis");
}

void IppDmeCmm::drain() {
  // What came while nobody waited (an e-stop event pressed at an idle machine) is read first.
  if (std::unique_lock io(io_mutex_, std::try_to_lock); io) pump(std::chrono::milliseconds(0));
}

MachineStatus IppDmeCmm::read_status() {
  MachineStatus s;
  std::unique_lock q(query_mutex_);
  bool cached = in_motion_.load();
  {
    std::lock_guard lock(mutex_);
    // In e-stop the server takes nothing but ClearAllErrors: the last report is what we know.
    cached = cached || estop_;
    if (link_down_) cached = false;  // transact below throws CommLost
  }
  std::optional<double> clock;
  Vec3 at = Vec3::Zero();
  if (!cached) {
    try {
      // An e-stop event read on the way (pressed at an idle machine) comes before the Get's refusal.
      at = query_position(&clock);
      std::lock_guard lock(mutex_);
      reported_ = at;
      if (clock) reported_clock_ = clock;
    } catch (const EStop&) {
    }
  }
  q.unlock();
  std::lock_guard lock(mutex_);
  s.moving = in_motion_.load();
  s.homed = homed_;
  s.estop = estop_;
  if (estop_) {
    s.fault = FaultKind::estop;
    s.fault_message = "the machine's emergency stop: " + estop_text_;
  }
  const Vec3 offset = settings_.machine.tips.at(active_).offset - server_offsets_.at(active_);
  s.position = reported_ + offset;
  s.t_s = reported_clock_.value_or(host_clock());
  s.tip_id = settings_.machine.tips.at(active_).id;
  return s;
}

description::MachineDescription IppDmeCmm::read_info() {
  std::lock_guard lock(mutex_);
  description::MachineDescription info = settings_.machine;
  info.name = "I++ DME machine at " + settings_.host + ":" + std::to_string(settings_.port) +
              (version_.empty() ? "" : " (DME " + version_ + ")");
  info.active_tip = settings_.machine.tips.at(active_).id;
  return info;
}

// ---- motion ---------------------------------------------------------------------------------

void IppDmeCmm::begin_motion() {
  stop_requested_ = false;  // a stop of an earlier call; one during this call ends it at its next command
  drain();
  std::lock_guard lock(mutex_);
  if (estop_) throw EStop("the machine's emergency stop is active (" + estop_text_ + "); reset() after releasing it");
}

void IppDmeCmm::set_prop(const std::string& name, double value, double& cache, const char* what) {
  if (std::abs(cache - value) < 1e-9) return;
  if (abort_requested_ || stop_requested_)
    throw Aborted(std::string(what) + (abort_requested_ ? ": aborted" : ": stopped by stop()") + " before SetProp");
  cache = -1;  // unknown until read back
  const Outcome set = transact(Kind::query, "SetProp", {ippdme::call_term(name, {ippdme::number_term(value)})}, what);
  // A server clamps an out-of-range value with a warning (0504) instead of refusing it: read it back.
  const Outcome got = transact(Kind::query, "GetProp", {ask(name.c_str())}, what);
  for (const auto& items : got.data)
    if (auto v = ippdme::number_of(items, name)) cache = *v;
  if (cache < 0) throw Protocol(std::string(what) + ": GetProp(" + name + "()) answered without its value");
  if (std::abs(cache - value) > 1e-6) {
    std::string warning;
    for (const auto& w : set.warnings) {
      char code[8];
      std::snprintf(code, sizeof code, "%04d", w.code);
      warning += std::string(" (warning ") + code + ": " + w.text + ")";
    }
    throw Protocol(std::string(what) + ": the machine holds " + name + " at " + ippdme::format_number(cache) + ", not the " +
                   ippdme::format_number(value) + " asked" + warning + "; nothing moved");
  }
}

void IppDmeCmm::do_home() {
  transact(Kind::motion, "Home", {}, "home", home_bound_s());
  std::lock_guard lock(mutex_);
  homed_ = true;
}

Vec3 IppDmeCmm::last_position() const {
  std::lock_guard lock(mutex_);
  return reported_;
}

void IppDmeCmm::go_to(const Vec3& target, const char* what) {
  const double bound = motion_bound_s((target - last_position()).norm(), goto_speed_);
  transact(Kind::motion, "GoTo", xyz(target), what, bound);
  std::lock_guard lock(mutex_);
  reported_ = target;  // where a GoTo ends (§6.3.2.12); the next motion's bound starts here
}

void IppDmeCmm::do_move(const Move& m) {
  if (!settings_.machine.travel_box.contains(m.target))
    throw SoftLimit("move target " + text(m.target) + " is outside the travel box");
  const double max_speed = settings_.machine.max_speed_mm_s;
  set_prop("Tool.GoToPar.Speed", std::min(m.speed_mm_s > 0 ? m.speed_mm_s : max_speed, max_speed), goto_speed_, "move");
  try {
    go_to(theirs_inside(m.target), "move");
  } catch (const EarlyTrigger& e) {
    throw EarlyTrigger(std::string("the probe touched during a guarded move to ") + text(m.target) + ": " + e.what());
  }
}

TouchResult IppDmeCmm::do_probe(const ProbeMove& p) {
  const Vec3 d = checked_probe_direction(p, settings_.machine.travel_box);

  // PtMeas moves straight to its approach point from wherever the machine is: get there first
  // with a guarded GoTo, so that the search itself is all at probing speed.
  if ((status().position - p.start).norm() > 1e-9) {
    const double max_speed = settings_.machine.max_speed_mm_s;
    set_prop("Tool.GoToPar.Speed", max_speed, goto_speed_, "probe");
    try {
      go_to(theirs_inside(p.start), "probe");
    } catch (const EarlyTrigger& e) {
      throw EarlyTrigger("the probe touched on the way to the search start " + text(p.start) + ": " + e.what());
    }
  }
  // The search from `start` along d is PtMeas's from its approach point: the nominal point N lies
  // half the travel ahead (Approach = Search = travel / 2), IJK = −d, and the server puts the ball
  // centre at N + IJK·(Approach + r), with r the radius it compensates with (its last ER).
  const double half = p.max_travel_mm / 2;
  const double speed = p.speed_mm_s > 0 ? p.speed_mm_s : settings_.machine.probe_speed_mm_s;
  set_prop("Tool.PtMeasPar.Speed", speed, probe_speed_, "probe");
  set_prop("Tool.PtMeasPar.Approach", half, approach_, "probe");
  set_prop("Tool.PtMeasPar.Search", half, search_, "probe");
  set_prop("Tool.PtMeasPar.Retract", std::max(0.0, p.retract_mm), retract_, "probe");
  const Vec3 ijk = -d;
  double r = 0;
  {
    std::lock_guard lock(mutex_);
    r = server_radii_.at(active_);
  }
  const Vec3 nominal = theirs(p.start) + d * (half + r);
  // The way to the search start (nothing, after the GoTo above), the search and the retract, all
  // counted at the probing speed.
  const double path = (theirs(p.start) - last_position()).norm() + p.max_travel_mm + std::max(0.0, p.retract_mm);
  Outcome out;
  try {
    out = transact(Kind::motion, "PtMeas",
                   {axis("X", nominal.x()), axis("Y", nominal.y()), axis("Z", nominal.z()),
                    ippdme::call_term("IJK", {ippdme::number_term(ijk.x()), ippdme::number_term(ijk.y()),
                                              ippdme::number_term(ijk.z())})},
                   "probe", motion_bound_s(path, speed));
  } catch (const NoContact&) {
    if (p.fail_on_miss) throw;
    TouchResult miss;
    miss.tip_id = active().id;
    miss.centre = status().position;
    miss.travel_mm = p.max_travel_mm;
    miss.t_s = status().t_s;
    return miss;
  }
  for (const auto& items : out.data) {
    if (!ippdme::find_call(items, "X")) continue;
    TouchResult r_out;
    r_out.tip_id = active().id;
    r_out.centre = ours(reported_centre(items, "probe"));
    r_out.travel_mm = (r_out.centre - p.start).norm();
    const auto clock = ippdme::number_of(items, "Clock");
    r_out.t_s = clock ? *clock : host_clock();
    const Vec3 retracted = theirs(r_out.centre) - d * std::max(0.0, p.retract_mm);
    {
      std::lock_guard lock(mutex_);
      reported_ = retracted;
    }
    // I++ has no minimum travel: the driver judges it, and never reports such a touch.
    if (r_out.travel_mm < std::max(p.min_travel_mm, 1e-6))
      throw EarlyTrigger("a trigger after " + std::to_string(r_out.travel_mm) + " mm, before the search's minimum travel of " +
                         std::to_string(p.min_travel_mm) + " mm, from " + text(p.start));
    r_out.contact = true;
    return r_out;
  }
  throw Protocol("probe: PtMeas ended without a point report");
}

Vec3 IppDmeCmm::reported_centre(const Items& items, const char* what) const {
  // X, Y, Z are the radius-compensated surface point: the ball centre is (X, Y, Z) + IJK·ER, with ER
  // the radius the server compensated with. An ER that is not its tool's radius is a report we
  // cannot read (ER(-1000), a diameter for a radius): refused, never learnt.
  const auto x = ippdme::number_of(items, "X"), y = ippdme::number_of(items, "Y"), z = ippdme::number_of(items, "Z");
  const auto n = ippdme::vector_of(items, "IJK");
  const auto er = ippdme::number_of(items, "ER");
  if (!(x && y && z) || !n || !er || !(n->norm() > 0.5))
    throw Protocol(std::string(what) + ": the PtMeas report \"" + ippdme::format_terms(items) +
                   "\" lacks X(), Y(), Z(), IJK() or ER(), which were asked for: the ball centre cannot be rebuilt");
  double radius = 0;
  {
    std::lock_guard lock(mutex_);
    radius = server_radii_.at(active_);
  }
  if (!(std::abs(*er - radius) <= kRadiusToleranceMm))
    throw Protocol(std::string(what) + ": the PtMeas report has ER(" + ippdme::format_number(*er) + "), but tool \"" +
                   tool_of(active().id) + "\" compensates with the tip's " + ippdme::format_number(radius) +
                   " mm radius (ball_radius_mm in the machine description); the touch is not used");
  return Vec3(*x, *y, *z) + n->normalized() * *er;
}

void IppDmeCmm::do_stop() {
  if (!link_up() || !link_) return;
  stop_requested_ = true;
  if (!in_motion_) return;  // the running call, if any, ends at its next command
  // AbortE jumps the queue and ends the running motion with a controlled stop; the server then
  // wants ClearAllErrors before anything else.
  auto tx = send(Kind::fast, "AbortE", {}, "stop");
  wait(tx, settings_.response_timeout_s, "stop", "AbortE");
  const auto deadline = Clock::now() + seconds(settings_.response_timeout_s + 5);
  while (in_motion_ && Clock::now() < deadline) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  clear_errors("stop");
}

void IppDmeCmm::do_abort() {
  abort_requested_ = true;
  if (!link_up() || !link_) return;
  auto tx = send(Kind::fast, "AbortE", {}, "abort");
  wait(tx, settings_.response_timeout_s, "abort", "AbortE");
  const auto deadline = Clock::now() + seconds(settings_.response_timeout_s + 5);
  while (in_motion_ && Clock::now() < deadline) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  clear_errors("abort");  // motion stays refused by the latch until reset()
}

void IppDmeCmm::do_reset() {
  clear_errors("reset");
  const Outcome homed = transact(Kind::query, "IsHomed", {}, "reset");
  std::lock_guard lock(mutex_);
  estop_ = false;
  estop_text_.clear();
  for (const auto& items : homed.data)
    if (auto h = ippdme::number_of(items, "IsHomed")) homed_ = *h != 0;
  abort_requested_ = false;
}

void IppDmeCmm::do_select_tip(const std::string& tip_id) {
  std::size_t index = settings_.machine.tips.size();
  for (std::size_t i = 0; i < settings_.machine.tips.size(); ++i)
    if (settings_.machine.tips[i].id == tip_id) index = i;
  if (index == settings_.machine.tips.size()) throw std::invalid_argument("no tip \"" + tip_id + "\" in the I++ driver's config");
  Term name;
  name.kind = Term::Kind::string;
  name.text = tool_of(tip_id);
  transact(Kind::query, "ChangeTool", {name}, "select_tip");
  std::lock_guard lock(mutex_);
  active_ = index;
}

void IppDmeCmm::do_record_qualification(const std::string& tip_id, const description::TipQualification& q) {
  std::lock_guard lock(mutex_);
  record_on(settings_.machine, tip_id, q, "the I++ driver's config");
}

}  // namespace cmm::hal
