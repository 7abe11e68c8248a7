// The Grbl server: a receive loop that acts on real-time bytes at once and queues lines for a worker,
// which runs them on the machine one at a time and answers each with ok, error:N or ALARM:N.
#include "sim/grbl_server.hpp"

#include <fcntl.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <stdexcept>
#include <vector>

namespace cmm::sim {

namespace grbl = hal::grbl;

namespace {
constexpr std::size_t kLineBytes = 80;  // Grbl's LINE_BUFFER_SIZE

void make_raw(int fd) {
  termios tio{};
  if (tcgetattr(fd, &tio) == 0) {
    cfmakeraw(&tio);
    tcsetattr(fd, TCSANOW, &tio);
  }
}

struct Word {
  char letter;
  double value;
};

// "G53G38.3X1Y2F60" → its words; nullopt on a malformed line (error_code says which error).
std::optional<std::vector<Word>> words_of(const std::string& line, int& error_code) {
  std::vector<Word> out;
  std::size_t i = 0;
  while (i < line.size()) {
    const char letter = line[i++];
    if (!std::isalpha(static_cast<unsigned char>(letter))) {
      error_code = grbl::kErrorExpectedLetter;
      return std::nullopt;
    }
    const char* begin = line.c_str() + i;
    char* end = nullptr;
    const double value = std::strtod(begin, &end);
    if (end == begin || !std::isfinite(value)) {
      error_code = grbl::kErrorBadNumber;
      return std::nullopt;
    }
    i += static_cast<std::size_t>(end - begin);
    out.push_back({letter, value});
  }
  return out;
}

bool is(double g, double code) { return std::abs(g - code) < 1e-6; }
}  // namespace

GrblServer::GrblServer(SimulatedMachine& machine, const FaultInjection& faults, const std::string& device)
    : machine_(machine), faults_(faults), device_(device) {
  open_line();
  worker_ = std::thread([this] { worker_loop(); });
  write_line(grbl::kBanner);
  if (!machine_.status().homed) write_line("[MSG:'$H'|'$X' to unlock]");
}

GrblServer::~GrblServer() {
  shutdown();
  {
    std::lock_guard lock(mutex_);
    ++generation_;
    lines_.clear();
    hold_ = false;
    wake_.notify_all();
  }
  machine_.abort();  // a motion still running must not keep the worker
  if (worker_.joinable()) worker_.join();
  if (fd_ >= 0) close(fd_);
}

void GrblServer::shutdown() {
  running_ = false;
  std::lock_guard lock(mutex_);
  wake_.notify_all();
}

void GrblServer::open_line() {
  if (device_.empty()) {
    fd_ = posix_openpt(O_RDWR | O_NOCTTY);
    if (fd_ < 0 || grantpt(fd_) != 0 || unlockpt(fd_) != 0)
      throw std::runtime_error(std::string("cmm-sim: cannot create a pty: ") + std::strerror(errno));
    path_ = ptsname(fd_);
    // The slave in raw mode, so the driver's bytes arrive as sent whatever it sets itself.
    const int slave = open(path_.c_str(), O_RDWR | O_NOCTTY);
    if (slave >= 0) make_raw(slave), close(slave);
  } else {
    fd_ = open(device_.c_str(), O_RDWR | O_NOCTTY);
    if (fd_ < 0) throw std::runtime_error("cmm-sim: cannot open " + device_ + ": " + std::strerror(errno));
    make_raw(fd_);
    tcflush(fd_, TCIOFLUSH);  // what was sent while the line was down is lost, as on a real cable
    path_ = device_;
  }
}

void GrblServer::write_line(const std::string& line) {
  std::lock_guard lock(write_mutex_);
  if (fd_ < 0) return;
  const std::string out = line + "\r\n";
  std::size_t done = 0;
  while (done < out.size()) {
    const ssize_t n = ::write(fd_, out.data() + done, out.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return;  // nobody listening on the other end; the driver will notice
    done += static_cast<std::size_t>(n);
  }
}

void GrblServer::serve() {
  char buffer[256];
  while (running_) {
    bool drop = false;
    {
      std::lock_guard lock(mutex_);
      drop = drop_now_;
      drop_now_ = false;
    }
    if (drop) {
      {
        std::lock_guard lock(write_mutex_);
        close(fd_);
        fd_ = -1;
      }
      if (device_.empty()) continue;  // our own pty is gone for good: its path died with it
      // Down for 1 s, longer than a driver's status timeout: it sees the link gone, then reconnects.
      for (int i = 0; i < 50 && running_; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(20));
      std::lock_guard lock(write_mutex_);
      open_line();  // the cable is back
      continue;
    }
    if (fd_ < 0) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      continue;
    }
    pollfd p{fd_, POLLIN, 0};
    const int ready = poll(&p, 1, 20);
    if (ready <= 0 || !(p.revents & POLLIN)) {
      // A pty master with no slave open reports a hangup; wait for someone to open it.
      if (ready > 0) std::this_thread::sleep_for(std::chrono::milliseconds(20));
      continue;
    }
    const ssize_t n = ::read(fd_, buffer, sizeof buffer);
    if (n <= 0) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      continue;
    }
    for (ssize_t i = 0; i < n; ++i) receive(buffer[i]);
  }
}

void GrblServer::receive(char byte) {
  switch (byte) {
    case grbl::kStatusQuery: status_report(); return;
    case grbl::kFeedHold: feed_hold(); return;
    case grbl::kSoftReset: soft_reset(); return;
    case grbl::kCycleStart: {
      std::lock_guard lock(mutex_);
      hold_ = false;  // a held motion is not resumed in our dialect: the held line just ends
      wake_.notify_all();
      return;
    }
    default: break;
  }
  std::lock_guard lock(mutex_);
  if (byte == '\n' || byte == '\r') {
    if (byte == '\r' && partial_.empty()) return;  // the \r of a \r\n pair
    lines_.push_back(partial_);
    partial_.clear();
    wake_.notify_all();
    return;
  }
  if (queued_bytes_ >= grbl::kRxBufferBytes) return;  // an overflowing RX buffer loses bytes
  ++queued_bytes_;
  partial_.push_back(byte);
}

void GrblServer::status_report() {
  const hal::MachineStatus s = machine_.status();
  const description::MachineDescription info = machine_.info();
  Vec3 offset = Vec3::Zero();
  for (const auto& tip : info.tips)
    if (tip.id == info.active_tip) offset = tip.offset;
  grbl::StatusReport r;
  {
    std::lock_guard lock(mutex_);
    if (s.estop) r.state = "Alarm";
    else if (homing_) r.state = "Home";
    else if (alarm_ || !s.homed) r.state = "Alarm";
    else if (hold_) r.state = "Hold", r.substate = held_ ? 0 : 1;
    else if (in_motion_) r.state = "Run";
    else r.state = "Idle";
    r.feed_mm_min = in_motion_ ? feed_mm_min_ : 0;
  }
  r.mpos = s.position - offset;
  r.pins = std::string(s.estop ? "R" : "");  // a temporary: GCC 12 -O3 warns falsely (-Wrestrict) on assign(const char*)
  r.clock_s = s.t_s;
  write_line(grbl::format_status(r));
}

void GrblServer::feed_hold() {
  {
    std::lock_guard lock(mutex_);
    if (!in_motion_ || homing_) return;  // nothing to hold (Grbl ignores a hold while homing)
    hold_ = true;
  }
  machine_.stop();
}

void GrblServer::soft_reset() {
  bool was_moving = false;
  {
    std::unique_lock lock(mutex_);
    ++generation_;
    lines_.clear();
    partial_.clear();
    queued_bytes_ = 0;
    was_moving = in_motion_ && !held_;
    if (was_moving) machine_.abort();
    hold_ = false;
    wake_.notify_all();
    wake_.wait(lock, [&] { return !busy_; });
  }
  try {
    machine_.reset();
  } catch (const std::exception&) {
    // reset() refuses only during motion, which the wait above has ruled out
  }
  {
    std::lock_guard lock(mutex_);
    alarm_ = was_moving ? grbl::kAlarmAbortCycle : 0;
  }
  if (was_moving) write_line("ALARM:" + std::to_string(grbl::kAlarmAbortCycle));
  write_line(grbl::kBanner);
  if (was_moving || !machine_.status().homed) write_line("[MSG:'$H'|'$X' to unlock]");
}

void GrblServer::worker_loop() {
  for (;;) {
    std::string line;
    std::uint64_t generation = 0;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [&] { return !lines_.empty() || !running_; });
      if (!running_) return;
      line = lines_.front();
      lines_.pop_front();
      queued_bytes_ -= std::min(queued_bytes_, line.size());
      generation = generation_;
      busy_ = true;
    }
    execute(line, generation);
    std::lock_guard lock(mutex_);
    busy_ = in_motion_ = homing_ = held_ = hold_ = false;
    wake_.notify_all();
  }
}

void GrblServer::reply(const std::string& text, std::uint64_t generation, int command) {
  std::unique_lock lock(mutex_);
  in_motion_ = homing_ = false;
  if (command > 0 && faults_.reply_delay_s > 0)
    wake_.wait_for(lock, std::chrono::duration<double>(faults_.reply_delay_s),
                   [&] { return generation != generation_ || !running_; });
  if (generation != generation_) return;  // a soft reset flushed the line
  std::string out = text;
  if (command > 0 && command == faults_.corrupt_reply_at_command) out = "o\x7f" + text.substr(1) + "#";
  write_line(out);
}

void GrblServer::emit(const std::string& text, std::uint64_t generation) {
  std::lock_guard lock(mutex_);
  if (generation == generation_) write_line(text);
}

std::string GrblServer::settings_report() const {
  const description::MachineDescription info = machine_.info();
  const Vec3 travel = info.travel_box.max - info.travel_box.min;
  std::string out;
  auto put = [&](int n, double v) {  // appended piece by piece: GCC 12 -O3's false -Wrestrict (bug 105329)
    out += '$';
    out += std::to_string(n);
    out += '=';
    out += grbl::format_number(v);
    out += "\r\n";
  };
  put(10, 1);   // MPos in status reports
  put(20, 1);   // soft limits
  put(21, 0);   // hard limits
  put(22, 1);   // homing cycle
  for (int axis = 0; axis < 3; ++axis) put(110 + axis, info.max_speed_mm_s * 60);
  for (int axis = 0; axis < 3; ++axis) put(120 + axis, info.max_accel_mm_s2);
  for (int axis = 0; axis < 3; ++axis) put(130 + axis, travel[axis]);
  out.resize(out.size() - 2);
  return out;
}

void GrblServer::execute(const std::string& raw, std::uint64_t generation) {
  std::string line;
  for (char c : raw)
    if (!std::isspace(static_cast<unsigned char>(c))) line.push_back(static_cast<char>(std::toupper(static_cast<unsigned char>(c))));
  auto error = [&](int code, int command = 0) { reply("error:" + std::to_string(code), generation, command); };
  if (raw.size() >= kLineBytes) return error(grbl::kErrorLineTooLong);
  if (line.empty()) return reply("ok", generation, 0);

  const hal::MachineStatus s = machine_.status();
  bool locked = false;
  {
    std::lock_guard lock(mutex_);
    locked = s.estop || alarm_ || !s.homed;
  }
  if (line[0] == '$') {
    if (line == "$$") {
      emit(settings_report(), generation);
      return reply("ok", generation, 0);
    }
    if (line == "$#") {
      for (const char* wcs : {"G54", "G55", "G56", "G57", "G58", "G59", "G28", "G30", "G92"})
        emit(std::string("[") + wcs + ":0.000000,0.000000,0.000000]", generation);
      emit("[TLO:0.000000]", generation);
      emit(grbl::format_probe(last_probe_), generation);
      return reply("ok", generation, 0);
    }
    if (line == "$") {
      emit("[HLP:$$ $# $G $I $N $x=val $Nx=line $J=line $SLP $C $X $H ~ ! ? ctrl-x]", generation);
      return reply("ok", generation, 0);
    }
    if (line == "$I") {
      emit("[VER:1.1h.20190830:cmm-sim]", generation);
      emit("[OPT:V,15,128]", generation);
      return reply("ok", generation, 0);
    }
    if (line == "$X") {
      // Our dialect keeps the homing lock: $X clears an alarm only while the position is known.
      if (s.estop || !s.homed) return error(grbl::kErrorLocked);
      {
        std::lock_guard lock(mutex_);
        alarm_ = 0;
      }
      emit("[MSG:Caution: Unlocked]", generation);
      return reply("ok", generation, 0);
    }
    if (line == "$H") {
      int command = 0;
      if (!begin_motion(command, true)) return;
      try {
        machine_.home();
        {
          std::lock_guard lock(mutex_);
          alarm_ = 0;
        }
        return reply("ok", generation, command);
      } catch (const hal::Fault& f) {
        return fault(f, generation, command, false);
      }
    }
    return error(grbl::kErrorInvalidStatement);
  }

  int code = 0;
  auto words = words_of(line, code);
  if (!words) return error(code);
  std::optional<double> motion;
  bool g53 = false, g10 = false;
  std::optional<double> x, y, z, l, p;
  for (const Word& w : *words) {
    switch (w.letter) {
      case 'G':
        if (is(w.value, 0) || is(w.value, 1) || is(w.value, 38.2) || is(w.value, 38.3)) motion = w.value;
        else if (is(w.value, 53)) g53 = true;
        else if (is(w.value, 10)) g10 = true;
        else if (!(is(w.value, 21) || is(w.value, 90) || is(w.value, 54) || is(w.value, 17) || is(w.value, 94) ||
                   is(w.value, 92.1) || is(w.value, 4)))
          return error(grbl::kErrorUnsupported);  // G20, G91, G2/G3, other offsets: not in our dialect
        break;
      case 'X': x = w.value; break;
      case 'Y': y = w.value; break;
      case 'Z': z = w.value; break;
      case 'F': feed_mm_min_ = w.value; break;
      case 'L': l = w.value; break;
      case 'P': p = w.value; break;
      case 'N': break;
      default: return error(grbl::kErrorUnsupported);
    }
  }
  if (locked) return error(grbl::kErrorLocked);
  if (g10) {
    // Only clearing G54 (G10 L2 P1 X0 Y0 Z0): work coordinates stay machine coordinates.
    const bool zero = (!x || *x == 0) && (!y || *y == 0) && (!z || *z == 0);
    if (!l || *l != 2 || !p || *p != 1 || !zero || motion) return error(grbl::kErrorUnsupported);
    return reply("ok", generation, 0);
  }
  if (g53 && motion && !(is(*motion, 0) || is(*motion, 1))) return error(grbl::kErrorG53);
  if (!motion) {
    if (x || y || z) return error(grbl::kErrorUnsupported);  // modal motion is not in our dialect
    return reply("ok", generation, 0);
  }
  if (!x && !y && !z) return error(grbl::kErrorNoAxisWords);
  const bool probe = is(*motion, 38.2) || is(*motion, 38.3);
  if ((probe || is(*motion, 1)) && !(feed_mm_min_ > 0)) return error(grbl::kErrorNoFeed);

  const description::MachineDescription info = machine_.info();
  Vec3 offset = Vec3::Zero();
  for (const auto& tip : info.tips)
    if (tip.id == info.active_tip) offset = tip.offset;
  const Vec3 here = s.position - offset;
  const Vec3 target(x.value_or(here.x()), y.value_or(here.y()), z.value_or(here.z()));
  const double distance = (target - here).norm();
  if (probe && distance < 1e-9) return error(grbl::kErrorInvalidTarget);

  int command = 0;
  if (!begin_motion(command, false)) return;
  try {
    if (!probe) {
      machine_.move({target + offset, is(*motion, 0) ? 0 : feed_mm_min_ / 60});
      return reply("ok", generation, command);
    }
    hal::ProbeMove move;
    move.start = s.position;
    move.direction = (target - here) / distance;
    move.max_travel_mm = distance;
    move.speed_mm_s = feed_mm_min_ / 60;
    move.retract_mm = 0;
    move.min_travel_mm = 0;
    move.fail_on_miss = is(*motion, 38.2);
    const hal::TouchResult touch = machine_.probe(move);
    {
      std::lock_guard lock(mutex_);
      last_probe_ = {touch.centre - offset, touch.contact};
    }
    emit(grbl::format_probe({touch.centre - offset, touch.contact}), generation);
    return reply("ok", generation, command);
  } catch (const hal::Fault& f) {
    return fault(f, generation, command, probe);
  } catch (const std::exception&) {
    return error(grbl::kErrorInvalidTarget, command);
  }
}

bool GrblServer::begin_motion(int& command, bool homing) {
  std::lock_guard lock(mutex_);
  command = ++commands_;
  if (faults_.drop_link_after_commands > 0 && commands_ > faults_.drop_link_after_commands && !dropped_) {
    dropped_ = drop_now_ = true;  // once: the cable is pulled, this line is lost with it
    return false;
  }
  in_motion_ = true;
  homing_ = homing;
  machine_.accept_command();  // a feed hold or a reset from now on stops this line's motion
  return true;
}

void GrblServer::fault(const hal::Fault& f, std::uint64_t generation, int command, bool probe) {
  const auto position = [&] {
    const description::MachineDescription info = machine_.info();
    Vec3 offset = Vec3::Zero();
    for (const auto& tip : info.tips)
      if (tip.id == info.active_tip) offset = tip.offset;
    return Vec3(machine_.status().position - offset);
  };
  auto alarm = [&](int code) {
    {
      std::lock_guard lock(mutex_);
      alarm_ = code;
    }
    reply("ALARM:" + std::to_string(code), generation, command);
  };
  switch (f.kind()) {
    case hal::FaultKind::soft_limit: return reply("error:" + std::to_string(grbl::kErrorTravelExceeded), generation, command);
    case hal::FaultKind::not_homed: return reply("error:" + std::to_string(grbl::kErrorLocked), generation, command);
    case hal::FaultKind::early_trigger:
      if (!probe) return alarm(grbl::kAlarmHardLimit);  // G0/G1/$H cannot pass through the part
      // A trigger at the very start of a G38 travel: a probe stop like any other.
      {
        std::lock_guard lock(mutex_);
        last_probe_ = {position(), true};
      }
      emit(grbl::format_probe({position(), true}), generation);
      return reply("ok", generation, command);
    case hal::FaultKind::no_contact:
      {
        std::lock_guard lock(mutex_);
        last_probe_ = {position(), false};
      }
      emit(grbl::format_probe({position(), false}), generation);
      return alarm(grbl::kAlarmProbeContact);
    case hal::FaultKind::estop:
      // The e-stop input is wired to Grbl's reset pin: an abort cycle, then the board restarts.
      alarm(grbl::kAlarmAbortCycle);
      emit(grbl::kBanner, generation);
      return;
    case hal::FaultKind::aborted: {
      std::unique_lock lock(mutex_);
      if (generation != generation_ || !hold_) return;  // a soft reset: the line is flushed unanswered
      held_ = true;
      in_motion_ = false;
      wake_.wait(lock, [&] { return !hold_ || generation != generation_ || !running_; });
      if (generation != generation_) return;
      lock.unlock();
      return reply("ok", generation, command);  // resumed with ~: the held motion ends where it stopped
    }
    default: return reply("error:" + std::to_string(grbl::kErrorInvalidTarget), generation, command);
  }
}

}  // namespace cmm::sim
