// The servo: the 1 kHz loop between a slow simulation (30-120 Hz) and the device.
//
//   simulation ──publish(LocalModel)──► Servo::tick(DeviceState) every T = 1 ms ──► force
//
// Each tick (../shared/haptics.md, "Servo law"):
//  1. first-order hold: the anchor a goes on from the newest LocalModel along the slope of the
//     last two, (a1 - a0) / (t1 - t0), until the model expires, so steady motion has no lag
//     (an interpolating hold, one frame behind, would pull back by K_d v / f: 1 N at 0.25 m/s and
//     60 Hz); a new model's correction of the prediction is blended in over one frame (the anchor
//     stays continuous: no force steps at the frame rate); the feed-forward force is
//     interpolated between the last two LocalModels over one frame interval (one frame of delay,
//     no steps, no overshoot);
//  2. coupling: F_c = K_d (a - x) + B_d (da/dt - v), v from a finite difference over a 15 ms window
//     (CHAI3D); plus the feed-forward force through a one-pole 25 Hz low-pass;
//  3. passivity observer and controller (Hannaford & Ryu 2002, IEEE T-RA 18(1), eqs. 7-9): the
//     energy the coupling took in, E_n = E_n-1 - F_c,n-1 . (dx_n - da_n) (the force held over the
//     last tick times the relative displacement: exact for a zero-order hold); when E < 0 the
//     coupling has generated energy and a damper alpha = -E / (T |v|^2) (capped at the device's
//     max damping, skipped below 1 mm/s) is added: F_c -= alpha v. The anchor's own motion is
//     excluded (that work is the simulation's), and so is the slow feed-forward load;
//  4. peak limit |F| <= F_peak;
//  5. start-up ramp: the force engages only after |F| < 0.2 N for 3 ticks, then rises over 2 s;
//  6. watchdog: a LocalModel older than 100 ms (or its ttl) fades the force to 0 over 200 ms;
//  7. continuous limit: when the 1 s RMS of the force (after ramp and fade) exceeds F_cont,
//     the force is scaled by F_cont / RMS (a sustained load settles at F_cont exactly, smoothly);
//     slew <= 0.05 N/ms.
// Smoothing::RollingAverage is the paper's method instead of 1-3: the force is the mean of the
// feed-forward force of the last N LocalModels (N frames), held between frames; it lags by
// (N - 1) / (2 f) at frame rate f.
//
// Why a stiffness limit: a sampled virtual spring K is passive only when the device's own damping b
// exceeds K T / 2 (Colgate & Schenkel 1997, J. Robotic Systems 14(1)); at 1 kHz the Touch's
// 250-400 N/m is fine, at 60 Hz it would need 17x less.
#pragma once

#include "haptics/device.h"

#include <array>
#include <cstdint>
#include <deque>
#include <mutex>
#include <optional>
#include <vector>

namespace sph::haptics {

/// What the simulation tells the servo once per frame, in the device frame.
struct LocalModel {
  double stamp = 0;                                         ///< servo-clock time the state it describes was current (unit: s)
  double received = -1;                                     ///< servo-clock time it reached the servo; < 0: at `stamp` (a bridge sets it: stamp = the State's time, one round trip earlier) (unit: s)
  Eigen::Vector3d anchor = Eigen::Vector3d::Zero();         ///< grasp point mapped to the device (unit: m)
  Eigen::Vector3d anchor_velocity = Eigen::Vector3d::Zero();///< (unit: m/s)
  Eigen::Vector3d feed_forward = Eigen::Vector3d::Zero();   ///< slowly varying load to render (unit: N)
  double stiffness = 250.0;                                 ///< K_d (unit: N/m)
  double damping = 1.5;                                     ///< B_d (unit: N s/m)
  double ttl = 0.1;                                         ///< valid for (unit: s)
  bool coupled = true;                                      ///< a body is held (false: only feed-forward)
};

enum class Smoothing { Servo, RollingAverage };

/// Servo settings; defaults for the Touch (../shared/haptics.md, "Defaults for the Touch").
struct ServoConfig {
  double rate = 1000.0;               ///< servo ticks per second (unit: Hz)
  double max_stiffness = 400.0;       ///< cap on K_d (unit: N/m)
  double max_damping = 4.0;           ///< cap on B_d and on the passivity damper (unit: N s/m)
  double peak_force = 3.0;            ///< (unit: N)
  double continuous_force = 0.85;     ///< limit on the 1 s RMS (unit: N)
  double rms_window = 1.0;            ///< (unit: s)
  double slew = 50.0;                 ///< largest change of force per second (unit: N/s)
  double lowpass = 25.0;              ///< feed-forward one-pole cut-off (unit: Hz)
  double velocity_window = 0.015;     ///< finite-difference window for v (unit: s)
  bool passivity = true;              ///< passivity observer + controller on
  double passivity_min_speed = 1e-3;  ///< no passivity damping below (unit: m/s)
  double ramp_time = 2.0;             ///< start-up ramp (unit: s)
  double engage_force = 0.2;          ///< the ramp starts after |F| stays below this (unit: N)
  int engage_ticks = 3;               ///< ... for this many ticks
  double watchdog = 0.1;              ///< oldest usable LocalModel (unit: s)
  double fade = 0.2;                  ///< fade to zero after the watchdog fires (unit: s)
  Smoothing smoothing = Smoothing::Servo;
  int rolling_window = 20;            ///< rolling-average length (unit: frames)
};

/// Flags of one tick (haptics.csv `flags`).
enum ServoFlag : uint32_t {
  kEngaged = 1u << 0,       ///< the start-up ramp has begun
  kRamping = 1u << 1,       ///< still below full scale
  kStale = 1u << 2,         ///< watchdog: no fresh LocalModel
  kPeakLimited = 1u << 3,
  kRmsLimited = 1u << 4,
  kSlewLimited = 1u << 5,
  kPassivity = 1u << 6,     ///< the passivity controller added damping
  kCoupled = 1u << 7,       ///< a body is held
};

/// One tick's result.
struct ServoOutput {
  double time = 0;                                   ///< (unit: s)
  Eigen::Vector3d force = Eigen::Vector3d::Zero();   ///< sent to the device (unit: N)
  Eigen::Vector3d target = Eigen::Vector3d::Zero();  ///< interpolated anchor a(t) (unit: m)
  double energy = 0;                                 ///< passivity observer E (unit: J)
  double alpha = 0;                                  ///< passivity damping this tick (unit: N s/m)
  uint32_t flags = 0;
};

class Servo {
 public:
  /// The settings are capped by the device's spec (stiffness, damping, forces).
  Servo(ServoConfig config, const DeviceSpec& device);

  /// From the simulation thread: a new LocalModel (its stamp set by the caller). Thread-safe.
  void publish(const LocalModel& m);
  /// From any thread: switch the smoothing mode (and rolling-average window, unit: frames); the
  /// servo takes it at its next tick.
  void setSmoothing(Smoothing mode, int window);
  /// From the servo thread: one tick at s.time with the device reading s.
  ServoOutput tick(const DeviceState& s);
  /// Reads the device, ticks, writes the force: one servo period.
  ServoOutput step(Device& device);

  const ServoConfig& config() const { return cfg_; }
  uint64_t ticks() const { return ticks_; }
  uint64_t modelsReceived() const { return models_; }

 private:
  ServoConfig cfg_;
  double T_;  // servo period (unit: s)
  // Mailbox: the newest published model (sequence number bumps on publish).
  std::mutex mutex_;
  LocalModel pending_;
  uint64_t pending_seq_ = 0, seen_seq_ = 0;
  Smoothing pending_smoothing_ = Smoothing::Servo;
  int pending_window_ = 20;
  bool smoothing_changed_ = false;
  // First-order hold: the previous and current models.
  std::optional<LocalModel> m0_, m1_;
  std::deque<Eigen::Vector3d> rolling_;  // last N feed-forward forces (rolling average)
  // State carried between ticks.
  uint64_t ticks_ = 0, models_ = 0;
  std::vector<Eigen::Vector3d> xs_;   // positions ring for the velocity window
  std::vector<double> ts_;
  std::size_t head_ = 0, filled_ = 0;
  Eigen::Vector3d x_prev_ = Eigen::Vector3d::Zero(), a_prev_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d fc_prev_ = Eigen::Vector3d::Zero();   // coupling force of the last tick
  Eigen::Vector3d ff_filtered_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d last_anchor_ = Eigen::Vector3d::Zero();  // anchor of the last tick
  Eigen::Vector3d blend_ = Eigen::Vector3d::Zero();        // prediction error blended out over a frame
  Eigen::Vector3d last_slope_ = Eigen::Vector3d::Zero();   // hold slope of the last tick (unit: m/s)
  bool have_anchor_ = false;
  Eigen::Vector3d f_prev_ = Eigen::Vector3d::Zero();    // force sent last tick
  double energy_ = 0;
  bool have_prev_ = false;
  bool was_coupled_ = false;
  // 1 s RMS of the requested force: ring of squares and their running sum.
  std::vector<double> sq_;
  std::size_t sq_head_ = 0;
  double sq_sum_ = 0;
  // Start-up ramp and watchdog fade.
  int calm_ticks_ = 0;
  bool engaged_ = false;
  double engage_time_ = 0;
  double fade_ = 1.0;
};

}  // namespace sph::haptics
