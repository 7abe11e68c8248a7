// The Grbl driver: an Asio serial port read by its own thread (status reports to status(), every
// other line to the one line in flight), real-time bytes from any thread, typed faults from
// error:N / ALARM:N, and the machine description kept on this side of the line.
#include "hal/grbl_cmm.hpp"

#include <poll.h>
#include <cstring>
#include <unistd.h>

#include <sys/ioctl.h>

#include <array>
#include <chrono>
#include <cmath>
#include <thread>

#include <asio.hpp>

#include "hal/description/json_fields.hpp"
#include "hal/probe_move_check.hpp"
#include "hal/qualification.hpp"

namespace cmm::hal {

using Clock = std::chrono::steady_clock;
namespace {
std::chrono::duration<double> seconds(double s) { return std::chrono::duration<double>(s); }
std::string text(const Vec3& p) { return "(" + grbl::format_coords(p) + ")"; }
}  // namespace

GrblSettings grbl_settings_from_json(const nlohmann::json& j, const std::string& base_dir) {
  description::JsonFields b(j);
  b.expect_object();
  GrblSettings s;
  b.text("driver", "grbl", {"grbl"});
  s.device = b.text("device", s.device);
  if (s.device.empty()) b.problem("device", "the serial device is required");
  s.baud = b.integer("baud", s.baud, 1200, 4000000);
  s.reset_on_open = b.flag("reset_on_open", s.reset_on_open);
  s.reset_wait_s = b.number("reset_wait_s", s.reset_wait_s, 0, 60);
  s.response_timeout_s = b.number("response_timeout_s", s.response_timeout_s, 0.01, 60);
  s.status_timeout_s = b.number("status_timeout_s", s.status_timeout_s, 0.01, 60);
  s.motion_timeout_s = b.number("motion_timeout_s", s.motion_timeout_s, 0.1, 86400);
  s.poll_interval_s = b.number("poll_interval_s", s.poll_interval_s, 0.0001, 1);
  s.connect_attempts = b.integer("connect_attempts", s.connect_attempts, 1, 100);
  s.connect_backoff_s = b.number("connect_backoff_s", s.connect_backoff_s, 0, 60);
  // Grbl knows nothing of the travel box or the tips, and a sample's box enforced on a real machine
  // is worse than none: the description is required.
  if (b.require("machine", "the machine description: machine.json's schema, inline or a file name")) {
    if (b.member("machine").value() == "")
      b.problem("machine", "must name a file or hold the description");
    else
      s.machine = description::described(b, "machine", s.machine, base_dir, description::machine_from_json,
                                         description::read_machine);
  }
  b.finish();
  b.throw_if_problems("grbl driver config");
  return s;
}

struct GrblCmm::Port {
  asio::io_context io;
  asio::serial_port port{io};
  std::thread thread;
  std::array<char, 512> buffer{};
  std::string partial;
};

GrblCmm::GrblCmm(std::string base_dir) : CmmDriver("the Grbl machine"), base_dir_(std::move(base_dir)) {}
GrblCmm::~GrblCmm() { disconnect(); }

std::optional<description::MachineDescription> GrblCmm::configured_machine() const { return settings_.machine; }

CmmDriver::ConnectPolicy GrblCmm::connect_policy() const {
  return {settings_.connect_attempts, settings_.connect_backoff_s};
}

std::string GrblCmm::where() const { return "the Grbl machine on " + settings_.device; }

void GrblCmm::on_configure(const nlohmann::json& block) {
  settings_ = grbl_settings_from_json(block, base_dir_);
  active_ = 0;
  for (std::size_t i = 0; i < settings_.machine.tips.size(); ++i)
    if (settings_.machine.tips[i].id == settings_.machine.active_tip) active_ = i;
}

const description::StylusTip& GrblCmm::active() const { return settings_.machine.tips.at(active_); }

void GrblCmm::on_line(const std::string& line) {
  std::lock_guard lock(mutex_);
  if (auto status = grbl::parse_status(line)) {
    last_status_ = status;
    ++status_seq_;
  } else if (!line.empty()) {
    replies_.push_back(line);
  }
  wake_.notify_all();
}

void GrblCmm::on_link_down() {
  std::lock_guard lock(mutex_);
  link_down_ = true;
  wake_.notify_all();
}

void GrblCmm::close_port() {
  std::lock_guard lock(write_mutex_);  // no write is under way on the descriptor being closed
  if (!port_) return;
  asio::post(port_->io, [p = port_.get()] {
    asio::error_code ignored;
    p->port.close(ignored);
  });
  port_->io.stop();
  if (port_->thread.joinable()) port_->thread.join();
  port_.reset();
}

void GrblCmm::on_connect() {
  close_port();
  {
    std::lock_guard lock(mutex_);
    replies_.clear();
    last_status_.reset();
    link_down_ = false;
    in_flight_bytes_ = 0;
  }
  auto port = std::make_unique<Port>();
  asio::error_code ec;
  port->port.open(settings_.device, ec);
  if (ec) throw CommLost(ec.message());
  using sp = asio::serial_port_base;
  port->port.set_option(sp::baud_rate(static_cast<unsigned>(settings_.baud)), ec);
  port->port.set_option(sp::character_size(8), ec);
  port->port.set_option(sp::parity(sp::parity::none), ec);
  port->port.set_option(sp::stop_bits(sp::stop_bits::one), ec);
  port->port.set_option(sp::flow_control(sp::flow_control::none), ec);  // a pty refuses some: harmless
  if (settings_.reset_on_open) {
    // DTR low then high: an Arduino-class board restarts (a pty has no modem lines and ignores it).
    int dtr = TIOCM_DTR;
    ioctl(port->port.native_handle(), TIOCMBIC, &dtr);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    ioctl(port->port.native_handle(), TIOCMBIS, &dtr);
  }
  Port* p = port.get();
  port_ = std::move(port);
  struct Reader {
    GrblCmm* self;
    Port* p;
    void operator()() const {
      p->port.async_read_some(asio::buffer(p->buffer), [self = self, p = p](const asio::error_code& e, std::size_t n) {
        if (e) return self->on_link_down();
        for (std::size_t i = 0; i < n; ++i) {
          const char c = p->buffer[i];
          if (c == '\n') {
            self->on_line(p->partial);
            p->partial.clear();
          } else if (c != '\r') {
            p->partial.push_back(c);
          }
        }
        Reader{self, p}();
      });
    }
  };
  Reader{this, p}();
  p->thread = std::thread([p] { p->io.run(); });
  if (settings_.reset_on_open) {
    const auto deadline = Clock::now() + seconds(settings_.reset_wait_s);
    std::unique_lock lock(mutex_);
    wake_.wait_until(lock, deadline, [&] {
      for (const auto& line : replies_)
        if (line.rfind("Grbl ", 0) == 0) return true;
      return link_down_;
    });
  }
  const grbl::StatusReport s = flush_old_line(query_status("connect"));
  if (s.state == "Idle") setup_modes();
}

void GrblCmm::on_disconnect() { close_port(); }

void GrblCmm::link_out_of_step() {
  unanswered_ = true;
  drop_link();
}

grbl::StatusReport GrblCmm::flush_old_line(grbl::StatusReport s) {
  // Grbl numbers no lines: the ok of a line sent before the link went quiet (a motion still
  // running, or an answer still on its way) would be read as the next line's. Its outcome is
  // unknown, so it is stopped, never replayed: a feed hold, then a soft reset once at rest (the
  // position kept; Grbl drops the line and its answer), then the banner. An idle machine that may
  // still owe an answer is reset alone; one in Alarm answers nothing late (and a reset there would
  // release our e-stop input).
  const bool running = s.state == "Run" || s.state == "Hold" || s.state == "Home" || s.state == "Jog";
  if (!running && !(unanswered_ && s.state == "Idle")) {
    unanswered_ = false;
    return s;
  }
  const auto deadline = Clock::now() + seconds(settings_.response_timeout_s + 5);
  if (s.state == "Run" || s.state == "Jog" || (s.state == "Hold" && s.substate == 1)) {
    if (s.state != "Hold") send(std::string(1, grbl::kFeedHold), "connect");
    while (!(s.state == "Hold" && s.substate == 0) && s.state != "Idle" && s.state != "Alarm") {
      if (Clock::now() > deadline) throw Timeout("connect: the Grbl machine's last line does not come to rest");
      std::this_thread::sleep_for(seconds(settings_.poll_interval_s));
      s = query_status("connect");
    }
  }
  {
    std::lock_guard lock(mutex_);
    replies_.clear();
  }
  send(std::string(1, grbl::kSoftReset), "connect");  // homing (Home) is cut short: it needs $H again
  {
    std::unique_lock lock(mutex_);
    const bool banner = wake_.wait_for(lock, seconds(settings_.response_timeout_s), [&] {
      for (const auto& line : replies_)
        if (line.rfind("Grbl ", 0) == 0) return true;
      return link_down_;
    });
    if (!banner || link_down_) throw Timeout("connect: no banner from the Grbl machine after flushing its last line");
    replies_.clear();
  }
  unanswered_ = false;
  stop_requested_ = false;
  return query_status("connect");
}

void GrblCmm::send(const std::string& bytes, const char* what) {
  // Written from the calling thread straight to the descriptor, under a lock of its own. The
  // reader's pending read is on the same descriptor, which POSIX allows; handing each write to the
  // reader's thread and back cost as much as the round trip on the line (docs/PERFORMANCE.md).
  std::lock_guard lock(write_mutex_);
  if (!port_ || !link_up()) throw CommLost(std::string(what) + ": the Grbl link is down");
  const int fd = port_->port.native_handle();
  const auto deadline = Clock::now() + seconds(settings_.status_timeout_s);
  for (std::size_t done = 0; done < bytes.size();) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n > 0) {
      done += static_cast<std::size_t>(n);
    } else if (n < 0 && errno == EINTR) {
      continue;
    } else if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      pollfd writable{fd, POLLOUT, 0};
      if (left <= 0 || ::poll(&writable, 1, static_cast<int>(left)) <= 0)
        throw CommLost(std::string(what) + ": the Grbl link does not take bytes");
    } else {
      throw CommLost(std::string(what) + ": " + std::strerror(errno));
    }
  }
}

grbl::StatusReport GrblCmm::query_status(const char* what) {
  std::uint64_t seq = 0;
  {
    std::lock_guard lock(mutex_);
    seq = status_seq_;
  }
  send(std::string(1, grbl::kStatusQuery), what);
  std::unique_lock lock(mutex_);
  if (!wake_.wait_for(lock, seconds(settings_.status_timeout_s), [&] { return status_seq_ > seq || link_down_; }) ||
      link_down_) {
    lock.unlock();
    drop_link();
    throw CommLost(std::string(what) + ": no status report within " + std::to_string(settings_.status_timeout_s) +
                   " s: the Grbl link is gone");
  }
  return *last_status_;
}

void GrblCmm::setup_modes() {
  // Millimetres, absolute, G54 cleared: work coordinates are machine coordinates, so G38.x targets
  // and [PRB] reports (always machine coordinates) agree.
  transact("G21G90G54", "setup", false);
  transact("G10L2P1X0Y0Z0", "setup", false);
  transact("G92.1", "setup", false);
}

GrblCmm::LineResult GrblCmm::transact(const std::string& line, const char* what, bool motion) {
  std::lock_guard line_lock(line_mutex_);
  const std::size_t bytes = line.size() + 1;
  if (bytes > grbl::kRxBufferBytes - 1) throw std::invalid_argument(std::string(what) + ": line too long for Grbl");
  {
    std::unique_lock lock(mutex_);
    // Character counting: never more in Grbl's RX buffer than it holds.
    wake_.wait_for(lock, seconds(settings_.response_timeout_s),
                   [&] { return in_flight_bytes_ + bytes < grbl::kRxBufferBytes || link_down_; });
    replies_.clear();  // anything unasked (a banner after a reset) is stale by now
    in_flight_bytes_ += bytes;
  }
  struct Release {
    GrblCmm* self;
    std::size_t bytes;
    ~Release() {
      std::lock_guard lock(self->mutex_);
      self->in_flight_bytes_ -= bytes;
      self->wake_.notify_all();
    }
  } release{this, bytes};
  // A stop or abort that came between the lines of one call ends the call here: an idle Grbl
  // ignores a feed hold and stays homed after a soft reset, so the next line would otherwise run.
  if (motion && (abort_requested_ || stop_requested_))
    throw Aborted(std::string(what) + (abort_requested_ ? ": aborted" : ": stopped by stop()") + " before the next line");
  unanswered_ = true;  // until its final answer: ok, error:N, ALARM:N, or the banner of a reset
  send(line + "\n", what);

  LineResult result;
  const auto sent = Clock::now();
  auto last_query = sent;
  // Clock::time_point{} means "not yet" (std::optional trips -Wmaybe-uninitialized here).
  Clock::time_point unanswered{}, idle_since{};
  std::uint64_t seen_seq = 0;
  {
    std::lock_guard lock(mutex_);
    seen_seq = status_seq_;
  }
  for (;;) {
    std::string reply;
    {
      std::unique_lock lock(mutex_);
      wake_.wait_for(lock, seconds(settings_.poll_interval_s), [&] { return !replies_.empty() || link_down_; });
      if (link_down_) {
        lock.unlock();
        link_out_of_step();
        throw CommLost(std::string(what) + ": the Grbl link dropped");
      }
      if (!replies_.empty()) {
        reply = replies_.front();
        replies_.pop_front();
      } else if (status_seq_ > seen_seq) {
        seen_seq = status_seq_;
        unanswered = {};
        const std::string& state = last_status_->state;
        if (state == "Idle" || state == "Alarm") {
          if (idle_since == Clock::time_point{}) idle_since = Clock::now();
        } else {
          idle_since = {};
        }
      }
    }
    const auto now = Clock::now();
    if (reply.empty()) {
      if (unanswered != Clock::time_point{} && now - unanswered > seconds(settings_.status_timeout_s)) {
        link_out_of_step();
        throw CommLost(std::string(what) + ": no status report within " + std::to_string(settings_.status_timeout_s) +
                       " s: the Grbl link is gone");
      }
      const double limit = motion ? settings_.motion_timeout_s : settings_.response_timeout_s;
      const bool idle = idle_since != Clock::time_point{};
      if ((idle && now - idle_since > seconds(settings_.response_timeout_s)) || now - sent > seconds(limit)) {
        try {
          send(std::string(1, grbl::kFeedHold), what);  // whatever it is doing, it should not go on unwatched
        } catch (const Fault&) {
        }
        // Its ok may still come, and would answer the next line: the link is out of step.
        link_out_of_step();
        throw Timeout(std::string(what) + ": no answer to \"" + line + "\" within " +
                      std::to_string(idle ? settings_.response_timeout_s : limit) + " s; the link is down until connect()");
      }
      if (now - last_query >= seconds(settings_.poll_interval_s)) {
        last_query = now;
        if (unanswered == Clock::time_point{}) unanswered = now;
        send(std::string(1, grbl::kStatusQuery), what);
      }
      continue;
    }
    if (reply == "ok" || grbl::parse_error(reply) || grbl::parse_alarm(reply) || reply.rfind("Grbl ", 0) == 0)
      unanswered_ = false;  // the line's final answer
    if (reply == "ok") return result;
    if (auto code = grbl::parse_error(reply)) {
      FaultKind kind = grbl::fault_from_error(*code);
      if (kind == FaultKind::not_homed && query_status(what).pins.find('R') != std::string::npos)
        throw EStop(std::string(what) + ": the e-stop input is active (Grbl's reset pin); reset() after releasing it");
      throw_fault(kind, std::string(what) + ": Grbl answered error:" + std::to_string(*code) + " (" +
                            grbl::error_text(*code) + ") to \"" + line + "\"");
    }
    if (auto code = grbl::parse_alarm(reply)) alarm(*code, what);
    if (auto probe = grbl::parse_probe(reply)) {
      result.probe = probe;
      continue;
    }
    if (reply.rfind("Grbl ", 0) == 0) {
      if (stop_requested_) throw Aborted(std::string(what) + ": stopped by stop()");
      throw Aborted(std::string(what) + ": the Grbl machine restarted during \"" + line + "\"");
    }
    if (reply.front() == '[') {
      result.messages.push_back(reply);
      continue;
    }
    throw Protocol(std::string(what) + ": cannot parse Grbl's answer \"" + reply + "\" to \"" + line + "\"");
  }
}

void GrblCmm::alarm(int code, const char* what) {
  const std::string message = std::string(what) + ": ALARM:" + std::to_string(code) + " (" + grbl::alarm_text(code) + ")";
  if (code == grbl::kAlarmAbortCycle) {
    if (abort_requested_) throw Aborted(message + " after abort()");
    if (query_status(what).pins.find('R') != std::string::npos)
      throw EStop(std::string(what) + ": the machine's e-stop input went active (Grbl's reset pin)");
    throw Aborted(message);
  }
  throw_fault(grbl::fault_from_alarm(code), message);
}

void GrblCmm::begin_motion() {
  stop_requested_ = false;  // a stop of an earlier call; one during this call ends it at its next line
}

description::MachineDescription GrblCmm::read_info() {
  std::lock_guard lock(mutex_);  // select_tip() and record_qualification() write the tips
  description::MachineDescription info = settings_.machine;
  info.name = "Grbl 1.1 machine on " + settings_.device;
  info.active_tip = active().id;
  info.tool_changer = false;  // Grbl has no tool changer: select_tip only says which stylus is fitted
  return info;
}

MachineStatus GrblCmm::read_status() {
  const grbl::StatusReport r = query_status("status");
  MachineStatus s;
  s.homed = r.state != "Alarm" && r.state != "Home";  // homing is enforced: an unhomed Grbl is in Alarm
  s.moving = r.state == "Run" || r.state == "Home" || r.state == "Jog" || (r.state == "Hold" && r.substate == 1);
  s.estop = r.pins.find('R') != std::string::npos;
  s.t_s = r.clock_s.value_or(0);
  std::lock_guard lock(mutex_);  // the tip may be changed by select_tip() on the motion thread
  s.position = r.mpos + active().offset;
  s.tip_id = active().id;
  return s;
}

std::optional<grbl::ProbeReport> GrblCmm::guarded(const Vec3& ball_target, double speed_mm_s, bool fail_on_miss,
                                                  const char* what) {
  const double max_speed = settings_.machine.max_speed_mm_s;
  const double feed = std::min(speed_mm_s > 0 ? speed_mm_s : max_speed, max_speed) * 60;
  const std::string line = std::string(fail_on_miss ? "G38.2" : "G38.3") + "X" + grbl::format_number(mpos_of(ball_target).x()) +
                           "Y" + grbl::format_number(mpos_of(ball_target).y()) + "Z" +
                           grbl::format_number(mpos_of(ball_target).z()) + "F" + grbl::format_number(feed);
  return transact(line, what, true).probe;
}

void GrblCmm::do_home() {
  transact("$H", "home", true);
  setup_modes();
}

void GrblCmm::do_move(const Move& m) {
  {
    if (!settings_.machine.travel_box.contains(m.target))
      throw SoftLimit("move target " + text(m.target) + " is outside the travel box");
    const Vec3 here = status().position;
    if ((here - m.target).norm() < 1e-9) return;
    // Grbl watches the probe only during G38.x: guarded travel is a G38.3 toward the target.
    auto prb = guarded(m.target, m.speed_mm_s, false, "move");
    if (prb && prb->success)
      throw EarlyTrigger("the probe triggered during a guarded move at " + text(prb->position + active().offset) +
                         " on the way to " + text(m.target));
  }
}

TouchResult GrblCmm::do_probe(const ProbeMove& p) {
  {
    const Vec3 d = checked_probe_direction(p, settings_.machine.travel_box);
    const Vec3 end = p.start + d * p.max_travel_mm;
    if ((status().position - p.start).norm() > 1e-9) {
      auto prb = guarded(p.start, 0, false, "probe");
      if (prb && prb->success) throw EarlyTrigger("the probe triggered on the way to the search start " + text(p.start));
    }
    const double speed = p.speed_mm_s > 0 ? p.speed_mm_s : settings_.machine.probe_speed_mm_s;
    std::optional<grbl::ProbeReport> prb;
    try {
      prb = guarded(end, speed, p.fail_on_miss, "probe");
    } catch (const NoContact&) {
      transact("$X", "probe", false);  // a miss keeps the position: unlock so the next call works
      throw;
    }
    if (!prb) throw Protocol("probe: Grbl answered ok to a G38 line without a [PRB] report");
    const MachineStatus after = status();
    TouchResult r;
    r.tip_id = active().id;
    r.centre = prb->position + active().offset;
    r.travel_mm = (r.centre - p.start).norm();
    r.t_s = after.t_s;
    if (!prb->success) return r;  // G38.3 ran its whole travel
    // Grbl has no minimum travel: the driver judges it, and never reports such a touch.
    if (r.travel_mm < std::max(p.min_travel_mm, 1e-6))
      throw EarlyTrigger("a trigger after " + std::to_string(r.travel_mm) + " mm, before the search's minimum travel of " +
                         std::to_string(p.min_travel_mm) + " mm, from " + text(p.start));
    r.contact = true;
    if (p.retract_mm > 0) {
      auto back = guarded(after.position - d * p.retract_mm, 0, false, "probe");
      if (back && back->success) throw EarlyTrigger("the probe triggered while retracting from " + text(r.centre));
    }
    return r;
  }
}

void GrblCmm::do_stop() {
  if (!link_up() || !port_) return;
  stop_requested_ = true;
  send(std::string(1, grbl::kFeedHold), "stop");
  // Feed hold brakes on the path; a soft reset once it has come to rest (Hold:0) keeps the position,
  // and flushes the held line.
  const auto deadline = Clock::now() + seconds(settings_.response_timeout_s + 5);
  while (Clock::now() < deadline) {
    const grbl::StatusReport s = query_status("stop");
    if (s.state == "Hold" && s.substate == 0) {
      stop_requested_ = true;
      send(std::string(1, grbl::kSoftReset), "stop");
      return;
    }
    if (s.state == "Idle" || s.state == "Alarm") return;
    if (s.state == "Home" || s.state == "Jog") {
      // Grbl ignores a feed hold while homing: reset at once (the position was not known yet).
      send(std::string(1, grbl::kSoftReset), "stop");
      return;
    }
    std::this_thread::sleep_for(seconds(settings_.poll_interval_s));
  }
  throw Timeout("stop: the Grbl machine did not come to rest");
}

void GrblCmm::do_abort() {
  abort_requested_ = true;
  if (!link_up() || !port_) return;
  send(std::string(1, grbl::kSoftReset), "abort");  // at once: a motion in progress loses the position
}

void GrblCmm::do_reset() {
  {
    std::lock_guard lock(mutex_);
    replies_.clear();
  }
  send(std::string(1, grbl::kSoftReset), "reset");
  std::unique_lock lock(mutex_);
  const bool banner = wake_.wait_for(lock, seconds(settings_.response_timeout_s), [&] {
    for (const auto& line : replies_)
      if (line.rfind("Grbl ", 0) == 0) return true;
    return link_down_;
  });
  if (!banner || link_down_) {
    lock.unlock();
    link_out_of_step();  // a banner that comes late would end the next motion as a restart
    throw Timeout("reset: no banner from the Grbl machine after a soft reset; the link is down until connect()");
  }
  abort_requested_ = false;
}

void GrblCmm::do_select_tip(const std::string& tip_id) {
  std::lock_guard lock(mutex_);
  for (std::size_t i = 0; i < settings_.machine.tips.size(); ++i)
    if (settings_.machine.tips[i].id == tip_id) {
      active_ = i;
      return;
    }
  throw std::invalid_argument("no tip \"" + tip_id + "\" in the Grbl driver's config");
}

void GrblCmm::do_record_qualification(const std::string& tip_id, const description::TipQualification& q) {
  std::lock_guard lock(mutex_);
  record_on(settings_.machine, tip_id, q, "the Grbl driver's config");
}

}  // namespace cmm::hal
