#include "haptics/live.h"

#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <chrono>

namespace sph::haptics {

LiveSession::LiveSession(std::unique_ptr<Device> device, std::shared_ptr<Clock> clock, ServoConfig servo,
                         GrabController grab)
    : device_(std::move(device)), clock_(std::move(clock)), servo_(servo, device_->spec()), grab_(std::move(grab)) {}

LiveSession::~LiveSession() { stop(); }

void LiveSession::start() {
  if (running_.load()) return;
  device_->open();
  device_->read(latest_);
  running_ = true;
  thread_ = std::thread([this] { loop(); });
}

void LiveSession::stop() {
  if (!running_.exchange(false)) return;
  if (thread_.joinable()) thread_.join();
  device_->close();
}

void LiveSession::loop() {
  // Real-time priority when permitted (else the ordinary scheduler; absolute deadlines either way).
  sched_param sp{};
  sp.sched_priority = std::max(1, sched_get_priority_max(SCHED_FIFO) - 1);
  const bool rt = pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp) == 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stats_.realtime = rt;
  }
  const auto T = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(1.0 / servo_.config().rate));
  auto deadline = std::chrono::steady_clock::now();
  auto last = deadline;
  lowpass_ = servo_.config().lowpass;
  while (running_.load()) {
    // A new smoothing cut-off from the window, taken between ticks.
    if (const double hz = lowpass_request_.exchange(-1.0); hz > 0) {
      servo_.setLowpass(hz);
      lowpass_ = hz;
    }
    // One servo period: read, compute, write.
    DeviceState s;
    device_->read(s);
    const ServoOutput o = servo_.tick(s);
    device_->write(o.force);
    // Sleep to the next absolute deadline; a late tick is an overrun.
    deadline += T;
    std::this_thread::sleep_until(deadline);
    const auto now = std::chrono::steady_clock::now();
    const double period = std::chrono::duration<double>(now - last).count();
    last = now;
    std::lock_guard<std::mutex> lock(mutex_);
    latest_ = s;
    stats_.force = o.force;
    ++stats_.ticks;
    if (period > 1.5 / servo_.config().rate) ++stats_.overruns;
    if (periods_.size() < 600000) periods_.push_back(period);  // 10 minutes at 1 kHz
  }
}

void LiveSession::apply(double, double, const std::vector<rigid::RigidBody>&, const std::vector<rigid::BodyState>& states,
                        std::vector<BodyWrench>& out) {
  DeviceState s;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    s = latest_;
  }
  if (recording_) applied_.push_back(s);
  grab_.update(s, states, out);
}

void LiveSession::publish(const std::vector<rigid::BodyState>& states) {
  servo_.publish(grab_.localModel(clock_->now(), states));
}

LiveStats LiveSession::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  LiveStats s = stats_;
  if (!periods_.empty()) {
    std::vector<double> p = periods_;
    std::sort(p.begin(), p.end());
    s.period_p50 = p[p.size() / 2];
    s.period_p99 = p[static_cast<std::size_t>(0.99 * static_cast<double>(p.size() - 1))];
    s.period_max = p.back();
  }
  return s;
}

}  // namespace sph::haptics
