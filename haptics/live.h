// A live haptic session (`sphaptics run --interactive`): the servo runs on its own thread at its
// rate with absolute-deadline sleeps (real-time priority when the system allows it) against a
// device on the steady clock; the simulation thread calls apply() once per step (the latest device
// reading drives the grab) and publish() once per frame.
//
//   servo thread (1 kHz)                           simulation thread (frames)
//   read ─► tick ─► write ─► push TickRecord ──ring──► takeTicks(): haptics.csv, --record
//                     ▲                                 applyControls(t): gain, mapping, smoothing
//                     └──── LocalModel mailbox ◄──────── publish()
//   LiveControls (any thread: stdin commands, the viewer's panel) ──► applied at a frame boundary
//
// Two live sources share this interface: LiveSession (the servo in this process, local backends)
// and BridgeSession (haptics/bridge_client.h: the servo runs in `sphaptics-bridge`, over UDP).
#pragma once

#include "haptics/device.h"
#include "haptics/grab.h"
#include "haptics/servo.h"
#include "haptics/session.h"

#include <atomic>
#include <memory>
#include <mutex>
#include <string>
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
  uint64_t dropped = 0;         ///< tick records lost because the ring was full (haptics.csv, --record)
  // Bridge backend only (0 otherwise).
  double servo_rate = 0;        ///< the bridge's servo rate, as it reports it (unit: Hz)
  double round_trip = 0;        ///< median age of the bridge's State a LocalModel was built from, at its send (unit: s)
  uint64_t rejected = 0;        ///< datagrams rejected (malformed or stale)
};

/// The settings a user may change while running ("haptic strength", workspace mapping, smoothing,
/// pause). Applied by the simulation thread at a frame boundary, so a scripted change (`at T ...`)
/// lands on the same frame every run.
struct LiveSettings {
  double gain = 1.0;                                 ///< felt force / force on the body (unit: 1); 0 = no force
  double scale = 1.0;                                ///< x_scene = scale R x_device + offset (unit: 1)
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  ///< (unit: m)
  Smoothing smoothing = Smoothing::Servo;
  int rolling_window = 20;                           ///< (unit: frames)
  bool paused = false;                               ///< the simulation holds; the servo keeps rendering the last model
  bool operator==(const LiveSettings& o) const {
    return gain == o.gain && scale == o.scale && offset == o.offset && smoothing == o.smoothing &&
           rolling_window == o.rolling_window && paused == o.paused;
  }
  bool operator!=(const LiveSettings& o) const { return !(*this == o); }
};

/// Thread-safe settings box: the stdin command reader and the viewer's panel write, the simulation
/// thread takes the settings at frame boundaries. All members may be called from any thread.
class LiveControls {
 public:
  explicit LiveControls(LiveSettings initial = {}) : pending_(initial) {}
  LiveSettings settings() const;          ///< the newest settings (not necessarily applied yet)
  void set(const LiveSettings& s);        ///< replaces all settings (applied at the next frame boundary)
  void setGain(double gain);              ///< (unit: 1), >= 0
  void setScale(double scale);            ///< (unit: 1), > 0
  void setOffset(const Eigen::Vector3d& offset);  ///< (unit: m)
  void setSmoothing(Smoothing mode, int window);  ///< window (unit: frames) >= 1
  void setPaused(bool paused);
  void requestQuit() { quit_ = true; }
  bool quitRequested() const { return quit_.load(); }
  /// One text command: `gain G`, `scale S`, `offset X Y Z`, `smoothing servo`, `smoothing
  /// rolling_average N`, `pause`, `resume`, `quit`, or any of them after `at T` (applied at the
  /// first frame boundary at simulation time >= T s). Returns "" when accepted, else why not.
  std::string command(const std::string& line);
  /// Simulation thread, at a frame boundary at simulation time `time` (unit: s): the scheduled
  /// commands that are due are applied, then `out` = the settings; true when they changed since
  /// the last take().
  bool take(double time, LiveSettings& out);

 private:
  mutable std::mutex mutex_;
  LiveSettings pending_;
  uint64_t version_ = 1, taken_ = 0;
  std::vector<std::pair<double, std::string>> scheduled_;  // (time, command), in arrival order
  std::atomic<bool> quit_{false};
};

/// Applies gain and mapping to a grab controller (live sessions and replays share this).
void applySettings(GrabController& grab, const LiveSettings& s);

/// One servo tick as the simulation thread receives it: the device reading and the haptics.csv row.
struct TickRecord {
  uint64_t tick = 0;   ///< servo tick index (bridge: the State's sequence number)
  DeviceState reading;
  HapticsRow row;
  bool servo = true;   ///< false: the reading taken when the device opened (no servo tick, not in haptics.csv)
};

/// Single-producer single-consumer ring (the servo pushes, the simulation thread drains): the
/// servo never waits; when the ring is full a record is dropped and counted.
class TickRing {
 public:
  explicit TickRing(std::size_t capacity) : buf_(capacity + 1) {}
  bool push(const TickRecord& r);          ///< producer only; false (and counted) when full
  void drain(std::vector<TickRecord>& out);///< consumer only: appends every record waiting
  uint64_t dropped() const { return dropped_.load(); }

 private:
  std::vector<TickRecord> buf_;
  std::atomic<std::size_t> head_{0}, tail_{0};  // head: next write (producer); tail: next read (consumer)
  std::atomic<uint64_t> dropped_{0};
};

/// What `run --interactive` drives: a servo thread (here or in a bridge) and the grab.
class LiveSource : public ExternalForceSource {
 public:
  explicit LiveSource(LiveSettings initial) : controls_(initial) {}
  virtual void start() = 0;  ///< opens the device, starts the threads; throws DeviceError
  virtual void stop() = 0;   ///< joins the threads, closes the device; safe to call twice
  /// After a frame: the LocalModel of the current states.
  virtual void publish(const std::vector<rigid::BodyState>& states) = 0;
  virtual LiveStats stats() const = 0;
  /// Names the device in messages ("simulated", "bridge 127.0.0.1:47001").
  virtual std::string deviceName() const = 0;
  /// Simulation thread only: the grab (the live window draws its cursor, grasp point and held body).
  virtual const GrabController& grab() const = 0;
  /// Simulation thread: throws DeviceError when the device stopped answering.
  virtual void check() {}
  /// Simulation thread, at a frame boundary at simulation time `time` (unit: s): applies changed
  /// settings; true when they changed (the new ones in `applied`).
  bool applyControls(double time, LiveSettings& applied);
  LiveControls& controls() { return controls_; }
  /// Simulation thread: every tick record since the last call (haptics.csv, --record).
  std::vector<TickRecord> takeTicks();
  /// --record: keep the tick index of the reading each apply() used and the hash of the bodies'
  /// state that step started from; takeStepTicks() and takeStepHashes() hand them over.
  void record(bool on) { recording_ = on; }
  std::vector<uint64_t> takeStepTicks() { return std::exchange(step_ticks_, {}); }
  std::vector<uint64_t> takeStepHashes() { return std::exchange(step_hashes_, {}); }

 protected:
  virtual void onSettings(const LiveSettings& s) = 0;
  TickRing ring_{32768};                  // 32 s at 1 kHz between two frames before anything is dropped
  LiveControls controls_;
  bool recording_ = false;                // simulation thread only
  std::vector<uint64_t> step_ticks_;      // simulation thread only
  std::vector<uint64_t> step_hashes_;     // simulation thread only
  /// apply(): with --record, note the tick this step used and the bodies' state it started from.
  void noteStep(uint64_t tick, const std::vector<rigid::BodyState>& states) {
    if (!recording_) return;
    step_ticks_.push_back(tick);
    step_hashes_.push_back(rigid::hashStates(states));
  }
  std::atomic<long> held_body_{-1};       // written by the simulation thread, read by the servo thread
};

/// The servo in this process against a local device (scripted, simulated; OpenHaptics).
class LiveSession : public LiveSource {
 public:
  LiveSession(std::unique_ptr<Device> device, std::shared_ptr<Clock> clock, ServoConfig servo, GrabController grab);
  ~LiveSession() override;
  void start() override;
  void stop() override;
  void apply(double time, double dt, const std::vector<rigid::RigidBody>& bodies,
             const std::vector<rigid::BodyState>& states, std::vector<BodyWrench>& out) override;
  void publish(const std::vector<rigid::BodyState>& states) override;
  LiveStats stats() const override;
  std::string deviceName() const override { return device_->spec().name; }
  /// Simulation thread only: the grab (cursor, grasp point, held body for the live window).
  const GrabController& grab() const override { return grab_; }
  bool running() const { return running_.load(); }

 protected:
  void onSettings(const LiveSettings& s) override;

 private:
  void loop();
  std::unique_ptr<Device> device_;
  std::shared_ptr<Clock> clock_;
  Servo servo_;
  GrabController grab_;  // simulation thread only
  std::thread thread_;
  std::atomic<bool> running_{false};
  mutable std::mutex mutex_;  // guards latest_, latest_tick_, stats_ / periods_
  DeviceState latest_;
  uint64_t latest_tick_ = 0;
  LiveStats stats_;
  std::vector<double> periods_;
};

/// The initial live settings of a grab controller and servo configuration.
LiveSettings initialSettings(const GrabController& grab, const ServoConfig& servo);

/// p50 / p99 / max of a list of periods (unit: s), into `s`.
void periodStats(std::vector<double> periods, LiveStats& s);

}  // namespace sph::haptics
