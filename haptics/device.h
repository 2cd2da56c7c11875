// The haptic device interface (SI units) and the clocks the backends run on.
//
//   simulation ──LocalModel──► Servo (1 kHz) ──write(F)──► Device ──read(state)──► Servo
//
// A Device is whatever sits at the hand: a scripted trajectory (batch runs, tests), a simulated
// hand + device mass (closed-loop tests), a UDP bridge to a real device. Positions are metres in
// the device's own frame (origin at the workspace centre), forces newtons; the simulation maps the
// device frame to the scene (x_scene = s R x_device + o) on its side.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <chrono>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace sph::haptics {

/// A device could not be opened or failed while running.
struct DeviceError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// What a device can do. Defaults: the 3D Systems Touch (OpenHaptics HD_NOMINAL_MAX_FORCE,
/// HD_NOMINAL_MAX_CONTINUOUS_FORCE, HD_NOMINAL_MAX_STIFFNESS; CHAI3D's damping and workspace).
struct DeviceSpec {
  std::string name = "touch";
  double max_force = 3.3;             ///< peak force (unit: N)
  double max_continuous_force = 0.88; ///< continuous force (unit: N)
  double max_stiffness = 500.0;       ///< largest renderable stiffness (unit: N/m)
  double max_damping = 4.0;           ///< largest renderable damping (unit: N s/m)
  double workspace_radius = 0.075;    ///< (unit: m)
  int actuated_dof = 3;               ///< force only, no torque
  int buttons = 2;
};

/// One reading of the device.
struct DeviceState {
  double time = 0;                                            ///< clock time of the reading (unit: s)
  Eigen::Vector3d position = Eigen::Vector3d::Zero();         ///< end effector, device frame (unit: m)
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();         ///< as the device reports it (unit: m/s)
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  ///< stylus, device frame
  uint32_t buttons = 0;                                       ///< bit i = button i pressed
};

/// The device interface. read() and write() are called from the servo thread only.
class Device {
 public:
  virtual ~Device() = default;
  /// Opens the device; throws DeviceError with a reason.
  virtual void open() = 0;
  /// Stops forces and releases the device; safe to call twice.
  virtual void close() = 0;
  virtual DeviceSpec spec() const = 0;
  /// The current state (at the backend's clock).
  virtual void read(DeviceState& s) = 0;
  /// The force to render until the next write (unit: N), device frame.
  virtual void write(const Eigen::Vector3d& force) = 0;
};

/// Time source for backends: virtual (batch runs and tests step it) or the steady clock (live).
class Clock {
 public:
  virtual ~Clock() = default;
  virtual double now() const = 0;  ///< (unit: s)
};

/// A clock that moves only when told: deterministic batch runs and tests.
class VirtualClock : public Clock {
 public:
  double now() const override { return t_; }
  void set(double t) { t_ = t; }  ///< (unit: s)
  void advance(double dt) { t_ += dt; }  ///< (unit: s)

 private:
  double t_ = 0;
};

}  // namespace sph::haptics

namespace sph::haptics {

/// Seconds since construction on std::chrono::steady_clock: live runs.
class SteadyClock : public Clock {
 public:
  SteadyClock() : t0_(std::chrono::steady_clock::now()) {}
  double now() const override {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
  }

 private:
  std::chrono::steady_clock::time_point t0_;
};

}  // namespace sph::haptics
