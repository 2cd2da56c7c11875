// The simulation side of the bridge backend (`haptics.device.backend: bridge`, live runs only):
// the servo runs in `sphaptics-bridge` next to the device (../shared/haptics.md, "Split"), and this
// process talks to it over UDP on 127.0.0.1 (haptics/bridge_protocol.h).
//
//   sphaptics-bridge (servo, 1 kHz) ──State (every tick)──► receiver thread ─► latest State, ring
//                                   ◄──LocalModel (per frame)── publish(): anchor, K_d, B_d, F_ff,
//                                                               stamped with the State it came from
//
// Round-trip lag: each LocalModel names the bridge time of the newest State the simulation had
// seen when it built the model. The bridge stamps the model with that time (its own clock), so the
// servo's first-order hold extrapolates the anchor over the whole round trip (network both ways
// plus the frame's computation), not just from the packet's arrival: a body moving at a steady
// speed is rendered where it is now, not where it was one round trip ago. The measured round trip
// (the age of that State when the model is sent, plus the bridge's measurement on arrival) is
// reported in the stats.
//
// Failure: no State within `timeout` of start() or of the previous one is a device failure
// (DeviceError naming the bridge's address; `sphaptics run` exits 3).
#pragma once

#include "haptics/bridge_protocol.h"
#include "haptics/live.h"
#include "haptics/udp.h"

#include <atomic>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace sph::haptics {

struct BridgeSettings {
  uint16_t bridge_port = 47001;  ///< where sphaptics-bridge listens (unit: 1)
  uint16_t listen_port = 47002;  ///< where this process listens for States (unit: 1)
  double timeout = 1.0;          ///< no State for this long = failure (unit: s)
  double max_force = 3.0;        ///< the simulation's force limit, sent with each model (unit: N)
};

class BridgeSession : public LiveSource {
 public:
  BridgeSession(BridgeSettings settings, ServoConfig servo, GrabController grab);
  ~BridgeSession() override;
  void start() override;
  void stop() override;
  void apply(double time, double dt, const std::vector<rigid::RigidBody>& bodies,
             const std::vector<rigid::BodyState>& states, std::vector<BodyWrench>& out) override;
  void publish(const std::vector<rigid::BodyState>& states) override;
  LiveStats stats() const override;
  std::string deviceName() const override;
  const GrabController& grab() const override { return grab_; }
  void check() override;

 protected:
  void onSettings(const LiveSettings& s) override;

 private:
  void receive();
  BridgeSettings settings_;
  GrabController grab_;  // simulation thread only
  std::unique_ptr<UdpSocket> socket_;
  std::thread thread_;
  std::atomic<bool> running_{false};
  std::atomic<bool> failed_{false};
  mutable std::mutex mutex_;  // guards everything below
  bridge::SequenceFilter filter_;
  bridge::StatePacket latest_;
  bool have_state_ = false;
  std::chrono::steady_clock::time_point latest_arrival_;
  std::vector<double> intervals_;  // State arrival intervals (unit: s)
  std::vector<double> ages_;       // age of the newest State at each LocalModel send (unit: s)
  uint64_t received_ = 0, rejected_ = 0;
  std::string failure_;
  Eigen::Vector3d anchor_ = Eigen::Vector3d::Zero();  // last anchor sent (haptics.csv target column)
  uint32_t model_seq_ = 0;  // simulation thread only
};

}  // namespace sph::haptics
