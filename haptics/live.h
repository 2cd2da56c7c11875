// A live haptic session (`sphaptics run --interactive`): the servo runs on its own thread at its
// rate with absolute-deadline sleeps (real-time priority when the system allows it) against a
// device on the steady clock; the simulation thread calls apply() once per step (the latest device
// reading drives the grab) and publish() once per frame. Shared between the two threads: the
// latest device reading and the statistics (one mutex), and the servo's LocalModel mailbox.
#pragma once

#include "haptics/device.h"
#include "haptics/grab.h"
#include "haptics/servo.h"

#include <atomic>
#include <memory>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

namespace sph::haptics {

/// What the servo thread measured.
struct LiveStats {
  uint64_t ticks = 0;
  uint64_t overruns = 0;        ///< periods longer than 1.5 T
  double period_p50 = 0;        ///< (unit: s)
  double period_p99 = 0;        ///< (unit: s)
  double period_max = 0;        ///< (unit: s)
  bool realtime = false;        ///< the thread got SCHED_FIFO
  Eigen::Vector3d force = Eigen::Vector3d::Zero();  ///< last force sent (unit: N)
};

class LiveSession : public ExternalForceSource {
 public:
  LiveSession(std::unique_ptr<Device> device, std::shared_ptr<Clock> clock, ServoConfig servo, GrabController grab);
  ~LiveSession() override;
  void start();  ///< opens the device and starts the servo thread
  void stop();   ///< stops the thread (joins) and closes the device; safe to call twice
  void apply(double time, double dt, const std::vector<rigid::RigidBody>& bodies,
             const std::vector<rigid::BodyState>& states, std::vector<BodyWrench>& out) override;
  /// After a frame: the LocalModel of the current states, stamped with the clock's time.
  void publish(const std::vector<rigid::BodyState>& states);
  LiveStats stats() const;
  /// Simulation thread only (the grab is the simulation thread's): the grab, and a new force gain.
  const GrabController& grab() const { return grab_; }
  void setGain(double gain) { grab_.setGain(gain); }
  /// Any thread: a new feed-forward cut-off (unit: Hz), applied by the servo thread at its next tick.
  void setLowpass(double hz) { lowpass_request_.store(hz); }
  double lowpass() const { return lowpass_.load(); }  ///< in use (unit: Hz)
  bool running() const { return running_.load(); }
  /// Keep the reading each apply() used (for --record); takeApplied() hands them over.
  void record(bool on) { recording_ = on; }
  std::vector<DeviceState> takeApplied() { return std::exchange(applied_, {}); }

 private:
  void loop();
  std::unique_ptr<Device> device_;
  std::shared_ptr<Clock> clock_;
  Servo servo_;
  GrabController grab_;  // simulation thread only
  std::thread thread_;
  std::atomic<bool> running_{false};
  std::atomic<double> lowpass_request_{-1.0};  // < 0: no request
  std::atomic<double> lowpass_{0.0};
  mutable std::mutex mutex_;  // guards latest_ and stats_ / periods_
  DeviceState latest_;
  LiveStats stats_;
  std::vector<double> periods_;
  bool recording_ = false;              // simulation thread only
  std::vector<DeviceState> applied_;    // simulation thread only
};

}  // namespace sph::haptics
