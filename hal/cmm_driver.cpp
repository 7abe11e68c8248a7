// The lifecycle, its checks and the latches every driver shares; see cmm_driver.hpp.
#include "hal/cmm_driver.hpp"

#include <chrono>
#include <thread>

#include "hal/touch_check.hpp"

namespace cmm::hal {

CmmDriver::CmmDriver(std::string machine) : machine_(std::move(machine)) {}

void CmmDriver::require(Lifecycle needed, const char* what) const {
  const Lifecycle now = lifecycle_.load();
  if (now < needed)
    throw StateError(std::string(what) + ": " + machine_ + " is " + to_string(now) + ", needs " + to_string(needed));
}

void CmmDriver::lower_to(Lifecycle state) {
  Lifecycle now = lifecycle_.load();
  while (now > state && !lifecycle_.compare_exchange_weak(now, state)) {
  }
}

void CmmDriver::drop_link() {
  connecting_ = false;
  lower_to(Lifecycle::configured);
}

void CmmDriver::configure(const nlohmann::json& block) {
  if (lifecycle_.load() >= Lifecycle::connected) throw StateError("configure: disconnect first");
  on_configure(block);
  lifecycle_ = Lifecycle::configured;
}

void CmmDriver::connect() {
  require(Lifecycle::configured, "connect");
  if (lifecycle_.load() >= Lifecycle::connected) return;
  const ConnectPolicy policy = connect_policy();
  double backoff_s = policy.backoff_s;
  std::string error;
  for (int attempt = 0; attempt < policy.attempts; ++attempt) {
    if (attempt > 0) {
      std::this_thread::sleep_for(std::chrono::duration<double>(backoff_s));
      backoff_s *= 2;
    }
    connecting_ = true;  // the link's first requests go out; to everyone else it is not up yet
    try {
      on_connect();
      lifecycle_ = Lifecycle::connected;
      connecting_ = false;
      clear_latches(false);  // what the old link reported is history; the machine's own status tells the rest
      return;
    } catch (const Fault& e) {
      // A link that is not there yet, or a machine still booting, may answer the next try; anything
      // else (a garbled answer: the wrong device or baud; a register map of another version; the
      // e-stop) will not, so it ends the connect at once with its own kind.
      if (e.kind() != FaultKind::comm_lost && e.kind() != FaultKind::timeout) {
        connecting_ = false;
        on_disconnect();
        throw;
      }
      error = e.what();
    } catch (...) {
      connecting_ = false;
      on_disconnect();
      throw;
    }
    connecting_ = false;
    on_disconnect();
  }
  throw CommLost("cannot reach " + where() + " after " + std::to_string(policy.attempts) +
                 (policy.attempts == 1 ? " attempt: " : " attempts: ") + error);
}

void CmmDriver::enable() {
  require(Lifecycle::connected, "enable");
  on_enable();
  lifecycle_ = Lifecycle::enabled;
}

void CmmDriver::disable() { lower_to(Lifecycle::connected); }

void CmmDriver::disconnect() {
  lower_to(Lifecycle::configured);  // before the link goes: nothing may use it from now on
  on_disconnect();
}

description::MachineDescription CmmDriver::info() {
  require(Lifecycle::connected, "info");
  return read_info();
}

MachineStatus CmmDriver::status() {
  require(Lifecycle::connected, "status");
  MachineStatus s = read_status();
  s.lifecycle = lifecycle_.load();
  s.aborted = s.aborted || aborted_.load();
  const std::lock_guard lock(fault_mutex_);
  if (!s.fault && fault_) {
    s.fault = fault_;
    s.fault_message = fault_message_;
  }
  return s;
}

void CmmDriver::latch(const Fault& fault) {
  const std::lock_guard lock(fault_mutex_);
  fault_ = fault.kind();
  fault_message_ = fault.what();
}

void CmmDriver::clear_latches(bool abort_too) {
  if (abort_too) aborted_ = false;
  const std::lock_guard lock(fault_mutex_);
  fault_.reset();
  fault_message_.clear();
}

template <class F>
auto CmmDriver::motion(const char* what, F&& f) {
  require(Lifecycle::enabled, what);
  try {
    if (aborted_.load()) throw Aborted(std::string(what) + ": abort is latched; reset() first");
    begin_motion();
    auto result = f();
    clear_latches(false);
    return result;
  } catch (const Fault& fault) {
    latch(fault);
    lower_to(Lifecycle::connected);
    throw;
  }
}

void CmmDriver::home() {
  motion("home", [&] {
    do_home();
    return 0;
  });
}

void CmmDriver::move(const Move& m) {
  motion("move", [&] {
    do_move(m);
    return 0;
  });
}

TouchResult CmmDriver::probe(const ProbeMove& p) {
  return motion("probe", [&] { return checked_touch(p, do_probe(p), machine_); });
}

void CmmDriver::stop() { do_stop(); }

void CmmDriver::abort() {
  aborted_ = true;  // at once: an abort that lands just as a motion ends must still refuse the next one
  lower_to(Lifecycle::connected);
  do_abort();
}

void CmmDriver::reset() {
  require(Lifecycle::connected, "reset");
  do_reset();
  clear_latches(true);
}

void CmmDriver::select_tip(const std::string& tip_id) {
  require(Lifecycle::connected, "select_tip");
  do_select_tip(tip_id);
}

void CmmDriver::record_qualification(const std::string& tip_id, const description::TipQualification& q) {
  require(Lifecycle::connected, "record_qualification");
  do_record_qualification(tip_id, q);
}

}  // namespace cmm::hal
