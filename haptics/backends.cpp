#include "haptics/backends.h"

#include <cmath>

namespace sph::haptics {

ScriptedDevice::ScriptedDevice(Trajectory path, const Clock& clock, DeviceSpec spec)
    : path_(std::move(path)), clock_(clock), spec_(std::move(spec)) {
  spec_.name = "scripted";
}

void ScriptedDevice::read(DeviceState& s) {
  // Position and velocity straight from the path; buttons from its events.
  const double t = clock_.now();
  const PathPoint p = path_.at(t);
  s.time = t;
  s.position = p.position;
  s.velocity = p.velocity;
  s.orientation = Eigen::Quaterniond::Identity();
  s.buttons = path_.buttons(t);
}

void ScriptedDevice::write(const Eigen::Vector3d& force) {
  std::lock_guard<std::mutex> lock(mutex_);
  force_ = force;
}

Eigen::Vector3d ScriptedDevice::lastForce() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return force_;
}

SimulatedDevice::SimulatedDevice(Trajectory target, const Clock& clock, SimulatedHand hand, DeviceSpec spec)
    : target_(std::move(target)), clock_(clock), hand_(hand), spec_(std::move(spec)) {
  spec_.name = "simulated";
  t_ = clock_.now();
  x_ = target_.at(t_).position;
  v_ = target_.at(t_).velocity;
}

void SimulatedDevice::open() {
  if (!(hand_.mass > 0) || !(hand_.substep > 0)) throw DeviceError("simulated device: mass and substep must be > 0");
  open_ = true;
}

void SimulatedDevice::reset(const Eigen::Vector3d& x, const Eigen::Vector3d& v) {
  t_ = clock_.now();
  x_ = x;
  v_ = v;
}

void SimulatedDevice::advanceTo(double t) {
  // Fixed substeps (the last one shortened) so that the plant is close to continuous next to the
  // 1 ms servo: the sampled-data effects under test are the servo's, not this integrator's.
  while (t - t_ > 1e-12) {
    const double h = std::min(hand_.substep, t - t_);
    const PathPoint p = target_.at(t_);
    const Eigen::Vector3d f = force_ + hand_.hand_stiffness * (p.position - x_) +
                              hand_.hand_damping * (p.velocity - v_) - hand_.damping * v_;
    v_ += h * f / hand_.mass;
    x_ += h * v_;
    t_ += h;
  }
}

void SimulatedDevice::read(DeviceState& s) {
  const double t = clock_.now();
  advanceTo(t);
  s.time = t;
  s.position = x_;
  s.velocity = v_;
  s.orientation = Eigen::Quaterniond::Identity();
  s.buttons = target_.buttons(t);
}

void SimulatedDevice::write(const Eigen::Vector3d& force) {
  // The force acts from now on: integrate up to now with the previous one first.
  advanceTo(clock_.now());
  force_ = force;
}

}  // namespace sph::haptics
