// A haptic session in virtual time (batch runs of `sphaptics run`, tests): the simulation calls
// apply() once per step (core/external_force.h); the servo first runs its 1 kHz ticks up to the
// step's start on a VirtualClock, then the grab controller couples the held body to the device.
// After each frame the runner publishes a LocalModel. No thread, no wall clock: deterministic.
//
//   frame k:  step ─► apply(t): servo ticks (t_prev, t] ─► grab.update ─► wrench ... publish(t_k)
#pragma once

#include "haptics/device.h"
#include "haptics/grab.h"
#include "haptics/servo.h"

#include <memory>
#include <utility>
#include <string>
#include <vector>

namespace sph::haptics {

/// One servo tick, as haptics.csv writes it.
struct HapticsRow {
  double time = 0;                                     ///< (unit: s)
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< device (unit: m)
  Eigen::Vector3d target = Eigen::Vector3d::Zero();    ///< servo anchor a(t), device frame (unit: m)
  Eigen::Vector3d force = Eigen::Vector3d::Zero();     ///< sent to the device (unit: N)
  long body = -1;                                      ///< held body (index into Model::bodies), -1 none
  double energy = 0;                                   ///< passivity observer (unit: J)
  uint32_t flags = 0;                                  ///< ServoFlag bits
};

class BatchSession : public ExternalForceSource {
 public:
  /// `device` reads `clock` (a VirtualClock this session owns and moves).
  BatchSession(std::unique_ptr<Device> device, std::shared_ptr<VirtualClock> clock, ServoConfig servo,
               GrabController grab);
  ~BatchSession() override;
  void apply(double time, double dt, const std::vector<rigid::RigidBody>& bodies,
             const std::vector<rigid::BodyState>& states, std::vector<BodyWrench>& out) override;
  /// After a frame: the LocalModel of the current states, stamped `time` (unit: s).
  void publish(double time, const std::vector<rigid::BodyState>& states);
  /// Ticks recorded since the last call.
  std::vector<HapticsRow> takeRows() { return std::exchange(rows_, {}); }
  GrabController& grab() { return grab_; }
  const Servo& servo() const { return servo_; }

 private:
  void runServoTo(double time);
  std::unique_ptr<Device> device_;
  std::shared_ptr<VirtualClock> clock_;
  Servo servo_;
  GrabController grab_;
  DeviceState last_;
  long next_tick_ = 0;
  std::vector<HapticsRow> rows_;
};

/// haptics.csv: `#` header lines (as bodies.csv), then one row per servo tick.
std::string hapticsCsvHeader();
/// Appends rows in the same format.
void writeHapticsRows(std::ostream& out, const std::vector<HapticsRow>& rows);

}  // namespace sph::haptics
