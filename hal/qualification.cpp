// Qualification on the reference sphere: pole touch, ring touches, sphere fit, record.
#include "hal/qualification.hpp"

#include <cmath>
#include <numbers>
#include <stdexcept>

#include "hal/sphere_fit.hpp"
#include "hal/utc_time.hpp"

namespace cmm::hal {

description::TipQualification qualify(Cmm& cmm, const std::string& tip_id, const QualificationOptions& options) {
  if (options.touches < 5) throw std::invalid_argument("qualify: needs at least 5 touches");
  if (!(options.ring_latitude_deg > 0 && options.ring_latitude_deg < 80))
    throw std::invalid_argument("qualify: ring_latitude_deg must be in (0, 80)");
  if (!(options.search_mm > 0)) throw std::invalid_argument("qualify: search_mm must be > 0");

  cmm.select_tip(tip_id);
  const description::MachineDescription info = cmm.info();
  const description::StylusTip* found = info.find_tip(tip_id);
  if (!found) throw std::invalid_argument("qualify: no tip \"" + tip_id + "\" on this machine");
  const description::StylusTip& tip = *found;
  const Vec3 centre = info.reference_sphere.centre;
  const double reach = info.reference_sphere.radius_mm + tip.ball_radius_mm;  // nominal centre-sphere radius
  const double speed = options.speed_mm_s > 0 ? options.speed_mm_s : info.probe_speed_mm_s;
  // Starts on the ring must be reachable by a vertical descent beside the sphere, so the start
  // radius grows until the ring's horizontal distance clears it by a millimetre.
  const double latitude = options.ring_latitude_deg * std::numbers::pi / 180;
  const double start_radius = std::max(reach + options.search_mm, (reach + 1) / std::cos(latitude));
  const double safe_z = centre.z() + start_radius + options.search_mm;

  std::vector<Vec3> outward{Vec3::UnitZ()};
  const int ring = options.touches - 1;
  for (int i = 0; i < ring; ++i) {
    double azimuth = 2 * std::numbers::pi * i / ring;
    outward.emplace_back(std::cos(latitude) * std::cos(azimuth), std::cos(latitude) * std::sin(azimuth),
                         std::sin(latitude));
  }

  const auto move = [&](const Vec3& target) {
    if (options.before_motion) options.before_motion();
    cmm.move({target, 0});
  };
  std::vector<Vec3> centres;
  for (const Vec3& u : outward) {
    Vec3 start = centre + start_radius * u;
    Vec3 above(start.x(), start.y(), safe_z);
    move(Vec3(cmm.status().position.x(), cmm.status().position.y(), safe_z));
    move(above);
    ProbeMove probe;
    probe.start = start;
    probe.direction = -u;
    probe.max_travel_mm = start_radius - reach + options.search_mm;
    probe.speed_mm_s = speed;
    probe.retract_mm = start_radius - reach;
    probe.fail_on_miss = true;
    if (options.before_motion) options.before_motion();
    TouchResult touch = cmm.probe(probe);
    centres.push_back(touch.centre);
  }
  move(Vec3(cmm.status().position.x(), cmm.status().position.y(), safe_z));
  if (options.before_motion) options.before_motion();  // a stop that came too late to stop the last motion

  SphereFit fit = fit_sphere(centres);
  description::TipQualification q;
  q.ball_radius_mm = fit.radius - info.reference_sphere.radius_mm;
  q.offset = tip.offset + (centre - fit.centre);
  q.residual_rms_mm = fit.residual_rms;
  q.touches = static_cast<int>(centres.size());
  q.time_utc = utc_now();
  cmm.record_qualification(tip_id, q);
  return q;
}

void record_on(description::MachineDescription& machine, const std::string& tip_id,
               const description::TipQualification& q, const std::string& owner) {
  for (auto& tip : machine.tips)
    if (tip.id == tip_id) {
      tip.ball_radius_mm = q.ball_radius_mm;
      tip.offset = q.offset;
      tip.qualification = q;
      return;
    }
  throw std::invalid_argument("no tip \"" + tip_id + "\" in " + owner);
}

}  // namespace cmm::hal
