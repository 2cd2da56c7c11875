#include "haptics/servo.h"

#include <algorithm>
#include <cmath>

namespace sph::haptics {

static constexpr double kTwoPi = 6.283185307179586;
static constexpr double kMaxLag = 0.25;  // largest round trip the hold extrapolates over (unit: s)

// When a model reached the servo (its stamp, unless a bridge set the arrival apart).
static double arrival(const LocalModel& m) { return m.received >= 0 ? m.received : m.stamp; }

Servo::Servo(ServoConfig config, const DeviceSpec& device) : cfg_(config) {
  // The device's spec caps what the simulation or the scene may ask for.
  cfg_.max_stiffness = std::min(cfg_.max_stiffness, device.max_stiffness);
  cfg_.max_damping = std::min(cfg_.max_damping, device.max_damping);
  cfg_.peak_force = std::min(cfg_.peak_force, device.max_force);
  cfg_.continuous_force = std::min(cfg_.continuous_force, device.max_continuous_force);
  T_ = 1.0 / cfg_.rate;
  // Velocity window: enough samples for velocity_window seconds (at least two).
  const std::size_t n = std::max<std::size_t>(2, static_cast<std::size_t>(std::lround(cfg_.velocity_window / T_)) + 1);
  xs_.assign(n, Eigen::Vector3d::Zero());
  ts_.assign(n, 0.0);
  sq_.assign(std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(cfg_.rms_window / T_))), 0.0);
}

void Servo::publish(const LocalModel& m) {
  std::lock_guard<std::mutex> lock(mutex_);
  pending_ = m;
  ++pending_seq_;
}

void Servo::setSmoothing(Smoothing mode, int window) {
  std::lock_guard<std::mutex> lock(mutex_);
  pending_smoothing_ = mode;
  pending_window_ = std::max(1, window);
  smoothing_changed_ = true;
}

ServoOutput Servo::step(Device& device) {
  DeviceState s;
  device.read(s);
  const ServoOutput out = tick(s);
  device.write(out.force);
  return out;
}

ServoOutput Servo::tick(const DeviceState& s) {
  ServoOutput out;
  const double t = s.time;
  out.time = t;
  ++ticks_;

  // Take the newest model from the mailbox; the previous one becomes the hold's start.
  bool fresh = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    // A smoothing mode changed while running (LiveControls): from this tick on.
    if (smoothing_changed_) {
      cfg_.smoothing = pending_smoothing_;
      cfg_.rolling_window = pending_window_;
      smoothing_changed_ = false;
    }
    if (pending_seq_ != seen_seq_) {
      seen_seq_ = pending_seq_;
      m0_ = m1_;
      m1_ = pending_;
      ++models_;
      fresh = true;
      rolling_.push_back(pending_.feed_forward);
      while (static_cast<int>(rolling_.size()) > std::max(1, cfg_.rolling_window)) rolling_.pop_front();
    }
  }

  // Velocity from a finite difference over the window (CHAI3D: 15 ms).
  xs_[head_] = s.position;
  ts_[head_] = t;
  const std::size_t n = xs_.size();
  const std::size_t oldest = filled_ + 1 >= n ? (head_ + 1) % n : 0;
  filled_ = std::min(filled_ + 1, n);
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  if (filled_ > 1 && ts_[head_] > ts_[oldest]) v = (xs_[head_] - xs_[oldest]) / (ts_[head_] - ts_[oldest]);
  head_ = (head_ + 1) % n;

  // Watchdog: no model, or the newest arrived longer ago than the watchdog or its ttl, fades the
  // force out (the link's freshness: a model that describes a state one round trip old is fresh
  // when it has just arrived).
  const bool stale = !m1_ || t - arrival(*m1_) > std::min(cfg_.watchdog, m1_->ttl);
  if (stale) out.flags |= kStale;
  const double dfade = cfg_.fade > 0 ? T_ / cfg_.fade : 1.0;
  fade_ = stale ? std::max(0.0, fade_ - dfade) : std::min(1.0, fade_ + dfade);

  Eigen::Vector3d f = Eigen::Vector3d::Zero();
  // Coupled: a body is held and the coupling renders something (a gain of 0 sends K_d = B_d = 0:
  // no coupling, so no passivity damping either, and nothing is felt).
  const bool coupled = m1_ && m1_->coupled && cfg_.smoothing == Smoothing::Servo && (m1_->stiffness > 0 || m1_->damping > 0);
  if (coupled) out.flags |= kCoupled;
  if (coupled != was_coupled_) {  // grab or release: the observer starts again
    energy_ = 0;
    have_prev_ = false;
    fc_prev_.setZero();
    have_anchor_ = false;  // a new grasp point: no prediction to blend from
    was_coupled_ = coupled;
  }
  if (m1_ && cfg_.smoothing == Smoothing::Servo) {
    // 1. First-order hold. The anchor goes on from the newest model along its velocity for at
    //    most one frame interval (no lag in steady motion: an interpolating hold, one frame behind,
    //    would pull back by K_d v / f, 1 N at 0.25 m/s and 60 Hz); the feed-forward force is
    //    interpolated between the last two models (one frame behind, continuous, no overshoot).
    const LocalModel& b = *m1_;
    const LocalModel& a = m0_ ? *m0_ : *m1_;
    const double d = b.stamp - a.stamp;
    const double u = d > 0 ? std::clamp((t - arrival(b)) / d, 0.0, 1.0) : 1.0;
    // Extrapolated until the model expires (a dropped frame must not stall the anchor; the
    //    watchdog fades the force out after that), plus the lag it arrived with (a bridge's round
    //    trip, at most kMaxLag): the anchor is predicted to now, not to when its state was sent.
    const double lag = std::clamp(arrival(b) - b.stamp, 0.0, kMaxLag);
    const double ahead = std::clamp(t - b.stamp, 0.0, std::min(cfg_.watchdog, b.ttl) + lag);
    // The slope of the hold: the anchor's mean velocity over the last frame, (a1 - a0) / (t1 - t0),
    //    exact for steady motion (the body's velocity at the frame's end may differ from its mean).
    //    Models less than 5 ms apart, or from a bridge (stamps jittered by the network: measured,
    //    the chord's noise times the round trip costs more than the chord gains), give no usable
    //    chord: then the simulation's own anchor velocity.
    const Eigen::Vector3d slope =
        d > 5e-3 && a.coupled == b.coupled && b.received < 0 ? Eigen::Vector3d((b.anchor - a.anchor) / d) : b.anchor_velocity;
    const Eigen::Vector3d predicted = b.anchor + ahead * slope;
    // A new model corrects the old prediction: the jump is blended in over one frame interval, so
    //    the anchor stays continuous (no force step at the frame rate).
    if (fresh) blend_ = have_anchor_ ? Eigen::Vector3d(last_anchor_ + T_ * last_slope_ - predicted) : Eigen::Vector3d::Zero();
    const Eigen::Vector3d anchor = predicted + (1.0 - u) * blend_;
    const Eigen::Vector3d anchor_v = slope;
    last_anchor_ = anchor;
    last_slope_ = slope;
    have_anchor_ = true;
    const Eigen::Vector3d ff = a.feed_forward + u * (b.feed_forward - a.feed_forward);
    out.target = anchor;

    // 2. Feed-forward through a one-pole low-pass (exact discretisation of 1 / (1 + s / wc)).
    const double k = 1.0 - std::exp(-kTwoPi * cfg_.lowpass * T_);
    ff_filtered_ += k * (ff - ff_filtered_);
    f = ff_filtered_;

    if (coupled) {
      // 2. Coupling spring and damper, capped by the device.
      const double K = std::clamp(b.stiffness, 0.0, cfg_.max_stiffness);
      const double B = std::clamp(b.damping, 0.0, cfg_.max_damping);
      Eigen::Vector3d fc = K * (anchor - s.position) + B * (anchor_v - v);

      // 3. Passivity observer: work the held coupling force did on the hand over the last tick,
      //    relative to the anchor's motion; controller: a damper that dissipates the deficit.
      if (have_prev_) {
        const Eigen::Vector3d dx = (s.position - x_prev_) - (anchor - a_prev_);
        energy_ -= fc_prev_.dot(dx);
        const Eigen::Vector3d vrel = dx / T_;
        const double speed2 = vrel.squaredNorm();
        if (cfg_.passivity && energy_ < 0 && speed2 > cfg_.passivity_min_speed * cfg_.passivity_min_speed) {
          out.alpha = std::min(-energy_ / (T_ * speed2), cfg_.max_damping);
          fc -= out.alpha * vrel;
          out.flags |= kPassivity;
        }
      }
      else {
        // First coupled tick: the spring already holds 1/2 K |a - x|^2, which it may give back.
        energy_ = 0.5 * K * (anchor - s.position).squaredNorm();
      }
      have_prev_ = true;
      x_prev_ = s.position;
      a_prev_ = anchor;
      fc_prev_ = fc;
      f += fc;
    }
  } else if (m1_) {
    // The paper's method: the mean force of the last N frames, held between frames.
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const Eigen::Vector3d& g : rolling_) sum += g;
    f = sum / static_cast<double>(rolling_.size());
  }
  out.energy = energy_;

  // 4. Peak limit.
  const double mag = f.norm();
  if (mag > cfg_.peak_force) {
    f *= cfg_.peak_force / mag;
    out.flags |= kPeakLimited;
  }
  // 5. Start-up ramp: engage after the request has stayed small for a few ticks, then rise.
  if (!engaged_) {
    calm_ticks_ = f.norm() < cfg_.engage_force ? calm_ticks_ + 1 : 0;
    if (calm_ticks_ >= cfg_.engage_ticks) {
      engaged_ = true;
      engage_time_ = t;
    }
  }
  double ramp = 0;
  if (engaged_) {
    out.flags |= kEngaged;
    ramp = cfg_.ramp_time > 0 ? std::clamp((t - engage_time_) / cfg_.ramp_time, 0.0, 1.0) : 1.0;
    if (ramp < 1.0) out.flags |= kRamping;
  }
  f *= ramp * fade_;

  // 7. Continuous limit: the 1 s RMS of the force after ramp and fade (this tick included), scaled
  //    down to F_cont above it.
  const double sq = f.squaredNorm();
  sq_sum_ += sq - sq_[sq_head_];
  sq_[sq_head_] = sq;
  sq_head_ = (sq_head_ + 1) % sq_.size();
  if (sq_head_ == 0) {  // once per window: the exact sum again, so rounding cannot drift
    sq_sum_ = 0;
    for (double q : sq_) sq_sum_ += q;
  }
  const double rms = std::sqrt(std::max(0.0, sq_sum_) / static_cast<double>(sq_.size()));
  if (rms > cfg_.continuous_force) {
    f *= cfg_.continuous_force / rms;
    out.flags |= kRmsLimited;
  }

  // 7. Slew limit on the change from the last tick's force.
  const Eigen::Vector3d df = f - f_prev_;
  const double max_step = cfg_.slew * T_;
  if (df.norm() > max_step) {
    f = f_prev_ + df * (max_step / df.norm());
    out.flags |= kSlewLimited;
  }
  f_prev_ = f;
  out.force = f;
  return out;
}

}  // namespace sph::haptics
