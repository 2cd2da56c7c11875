#include "haptics/session.h"

#include <cmath>
#include <cstdio>
#include <ostream>

namespace sph::haptics {

BatchSession::BatchSession(std::unique_ptr<Device> device, std::shared_ptr<VirtualClock> clock, ServoConfig servo,
                           GrabController grab)
    : device_(std::move(device)), clock_(std::move(clock)), servo_(servo, device_->spec()), grab_(std::move(grab)) {
  device_->open();
  device_->read(last_);
}

BatchSession::~BatchSession() { device_->close(); }

void BatchSession::runServoTo(double time) {
  // Ticks at k / rate up to and including `time` (integer tick count: no drift).
  const double rate = servo_.config().rate;
  while (static_cast<double>(next_tick_) / rate <= time + 1e-12) {
    clock_->set(static_cast<double>(next_tick_) / rate);
    device_->read(last_);
    const ServoOutput o = servo_.tick(last_);
    device_->write(o.force);
    rows_.push_back({o.time, last_.position, o.target, o.force, grab_.grabbed(), o.energy, o.flags});
    ++next_tick_;
  }
}

void BatchSession::apply(double time, double dt, const std::vector<rigid::RigidBody>&,
                         const std::vector<rigid::BodyState>& states, std::vector<BodyWrench>& out) {
  runServoTo(time);
  grab_.update(last_, states, out, dt);
}

void BatchSession::publish(double time, const std::vector<rigid::BodyState>& states) {
  runServoTo(time);
  servo_.publish(grab_.localModel(time, states));
}

std::string hapticsCsvHeader() {
  return "# sphaptics haptics, one row per servo tick. SI units: s, m, N, J; positions and forces in the device frame.\n"
         "# x*: device position; a*: servo anchor a(t) (the grasp point mapped to the device, first-order hold);\n"
         "# f*: force sent to the device; body: index of the held body (-1: none);\n"
         "# energy: passivity observer E; flags: bits 0 engaged, 1 ramping, 2 stale (watchdog), 3 peak-limited,\n"
         "# 4 RMS-limited, 5 slew-limited, 6 passivity damping, 7 coupled.\n"
         "time,x,y,z,ax,ay,az,fx,fy,fz,body,energy,flags\n";
}

void writeHapticsRows(std::ostream& out, const std::vector<HapticsRow>& rows) {
  char buf[512];
  for (const HapticsRow& r : rows) {
    std::snprintf(buf, sizeof buf, "%.6f,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%ld,%.9g,%u\n", r.time,
                  r.position.x(), r.position.y(), r.position.z(), r.target.x(), r.target.y(), r.target.z(), r.force.x(),
                  r.force.y(), r.force.z(), r.body, r.energy, r.flags);
    out << buf;
  }
}

}  // namespace sph::haptics
