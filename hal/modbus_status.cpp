// Decoding the Modbus status block and tip table entries: bounds first, then the map's packing.
#include "hal/modbus_status.hpp"

#include "hal/fault.hpp"
#include "hal/utc_time.hpp"

namespace cmm::hal::modbus {

namespace {

void require_registers(std::span<const std::uint16_t> regs, std::size_t count, const char* what) {
  if (regs.size() < count)
    throw Protocol(std::string(what) + ": " + std::to_string(regs.size()) + " registers, " + std::to_string(count) +
                   " expected");
}

// The register at `address` of a block that starts at `first`.
const std::uint16_t* at(std::span<const std::uint16_t> regs, std::uint16_t first, std::uint16_t address) {
  return regs.data() + (address - first);
}

Vec3 get_vec(const std::uint16_t* regs) {
  return Vec3(get_i32(regs), get_i32(regs + 2), get_i32(regs + 4)) * 1e-6;
}

}  // namespace

MachineStatus decode_status(std::span<const std::uint16_t> r, const std::vector<std::string>& tip_ids) {
  require_registers(r, kStatusCount, "status block");
  MachineStatus s;
  const std::uint16_t flags = *at(r, kStatusFirst, address("flags"));
  s.homed = flags & homed;
  s.moving = flags & moving;
  s.estop = flags & estop;
  s.aborted = flags & aborted;
  if (const std::uint16_t code = *at(r, kStatusFirst, address("fault_code"))) s.fault = fault_from_code(code);
  s.position = get_vec(at(r, kStatusFirst, address("position_x")));
  s.t_s = get_u32(at(r, kStatusFirst, address("clock"))) * 1e-3;
  const std::size_t tip = *at(r, kStatusFirst, address("active_tip"));
  s.tip_id = tip < tip_ids.size() ? tip_ids[tip] : "";
  return s;
}

TouchResult decode_touch(std::span<const std::uint16_t> r, const std::vector<std::string>& tip_ids) {
  const MachineStatus status = decode_status(r, tip_ids);
  TouchResult t;
  t.contact = *at(r, kStatusFirst, address("touch_contact")) != 0;
  t.centre = t.contact ? get_vec(at(r, kStatusFirst, address("touch_x"))) : status.position;
  t.travel_mm = get_u32(at(r, kStatusFirst, address("touch_travel"))) * 1e-6;
  t.t_s = get_u32(at(r, kStatusFirst, address("touch_clock"))) * 1e-3;
  t.tip_id = status.tip_id;
  return t;
}

description::StylusTip decode_tip(std::span<const std::uint16_t> entry) {
  require_registers(entry, kTipEntryCount, "tip table entry");
  const std::uint16_t first = address("tip_id");
  description::StylusTip tip;
  tip.id = get_ascii(at(entry, first, address("tip_id")), modbus::entry("tip_id").count);
  tip.ball_radius_mm = get_u32(at(entry, first, address("tip_radius"))) * 1e-6;
  tip.offset = get_vec(at(entry, first, address("tip_offset_x")));
  if (const std::uint32_t when = get_u32(at(entry, first, address("tip_qualified")))) {
    description::TipQualification q;
    q.ball_radius_mm = tip.ball_radius_mm;
    q.offset = tip.offset;
    q.residual_rms_mm = get_u32(at(entry, first, address("tip_residual"))) * 1e-6;
    q.touches = *at(entry, first, address("tip_touches"));
    q.time_utc = utc_text(when);
    tip.qualification = q;
  }
  return tip;
}

}  // namespace cmm::hal::modbus
