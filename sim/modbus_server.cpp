// The Modbus server loop: select() over the listening socket and its clients, libmodbus to parse
// and answer, a worker thread to run each command on the machine while polls go on.
#include "sim/modbus_server.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/select.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "hal/modbus_map.hpp"
#include "hal/utc_time.hpp"

namespace cmm::sim {

namespace mb = hal::modbus;

namespace {
constexpr std::uint16_t kUrgent = mb::address("urgent"), kHeartbeat = mb::address("heartbeat"),
                        kHeartbeatTimeout = mb::address("heartbeat_timeout");

bool writable(int address, int count) {
  const int end = address + count;
  return (address >= mb::kCommandFirst && end <= mb::kCommandFirst + mb::kCommandCount) ||
         (address >= kUrgent && end <= kHeartbeatTimeout + 1);
}

void put_vec(std::uint16_t* regs, const Vec3& v) {
  for (int i = 0; i < 3; ++i) mb::put_i32(regs + 2 * i, mb::to_nm(v[i]));
}
Vec3 get_vec(const std::uint16_t* regs, double unit) {
  return Vec3(mb::get_i32(regs), mb::get_i32(regs + 2), mb::get_i32(regs + 4)) * unit;
}
}  // namespace

ModbusServer::ModbusServer(SimulatedMachine& machine, const FaultInjection& faults, const ModbusTcpEndpoint& endpoint)
    : machine_(machine), faults_(faults) {
  ctx_ = modbus_new_tcp(endpoint.host.c_str(), endpoint.port);
  map_ = modbus_mapping_new(0, 0, mb::kRegisterSpace, 0);
  if (!ctx_ || !map_) throw std::runtime_error("cmm-sim: cannot create the Modbus server context");
  listen_fd_ = modbus_tcp_listen(ctx_, 8);
  if (listen_fd_ < 0)
    throw std::runtime_error("cmm-sim: cannot listen for Modbus TCP on " + endpoint.host + ":" +
                             std::to_string(endpoint.port) + ": " + modbus_strerror(errno));
  sockaddr_in address{};
  socklen_t length = sizeof address;
  getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&address), &length);
  port_ = ntohs(address.sin_port);
  start();
}

ModbusServer::ModbusServer(SimulatedMachine& machine, const FaultInjection& faults, const ModbusRtuEndpoint& endpoint)
    : machine_(machine), faults_(faults), rtu_(true) {
  ctx_ = modbus_new_rtu(endpoint.device.c_str(), endpoint.baud, 'N', 8, 1);
  map_ = modbus_mapping_new(0, 0, mb::kRegisterSpace, 0);
  if (!ctx_ || !map_) throw std::runtime_error("cmm-sim: cannot create a Modbus RTU context for " + endpoint.device);
  modbus_set_slave(ctx_, 1);
  if (modbus_connect(ctx_) < 0)
    throw std::runtime_error("cmm-sim: cannot open " + endpoint.device + " for Modbus RTU: " + modbus_strerror(errno));
  start();
}

void ModbusServer::start() {
  last_heartbeat_ = std::chrono::steady_clock::now();
  worker_ = std::thread([this] { worker_loop(); });
}

ModbusServer::~ModbusServer() {
  shutdown();
  {
    std::lock_guard lock(mutex_);
    wake_.notify_all();
  }
  machine_.abort();  // a motion still running must not keep the worker
  if (worker_.joinable()) worker_.join();
  drop_clients();
  if (listen_fd_ >= 0) close(listen_fd_);
  if (rtu_) modbus_close(ctx_);
  modbus_mapping_free(map_);
  modbus_free(ctx_);
}

void ModbusServer::shutdown() { running_ = false; }

void ModbusServer::drop_clients() {
  for (int fd : clients_) close(fd);
  clients_.clear();
}

void ModbusServer::serve_rtu(std::uint8_t* query) {
  const int fd = modbus_get_socket(ctx_);
  while (running_) {
    fd_set readable;
    FD_ZERO(&readable);
    FD_SET(fd, &readable);
    timeval tick{0, 5000};
    if (select(fd + 1, &readable, nullptr, nullptr, &tick) < 0 && errno != EINTR)
      throw std::runtime_error(std::string("cmm-sim: select: ") + std::strerror(errno));
    watch_heartbeat();
    if (!FD_ISSET(fd, &readable)) continue;
    const int length = modbus_receive(ctx_, query);
    if (length < 0) {
      modbus_flush(ctx_);  // a garbled frame: the client times out and retries
    } else if (length > 0 && !silent_) {
      handle(fd, query, length);
    }
  }
}

void ModbusServer::serve() {
  std::vector<std::uint8_t> query(MODBUS_TCP_MAX_ADU_LENGTH > MODBUS_RTU_MAX_ADU_LENGTH ? MODBUS_TCP_MAX_ADU_LENGTH
                                                                                         : MODBUS_RTU_MAX_ADU_LENGTH);
  if (rtu_) return serve_rtu(query.data());
  while (running_) {
    fd_set readable;
    FD_ZERO(&readable);
    FD_SET(listen_fd_, &readable);
    int top = listen_fd_;
    for (int fd : clients_) FD_SET(fd, &readable), top = std::max(top, fd);
    timeval tick{0, 5000};  // wakes to watch the heartbeat and the shutdown flag
    if (select(top + 1, &readable, nullptr, nullptr, &tick) < 0) {
      if (errno == EINTR) continue;
      throw std::runtime_error(std::string("cmm-sim: select: ") + std::strerror(errno));
    }
    watch_heartbeat();
    if (FD_ISSET(listen_fd_, &readable)) {
      int fd = accept(listen_fd_, nullptr, nullptr);
      if (fd >= 0) clients_.push_back(fd);
    }
    for (int fd : std::vector<int>(clients_)) {
      if (!FD_ISSET(fd, &readable) || std::find(clients_.begin(), clients_.end(), fd) == clients_.end()) continue;
      modbus_set_socket(ctx_, fd);
      int length = modbus_receive(ctx_, query.data());
      if (length < 0) {
        close(fd);
        clients_.erase(std::find(clients_.begin(), clients_.end(), fd));
      } else if (length > 0) {
        handle(fd, query.data(), length);
      }
    }
  }
}

void ModbusServer::watch_heartbeat() {
  const int timeout_ms = map_->tab_registers[kHeartbeatTimeout];
  std::lock_guard lock(mutex_);
  if (timeout_ms == 0 || !busy_ || stale_stop_) return;
  if (std::chrono::steady_clock::now() - last_heartbeat_ > std::chrono::milliseconds(timeout_ms)) {
    stale_stop_ = stale_ = true;
    machine_.stop();  // the link is gone quiet: brake, keep the position, report CommLost
  }
}

void ModbusServer::handle(int fd, const std::uint8_t* query, int length) {
  const int offset = modbus_get_header_length(ctx_);
  const int function = query[offset];
  const int address = (query[offset + 1] << 8) | query[offset + 2];
  const int count = function == MODBUS_FC_WRITE_SINGLE_REGISTER ? 1 : (query[offset + 3] << 8) | query[offset + 4];
  const bool write = function == MODBUS_FC_WRITE_SINGLE_REGISTER || function == MODBUS_FC_WRITE_MULTIPLE_REGISTERS;
  if (write && !writable(address, count)) {
    modbus_reply_exception(ctx_, query, MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS);
    return;
  }
  // A command is the whole block in one request: a partial write would run with the last block's
  // arguments.
  if (function == MODBUS_FC_WRITE_MULTIPLE_REGISTERS && address == mb::kCommandFirst && count != mb::kCommandCount) {
    modbus_reply_exception(ctx_, query, MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE);
    return;
  }
  const bool command = function == MODBUS_FC_WRITE_MULTIPLE_REGISTERS && address == mb::kCommandFirst;
  if (command) {
    ++commands_;
    if (faults_.drop_link_after_commands > 0 && commands_ > faults_.drop_link_after_commands && !dropped_) {
      dropped_ = true;  // once: the link may come back, as a cable put back in does
      drop_clients();
      silent_ = rtu_;  // a serial line has no connection to close: it just goes quiet
      return;
    }
    if (commands_ == faults_.corrupt_reply_at_command) {
      // A frame damaged on the way: over TCP the transaction id does not match the request's,
      // over RTU the CRC is wrong.
      std::uint8_t reply[12];
      std::memcpy(reply, query, static_cast<std::size_t>(offset + 1));
      std::memcpy(reply + offset + 1, query + offset + 1, 4);
      std::size_t size = static_cast<std::size_t>(offset) + 5;
      if (rtu_) {
        reply[size++] = 0xde, reply[size++] = 0xad;
      } else {
        reply[1] ^= 0x5a;
        reply[5] = 6;
      }
      if (::write(fd, reply, size) < 0) { /* the client is gone; the loop notices */ }
      return;
    }
    if (faults_.reply_delay_s > 0)
      std::this_thread::sleep_for(std::chrono::duration<double>(faults_.reply_delay_s));
  }
  refresh();
  if (modbus_reply(ctx_, query, length, map_) < 0) return;

  const std::uint16_t* regs = map_->tab_registers;
  if (command && regs[mb::kCommandFirst] != 0 && regs[mb::kCommandFirst] != last_seq_) {
    last_seq_ = regs[mb::kCommandFirst];
    std::lock_guard lock(mutex_);
    if (busy_ || pending_) {
      done_seq_ = last_seq_;
      done_result_ = mb::to_code(hal::FaultKind::protocol);
      done_message_ = "a command arrived while another was running";
      return;
    }
    stop_pending_ = false;
    machine_.accept_command();  // a stop or a stale heartbeat from now on stops this command
    pending_ = Command{last_seq_, std::vector<std::uint16_t>(regs + mb::kCommandFirst, regs + mb::kCommandFirst + mb::kCommandCount)};
    busy_ = true;
    stale_ = false;
    wake_.notify_all();
  } else if (function == MODBUS_FC_WRITE_SINGLE_REGISTER && address == kUrgent) {
    if (regs[kUrgent] == mb::Urgent::stop) machine_.stop();
    if (regs[kUrgent] == mb::Urgent::abort) machine_.abort();
    // A command accepted but not yet running on the machine must not start after this.
    std::lock_guard lock(mutex_);
    if (busy_ && regs[kUrgent] == mb::Urgent::stop) stop_pending_ = true;
  } else if (function == MODBUS_FC_WRITE_SINGLE_REGISTER && (address == kHeartbeat || address == kHeartbeatTimeout)) {
    std::lock_guard lock(mutex_);
    last_heartbeat_ = std::chrono::steady_clock::now();
  }
}

void ModbusServer::refresh() {
  std::uint16_t* r = map_->tab_registers;
  // One snapshot: the machine is read under the lock that also guards done_seq, so a client that
  // sees a command done never sees the machine still moving from it.
  std::lock_guard lock(mutex_);
  const hal::MachineStatus s = machine_.status();
  const description::MachineDescription info = machine_.info();
  r[mb::address("protocol_version")] = mb::kProtocolVersion;
  r[mb::address("flags")] = static_cast<std::uint16_t>((s.homed ? mb::homed : 0) | (s.moving ? mb::moving : 0) |
                                                       (s.estop ? mb::estop : 0) | (s.aborted ? mb::aborted : 0) |
                                                       (busy_ ? mb::busy : 0) | (stale_ ? mb::heartbeat_stale : 0));
  // A command the server ended before the machine ran it (stopped, or a stale heartbeat, before it
  // started; refused while another ran) leaves no fault on the machine, yet its fault stands too.
  r[mb::address("fault_code")] = s.fault ? mb::to_code(*s.fault) : done_result_;
  r[mb::address("done_seq")] = done_seq_;
  r[mb::address("done_result")] = done_result_;
  put_vec(r + mb::address("position_x"), s.position);
  mb::put_u32(r + mb::address("clock"), static_cast<std::uint32_t>(std::llround(s.t_s * 1000)));
  std::uint16_t active = 0;
  for (std::size_t i = 0; i < info.tips.size(); ++i)
    if (info.tips[i].id == info.active_tip) active = static_cast<std::uint16_t>(i);
  r[mb::address("active_tip")] = active;
  r[mb::address("touch_contact")] = touch_.contact;
  put_vec(r + mb::address("touch_x"), touch_.centre);
  mb::put_u32(r + mb::address("touch_travel"), mb::to_unsigned(touch_.travel_mm, 1e-6));
  mb::put_u32(r + mb::address("touch_clock"), static_cast<std::uint32_t>(std::llround(touch_.t_s * 1000)));

  put_vec(r + mb::address("box_min_x"), info.travel_box.min);
  put_vec(r + mb::address("box_max_x"), info.travel_box.max);
  mb::put_u32(r + mb::address("max_speed"), mb::to_unsigned(info.max_speed_mm_s, 1e-3));
  mb::put_u32(r + mb::address("max_accel"), mb::to_unsigned(info.max_accel_mm_s2, 1e-3));
  mb::put_u32(r + mb::address("probe_speed"), mb::to_unsigned(info.probe_speed_mm_s, 1e-3));
  put_vec(r + mb::address("sphere_x"), info.reference_sphere.centre);
  mb::put_u32(r + mb::address("sphere_radius"), mb::to_unsigned(info.reference_sphere.radius_mm, 1e-6));
  const int tips = std::min<int>(static_cast<int>(info.tips.size()), mb::kMaxTips);
  r[mb::address("tip_count")] = static_cast<std::uint16_t>(tips);
  for (int i = 0; i < tips; ++i) {
    const description::StylusTip& tip = info.tips[static_cast<std::size_t>(i)];
    std::uint16_t* base = r + i * mb::kTipStride;
    mb::put_ascii(base + mb::address("tip_id"), 4, tip.id);
    mb::put_u32(base + mb::address("tip_radius"), mb::to_unsigned(tip.ball_radius_mm, 1e-6));
    put_vec(base + mb::address("tip_offset_x"), tip.offset);
    const auto& q = tip.qualification;
    mb::put_u32(base + mb::address("tip_qualified"), q ? static_cast<std::uint32_t>(hal::unix_seconds(q->time_utc)) : 0);
    mb::put_u32(base + mb::address("tip_residual"), q ? mb::to_unsigned(q->residual_rms_mm, 1e-6) : 0);
    base[mb::address("tip_touches")] = q ? static_cast<std::uint16_t>(q->touches) : 0;
  }
  const std::string& text = done_result_ ? done_message_ : s.fault_message;
  mb::put_ascii(r + mb::address("fault_text"), 64, text);
}

void ModbusServer::worker_loop() {
  for (;;) {
    Command command;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [&] { return pending_.has_value() || !running_; });
      if (!pending_) return;
      command = *pending_;
      pending_.reset();
    }
    execute(command);
  }
}

void ModbusServer::execute(const Command& command) {
  {
    std::lock_guard lock(mutex_);
    if (stop_pending_ || stale_stop_) {
      done_result_ = mb::to_code(stale_stop_ ? hal::FaultKind::comm_lost : hal::FaultKind::aborted);
      done_message_ = stale_stop_ ? "the heartbeat went stale: the command did not start" : "stopped before it started";
      stale_stop_ = stop_pending_ = false;
      done_seq_ = command.seq;
      busy_ = false;
      return;
    }
  }
  const std::uint16_t* b = command.block.data();
  auto reg = [&](std::uint16_t address) { return b + (address - mb::kCommandFirst); };
  const Vec3 xyz = get_vec(reg(mb::address("x")), 1e-6);
  std::uint16_t result = 0;
  std::string message;
  std::optional<hal::TouchResult> touch;
  try {
    switch (b[1]) {
      case mb::Opcode::home: machine_.home(); break;
      case mb::Opcode::move: machine_.move({xyz, mb::get_u32(reg(mb::address("speed"))) * 1e-3}); break;
      case mb::Opcode::probe: {
        hal::ProbeMove p;
        p.start = xyz;
        p.direction = get_vec(reg(mb::address("dir_x")), 1e-9).normalized();
        p.speed_mm_s = mb::get_u32(reg(mb::address("speed"))) * 1e-3;
        p.max_travel_mm = mb::get_u32(reg(mb::address("max_travel"))) * 1e-6;
        p.min_travel_mm = mb::get_u32(reg(mb::address("min_travel"))) * 1e-6;
        p.retract_mm = mb::get_u32(reg(mb::address("retract"))) * 1e-6;
        p.fail_on_miss = (*reg(mb::address("probe_flags")) & 1u) != 0;
        touch = machine_.probe(p);
        break;
      }
      case mb::Opcode::reset: machine_.reset(); break;
      case mb::Opcode::select_tip:
      case mb::Opcode::set_tip: {
        const auto tips = machine_.info().tips;
        const std::size_t index = *reg(mb::address("tip"));
        if (index >= tips.size()) throw std::invalid_argument("tip index " + std::to_string(index) + " out of range");
        if (b[1] == mb::Opcode::select_tip) {
          machine_.select_tip(tips[index].id);
        } else {
          description::TipQualification q;
          q.offset = xyz;
          q.ball_radius_mm = mb::get_u32(reg(mb::address("max_travel"))) * 1e-6;
          q.time_utc = hal::utc_text(mb::get_u32(reg(mb::address("min_travel"))));
          q.residual_rms_mm = mb::get_u32(reg(mb::address("retract"))) * 1e-6;
          q.touches = *reg(mb::address("touches"));
          machine_.record_qualification(tips[index].id, q);
        }
        break;
      }
      default: throw std::invalid_argument("unknown opcode " + std::to_string(b[1]));
    }
  } catch (const hal::Fault& f) {
    result = mb::to_code(f.kind());
    message = f.what();
  } catch (const std::exception& e) {
    result = mb::to_code(hal::FaultKind::protocol);
    message = e.what();
  }
  std::lock_guard lock(mutex_);
  if (stale_stop_ && result == mb::to_code(hal::FaultKind::aborted)) {
    result = mb::to_code(hal::FaultKind::comm_lost);
    message = "the heartbeat went stale: the machine stopped";
  }
  stale_stop_ = false;
  if (touch) touch_ = *touch;
  done_seq_ = command.seq;
  done_result_ = result;
  done_message_ = message;
  busy_ = false;
}

}  // namespace cmm::sim
