// Device backends without hardware: `scripted` (the device follows a trajectory exactly, forces are
// recorded but move nothing) and `simulated` (a hand + device mass pulled by a spring and damper
// towards a scripted target, and pushed by the rendered force: closed-loop tests).
#pragma once

#include "haptics/device.h"
#include "haptics/trajectory.h"

#include <mutex>

namespace sph::haptics {

/// The device is where the script says; the forces it is sent are kept (lastForce) and move nothing.
class ScriptedDevice : public Device {
 public:
  ScriptedDevice(Trajectory path, const Clock& clock, DeviceSpec spec = {});
  void open() override { open_ = true; }
  void close() override { open_ = false; }
  DeviceSpec spec() const override { return spec_; }
  void read(DeviceState& s) override;
  void write(const Eigen::Vector3d& force) override;
  Eigen::Vector3d lastForce() const;  ///< (unit: N)

 private:
  Trajectory path_;
  const Clock& clock_;
  DeviceSpec spec_;
  bool open_ = false;
  mutable std::mutex mutex_;
  Eigen::Vector3d force_ = Eigen::Vector3d::Zero();
};

/// The hand + device as one mass on the device's frame:
///     m dv/dt = F_rendered + k_h (p_target - x) + b_h (v_target - v) - b v,
/// integrated with semi-implicit Euler in substeps up to the clock's time at each read().
struct SimulatedHand {
  double mass = 0.15;           ///< hand + end effector (unit: kg)
  double damping = 0.05;        ///< device friction to ground (unit: N s/m)
  double hand_stiffness = 300;  ///< grip spring to the target (unit: N/m)
  double hand_damping = 3.0;    ///< grip damper to the target's velocity (unit: N s/m)
  double substep = 1e-4;        ///< integration step (unit: s)
};

class SimulatedDevice : public Device {
 public:
  SimulatedDevice(Trajectory target, const Clock& clock, SimulatedHand hand = {}, DeviceSpec spec = {});
  void open() override;
  void close() override { open_ = false; }
  DeviceSpec spec() const override { return spec_; }
  void read(DeviceState& s) override;
  void write(const Eigen::Vector3d& force) override;
  /// Sets the state (tests: an initial displacement or velocity).
  void reset(const Eigen::Vector3d& x, const Eigen::Vector3d& v);
  const Trajectory& target() const { return target_; }

 private:
  void advanceTo(double t);
  Trajectory target_;
  const Clock& clock_;
  SimulatedHand hand_;
  DeviceSpec spec_;
  bool open_ = false;
  double t_ = 0;
  Eigen::Vector3d x_ = Eigen::Vector3d::Zero(), v_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d force_ = Eigen::Vector3d::Zero();
};

}  // namespace sph::haptics
