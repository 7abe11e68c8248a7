// The Modbus driver: command blocks with a sequence echo, status polls on a second context, typed
// faults from libmodbus's errno, reconnection with backoff, and a heartbeat thread.
#include "hal/modbus_cmm.hpp"

#include <cerrno>
#include <chrono>
#include <cmath>

#include "hal/description/json_fields.hpp"
#include "hal/modbus_map.hpp"
#include "hal/modbus_status.hpp"
#include "hal/utc_time.hpp"

namespace cmm::hal {

namespace mb = modbus;
using Clock = std::chrono::steady_clock;

ModbusSettings modbus_settings_from_json(const nlohmann::json& j) {
  description::JsonFields b(j);
  b.expect_object();
  ModbusSettings s;
  b.text("driver", "modbus", {"modbus"});
  s.transport = b.text("transport", s.transport, {"tcp", "rtu"});
  s.host = b.text("host", s.host);
  s.port = b.integer("port", s.port, 1, 65535);
  s.device = b.text("device", s.device);
  s.baud = b.integer("baud", s.baud, 1200, 4000000);
  s.parity = b.text("parity", s.parity, {"N", "E", "O"});
  s.unit_id = b.integer("unit_id", s.unit_id, 1, 247);
  s.response_timeout_s = b.number("response_timeout_s", s.response_timeout_s, 0.01, 60);
  s.motion_timeout_s = b.number("motion_timeout_s", s.motion_timeout_s, 0.1, 86400);
  s.poll_interval_s = b.number("poll_interval_s", s.poll_interval_s, 0, 1);
  s.heartbeat_s = b.number("heartbeat_s", s.heartbeat_s, 0, 10);
  s.heartbeat_timeout_s = b.number("heartbeat_timeout_s", s.heartbeat_timeout_s, 0.01, 60);
  s.connect_attempts = b.integer("connect_attempts", s.connect_attempts, 1, 100);
  s.connect_backoff_s = b.number("connect_backoff_s", s.connect_backoff_s, 0, 60);
  if (s.transport == "rtu" && s.device.empty()) b.problem("device", "the serial device is required for transport rtu");
  if (s.heartbeat_s > 0 && s.heartbeat_s >= s.heartbeat_timeout_s)
    b.problem("heartbeat_s", "must be shorter than heartbeat_timeout_s, or the machine stops between beats");
  b.finish();
  b.throw_if_problems("modbus driver config");
  return s;
}

ModbusCmm::ModbusCmm() : CmmDriver("the Modbus machine") {}
ModbusCmm::~ModbusCmm() { disconnect(); }

CmmDriver::ConnectPolicy ModbusCmm::connect_policy() const {
  return {settings_.connect_attempts, settings_.connect_backoff_s};
}

std::string ModbusCmm::endpoint() const {
  return settings_.transport == "rtu" ? settings_.device : settings_.host + ":" + std::to_string(settings_.port);
}

std::string ModbusCmm::where() const { return "the Modbus machine at " + endpoint(); }

void ModbusCmm::on_configure(const nlohmann::json& block) { settings_ = modbus_settings_from_json(block); }

modbus_t* ModbusCmm::open_context() const {
  modbus_t* ctx = settings_.transport == "rtu"
                      ? modbus_new_rtu(settings_.device.c_str(), settings_.baud, settings_.parity[0], 8, 1)
                      : modbus_new_tcp(settings_.host.c_str(), settings_.port);
  if (!ctx) return nullptr;
  modbus_set_slave(ctx, settings_.unit_id);
  const double t = settings_.response_timeout_s;
  modbus_set_response_timeout(ctx, static_cast<std::uint32_t>(t), static_cast<std::uint32_t>(std::fmod(t, 1.0) * 1e6));
  if (modbus_connect(ctx) < 0) {
    modbus_free(ctx);
    return nullptr;
  }
  return ctx;
}

void ModbusCmm::close_contexts() {
  std::scoped_lock lock(command_mutex_, aux_mutex_);
  for (modbus_t** ctx : {&command_ctx_, &aux_ctx_})
    if (*ctx) {
      modbus_close(*ctx);
      modbus_free(*ctx);
      *ctx = nullptr;
    }
}

void ModbusCmm::on_connect() {
  stop_heartbeat();  // a link that dropped left its heartbeat thread behind
  close_contexts();
  modbus_t* command = open_context();
  const int error = errno;
  modbus_t* aux = command && settings_.transport == "tcp" ? open_context() : nullptr;
  if (!command || (!aux && settings_.transport == "tcp")) {
    const int aux_error = errno;
    if (command) modbus_close(command), modbus_free(command);
    throw CommLost(modbus_strerror(command ? aux_error : error));
  }
  {
    std::scoped_lock lock(command_mutex_, aux_mutex_);
    command_ctx_ = command, aux_ctx_ = aux;
  }
  {
    std::lock_guard lock(down_mutex_);
    down_.reset();
  }
  const auto version = read(command_link(), mb::address("protocol_version"), 1, "connect");
  if (version[0] != mb::kProtocolVersion)
    throw Protocol(where() + " speaks register map version " + std::to_string(version[0]) + ", this driver version " +
                   std::to_string(mb::kProtocolVersion));
  read_info();  // the tip table
  // A command from before the link dropped may still be running: its outcome is unknown, so it is
  // stopped, never replayed, and its echo is awaited so that the next number cannot collide with it.
  if (read(command_link(), mb::address("flags"), 1, "connect")[0] & mb::busy) {
    write_single(command_link(), mb::address("urgent"), mb::Urgent::stop, "connect");
    const auto deadline = Clock::now() + std::chrono::duration<double>(settings_.motion_timeout_s);
    while (read(command_link(), mb::address("flags"), 1, "connect")[0] & mb::busy) {
      if (Clock::now() > deadline) throw Timeout("connect: the machine's last command does not stop");
      std::this_thread::sleep_for(std::chrono::duration<double>(std::max(settings_.poll_interval_s, 1e-3)));
    }
  }
  seq_ = read(command_link(), mb::address("done_seq"), 1, "connect")[0];
  if (settings_.heartbeat_s > 0) {
    write_single(command_link(), mb::address("heartbeat_timeout"),
                 static_cast<std::uint16_t>(std::lround(settings_.heartbeat_timeout_s * 1000)), "connect");
    heartbeat_stop_ = false;
    heartbeat_ = std::thread([this] { heartbeat_loop(); });
  }
}

void ModbusCmm::stop_heartbeat() {
  {
    std::lock_guard lock(heartbeat_mutex_);
    heartbeat_stop_ = true;
    heartbeat_wake_.notify_all();
  }
  if (heartbeat_.joinable()) heartbeat_.join();
}

void ModbusCmm::on_disconnect() {
  stop_heartbeat();
  close_contexts();
  std::lock_guard lock(down_mutex_);
  down_.reset();
}

void ModbusCmm::heartbeat_loop() {
  std::uint16_t beat = 0;
  std::unique_lock lock(heartbeat_mutex_);
  while (!heartbeat_wake_.wait_for(lock, std::chrono::duration<double>(settings_.heartbeat_s), [&] { return heartbeat_stop_; })) {
    lock.unlock();
    try {
      write_single(aux_link(), mb::address("heartbeat"), ++beat, "heartbeat");
    } catch (const std::exception&) {
      // A missed beat is the point of a heartbeat: the machine notices; the next call reports the
      // link, which a beat left unanswered has dropped. Nothing beats on a dropped link.
      if (!link_up()) return;
    }
    lock.lock();
  }
}

void ModbusCmm::request_failed(modbus_t*& ctx, const char* what, int error) {
  const std::string message = std::string(what) + ": " + modbus_strerror(error);
  FaultKind kind = FaultKind::comm_lost;
  std::string why = message;
  switch (error) {
    case EMBXILFUN: case EMBXILADD: case EMBXILVAL: case EMBXSFAIL: case EMBXACK: case EMBXSBUSY: case EMBXNACK:
    case EMBXMEMPAR: case EMBXGPATH: case EMBXGTAR: case EMBBADEXC: case EMBBADCRC: case EMBMDATA:
      // The machine answered this very request (refused it, or the frame came damaged), or libmodbus
      // refused it before sending: the context is still in step.
      modbus_flush(ctx);
      throw Protocol(message);
    case ETIMEDOUT:
      // The answer may still come, after the next request has gone out: it would be read as that
      // one's answer (libmodbus's flush drops only what has already arrived).
      kind = FaultKind::timeout;
      why = message + " (no answer within " + std::to_string(settings_.response_timeout_s) + " s)";
      break;
    case EMBBADDATA: case EMBBADSLAVE:
      // An answer to another request (a wrong transaction id, function or unit): an earlier one
      // came late, so this request's own answer is still to come.
      kind = FaultKind::protocol;
      why = message + " (an answer that is not this request's)";
      break;
    default:
      break;  // the connection itself is gone
  }
  // The link cannot be trusted any more: a motion's outcome is unknown and nothing is replayed;
  // connect() opens the link afresh and re-reads the machine.
  modbus_close(ctx);
  modbus_free(ctx);
  ctx = nullptr;
  {
    std::lock_guard lock(down_mutex_);
    if (!down_) down_.emplace(kind, why);
  }
  drop_link();
  throw_fault(kind, why + "; the link is closed until connect()");
}

void ModbusCmm::link_is_down(const char* what) const {
  std::lock_guard lock(down_mutex_);
  if (!down_) throw CommLost(std::string(what) + ": the Modbus link is down");
  // The fault that dropped the link on another thread (the heartbeat, a status poll) is the one
  // this call failed for, too.
  throw_fault(down_->first, std::string(what) + ": the Modbus link is down after " + down_->second);
}

template <class Request>
void ModbusCmm::exchange(Link link, const char* what, Request&& request, bool even_if_down) {
  std::lock_guard lock(*link.mutex);
  modbus_t*& ctx = *link.ctx;
  if (!ctx || (!even_if_down && !link_up())) link_is_down(what);
  if (request(ctx)) return;
  request_failed(ctx, what, errno);
}

std::vector<std::uint16_t> ModbusCmm::read(Link link, int address, int count, const char* what) {
  std::vector<std::uint16_t> regs(static_cast<std::size_t>(count));
  exchange(link, what, [&](modbus_t* ctx) { return modbus_read_registers(ctx, address, count, regs.data()) == count; });
  return regs;
}

void ModbusCmm::write_single(Link link, int address, std::uint16_t value, const char* what, bool even_if_down) {
  exchange(link, what, [&](modbus_t* ctx) { return modbus_write_register(ctx, address, value) == 1; }, even_if_down);
}

std::vector<std::uint16_t> ModbusCmm::run_command(std::vector<std::uint16_t> block, const char* what, bool motion) {
  bool echoed_fault = false;  // the machine finished the command with a fault: it is not running
  try {
    seq_ = static_cast<std::uint16_t>(seq_ % 65535 + 1);
    block[0] = seq_;
    exchange(command_link(), what, [&](modbus_t* ctx) {
      return modbus_write_registers(ctx, mb::kCommandFirst, mb::kCommandCount, block.data()) == mb::kCommandCount;
    });
    const auto deadline = Clock::now() + std::chrono::duration<double>(settings_.motion_timeout_s);
    for (;;) {
      auto regs = read(command_link(), mb::kStatusFirst, mb::kStatusCount, what);
      if (regs[mb::address("done_seq")] == seq_) {
        if (const std::uint16_t result = regs[mb::address("done_result")]) {
          const auto text = read(command_link(), mb::address("fault_text"), 64, what);
          echoed_fault = true;
          throw_fault(mb::fault_from_code(result), mb::get_ascii(text.data(), 64));
        }
        return regs;
      }
      if (Clock::now() > deadline) {
        throw Timeout(std::string(what) + ": no echo of command " + std::to_string(seq_) + " within " +
                      std::to_string(settings_.motion_timeout_s) + " s");
      }
      if (settings_.poll_interval_s > 0) std::this_thread::sleep_for(std::chrono::duration<double>(settings_.poll_interval_s));
    }
  } catch (const Fault&) {
    // A fault of the link, not of the machine: the command may be running unwatched. Stop it if any
    // context still reaches it, even with the link dropped (the heartbeat stops it otherwise).
    if (motion && !echoed_fault) try {
        write_single(aux_link(), mb::address("urgent"), mb::Urgent::stop, what, true);
      } catch (const std::exception&) {
      }
    throw;
  }
}

namespace {
std::vector<std::uint16_t> empty_block(std::uint16_t opcode) {
  std::vector<std::uint16_t> block(mb::kCommandCount, 0);
  block[1] = opcode;
  return block;
}
std::uint16_t* field(std::vector<std::uint16_t>& block, std::uint16_t address) {
  return block.data() + (address - mb::kCommandFirst);
}
void put_vec(std::uint16_t* regs, const Vec3& v, double unit) {
  for (int i = 0; i < 3; ++i) mb::put_i32(regs + 2 * i, static_cast<std::int32_t>(std::lround(v[i] / unit)));
}
Vec3 get_vec(const std::uint16_t* regs) {
  return Vec3(mb::get_i32(regs), mb::get_i32(regs + 2), mb::get_i32(regs + 4)) * 1e-6;
}
}  // namespace

MachineStatus ModbusCmm::decode_status(const std::vector<std::uint16_t>& r) const {
  std::lock_guard lock(tips_mutex_);
  return mb::decode_status(r, tip_ids_);
}

MachineStatus ModbusCmm::read_status() {
  auto regs = read(aux_link(), mb::kStatusFirst, mb::kStatusCount, "status");
  MachineStatus s = decode_status(regs);
  if (s.fault) s.fault_message = mb::get_ascii(read(aux_link(), mb::address("fault_text"), 64, "status").data(), 64);
  return s;
}

description::MachineDescription ModbusCmm::read_info() {
  auto r = read(aux_link(), mb::kInfoFirst, mb::kInfoCount, "info");
  auto at = [&](std::uint16_t address) { return &r[static_cast<std::size_t>(address - mb::kInfoFirst)]; };
  description::MachineDescription info;
  info.name = "Modbus machine at " + endpoint();
  info.travel_box = {get_vec(at(mb::address("box_min_x"))), get_vec(at(mb::address("box_max_x")))};
  info.max_speed_mm_s = mb::get_u32(at(mb::address("max_speed"))) * 1e-3;
  info.max_accel_mm_s2 = mb::get_u32(at(mb::address("max_accel"))) * 1e-3;
  info.probe_speed_mm_s = mb::get_u32(at(mb::address("probe_speed"))) * 1e-3;
  info.reference_sphere = {get_vec(at(mb::address("sphere_x"))), mb::get_u32(at(mb::address("sphere_radius"))) * 1e-6};
  const int tips = std::min<int>(*at(mb::address("tip_count")), mb::kMaxTips);
  std::vector<std::string> ids;
  for (int i = 0; i < tips; ++i) {
    auto t = read(aux_link(), mb::address("tip_id") + i * mb::kTipStride, mb::kTipEntryCount, "info");
    const description::StylusTip tip = mb::decode_tip(t);
    ids.push_back(tip.id);
    info.tips.push_back(tip);
  }
  {
    std::lock_guard lock(tips_mutex_);
    tip_ids_ = ids;
  }
  const std::size_t active = read(aux_link(), mb::address("active_tip"), 1, "info")[0];
  info.active_tip = active < ids.size() ? ids[active] : "";
  return info;
}

void ModbusCmm::do_home() { run_command(empty_block(mb::Opcode::home), "home", true); }

void ModbusCmm::do_move(const Move& move) {
  auto block = empty_block(mb::Opcode::move);
  put_vec(field(block, mb::address("x")), move.target, 1e-6);
  mb::put_u32(field(block, mb::address("speed")), mb::to_unsigned(move.speed_mm_s, 1e-3));
  run_command(block, "move", true);
}

TouchResult ModbusCmm::do_probe(const ProbeMove& move) {
  auto block = empty_block(mb::Opcode::probe);
  put_vec(field(block, mb::address("x")), move.start, 1e-6);
  put_vec(field(block, mb::address("dir_x")), move.direction.normalized(), 1e-9);
  mb::put_u32(field(block, mb::address("speed")), mb::to_unsigned(move.speed_mm_s, 1e-3));
  mb::put_u32(field(block, mb::address("max_travel")), mb::to_unsigned(move.max_travel_mm, 1e-6));
  mb::put_u32(field(block, mb::address("min_travel")), mb::to_unsigned(move.min_travel_mm, 1e-6));
  mb::put_u32(field(block, mb::address("retract")), mb::to_unsigned(move.retract_mm, 1e-6));
  *field(block, mb::address("probe_flags")) = move.fail_on_miss ? 1 : 0;
  auto r = run_command(block, "probe", true);
  std::lock_guard lock(tips_mutex_);
  return mb::decode_touch(r, tip_ids_);
}

void ModbusCmm::do_stop() {
  if (!link_up()) return;
  write_single(aux_link(), mb::address("urgent"), mb::Urgent::stop, "stop");
}

void ModbusCmm::do_abort() {
  if (!link_up()) return;
  write_single(aux_link(), mb::address("urgent"), mb::Urgent::abort, "abort");
}

void ModbusCmm::do_reset() { run_command(empty_block(mb::Opcode::reset), "reset", false); }

int ModbusCmm::tip_index(const std::string& id) {
  std::lock_guard lock(tips_mutex_);
  for (std::size_t i = 0; i < tip_ids_.size(); ++i)
    if (tip_ids_[i] == id) return static_cast<int>(i);
  throw std::invalid_argument("no tip \"" + id + "\" on the Modbus machine");
}

void ModbusCmm::do_select_tip(const std::string& tip_id) {
  auto block = empty_block(mb::Opcode::select_tip);
  *field(block, mb::address("tip")) = static_cast<std::uint16_t>(tip_index(tip_id));
  run_command(block, "select_tip", false);
}

void ModbusCmm::do_record_qualification(const std::string& tip_id, const description::TipQualification& q) {
  auto block = empty_block(mb::Opcode::set_tip);
  *field(block, mb::address("tip")) = static_cast<std::uint16_t>(tip_index(tip_id));
  put_vec(field(block, mb::address("x")), q.offset, 1e-6);
  mb::put_u32(field(block, mb::address("max_travel")), mb::to_unsigned(q.ball_radius_mm, 1e-6));
  mb::put_u32(field(block, mb::address("min_travel")), static_cast<std::uint32_t>(unix_seconds(q.time_utc)));
  mb::put_u32(field(block, mb::address("retract")), mb::to_unsigned(q.residual_rms_mm, 1e-6));
  *field(block, mb::address("touches")) = static_cast<std::uint16_t>(q.touches);
  run_command(block, "record_qualification", false);
}

}  // namespace cmm::hal
