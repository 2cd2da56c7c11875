#include "haptics/live.h"

#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

namespace sph::haptics {

// --- LiveControls ---------------------------------------------------------------------------

LiveSettings LiveControls::settings() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return pending_;
}

void LiveControls::set(const LiveSettings& s) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (s != pending_) ++version_;
  pending_ = s;
}

void LiveControls::setGain(double gain) {
  LiveSettings s = settings();
  s.gain = std::max(0.0, gain);
  set(s);
}

void LiveControls::setScale(double scale) {
  if (!(scale > 0) || !std::isfinite(scale)) return;
  LiveSettings s = settings();
  s.scale = scale;
  set(s);
}

void LiveControls::setOffset(const Eigen::Vector3d& offset) {
  if (!offset.allFinite()) return;
  LiveSettings s = settings();
  s.offset = offset;
  set(s);
}

void LiveControls::setSmoothing(Smoothing mode, int window) {
  LiveSettings s = settings();
  s.smoothing = mode;
  s.rolling_window = std::clamp(window, 1, 1000);
  set(s);
}

void LiveControls::setPaused(bool paused) {
  LiveSettings s = settings();
  s.paused = paused;
  set(s);
}

namespace {

// Parses one command (without `at T`) into a change of `s`; "" when good, else why not.
std::string parseCommand(const std::string& line, LiveSettings& s, bool& quit) {
  std::istringstream in(line);
  std::string word;
  in >> word;
  auto number = [&](double& v, const char* what) -> std::string {
    if (!(in >> v) || !std::isfinite(v)) return std::string("'") + word + "' needs " + what;
    return "";
  };
  auto end = [&]() -> std::string {
    std::string rest;
    if (in >> rest) return "'" + word + "': unexpected '" + rest + "'";
    return "";
  };
  std::string err;
  if (word == "gain") {
    double g = 0;
    if (!(err = number(g, "a number >= 0 (unit: 1)")).empty()) return err;
    if (g < 0) return "'gain' must be >= 0, got " + std::to_string(g);
    s.gain = g;
  } else if (word == "scale") {
    double v = 0;
    if (!(err = number(v, "a number > 0 (unit: 1)")).empty()) return err;
    if (!(v > 0)) return "'scale' must be > 0, got " + std::to_string(v);
    s.scale = v;
  } else if (word == "offset") {
    Eigen::Vector3d o;
    for (int a = 0; a < 3; ++a)
      if (!(err = number(o[a], "three numbers x y z (unit: m)")).empty()) return err;
    s.offset = o;
  } else if (word == "smoothing") {
    std::string mode;
    in >> mode;
    if (mode == "servo") {
      s.smoothing = Smoothing::Servo;
    } else if (mode == "rolling_average") {
      int n = s.rolling_window;
      std::string w;
      if (in >> w) {
        try {
          std::size_t used = 0;
          n = std::stoi(w, &used);
          if (used != w.size()) throw std::invalid_argument(w);
        } catch (const std::exception&) {
          return "'smoothing rolling_average' needs a window in frames (1-1000), got '" + w + "'";
        }
      }
      if (n < 1 || n > 1000) return "'smoothing rolling_average' window must be 1-1000 frames, got " + std::to_string(n);
      s.smoothing = Smoothing::RollingAverage;
      s.rolling_window = n;
    } else {
      return "'smoothing' needs 'servo' or 'rolling_average N', got '" + mode + "'";
    }
  } else if (word == "pause") {
    s.paused = true;
  } else if (word == "resume") {
    s.paused = false;
  } else if (word == "quit") {
    quit = true;
  } else {
    return "unknown command '" + word + "' (gain G, scale S, offset X Y Z, smoothing servo | rolling_average N, "
           "pause, resume, quit; any of them after 'at T')";
  }
  return end();
}

}  // namespace

std::string LiveControls::command(const std::string& line) {
  std::istringstream in(line);
  std::string word;
  if (!(in >> word) || word[0] == '#') return "";  // blank lines and comments
  // `at T command`: checked now, applied at the first frame boundary at simulation time >= T.
  if (word == "at") {
    double t = 0;
    if (!(in >> t) || !std::isfinite(t) || t < 0) return "'at' needs a time >= 0 (unit: s) and a command";
    std::string rest;
    std::getline(in >> std::ws, rest);
    LiveSettings probe = settings();
    bool quit = false;
    if (const std::string err = parseCommand(rest, probe, quit); !err.empty()) return err;
    std::lock_guard<std::mutex> lock(mutex_);
    scheduled_.emplace_back(t, rest);
    return "";
  }
  std::lock_guard<std::mutex> lock(mutex_);
  LiveSettings s = pending_;
  bool quit = false;
  if (const std::string err = parseCommand(line, s, quit); !err.empty()) return err;
  if (quit) quit_ = true;
  if (s != pending_) ++version_;
  pending_ = s;
  return "";
}

bool LiveControls::take(double time, LiveSettings& out) {
  std::lock_guard<std::mutex> lock(mutex_);
  // Scheduled commands that are due, in the order they came.
  for (auto it = scheduled_.begin(); it != scheduled_.end();) {
    if (it->first <= time + 1e-9) {
      LiveSettings s = pending_;
      bool quit = false;
      parseCommand(it->second, s, quit);
      if (quit) quit_ = true;
      if (s != pending_) ++version_;
      pending_ = s;
      it = scheduled_.erase(it);
    } else {
      ++it;
    }
  }
  out = pending_;
  const bool changed = version_ != taken_;
  taken_ = version_;
  return changed;
}

void applySettings(GrabController& grab, const LiveSettings& s) {
  grab.setGain(s.gain);
  Mapping m = grab.mapping();
  m.scale = s.scale;
  m.offset = s.offset;
  grab.setMapping(m);
  grab.setForceAsFeedForward(s.smoothing == Smoothing::RollingAverage);
}

LiveSettings initialSettings(const GrabController& grab, const ServoConfig& servo) {
  LiveSettings s;
  s.gain = grab.gain();
  s.scale = grab.mapping().scale;
  s.offset = grab.mapping().offset;
  s.smoothing = servo.smoothing;
  s.rolling_window = servo.rolling_window;
  return s;
}

// --- TickRing -------------------------------------------------------------------------------

bool TickRing::push(const TickRecord& r) {
  const std::size_t head = head_.load(std::memory_order_relaxed);
  const std::size_t next = (head + 1) % buf_.size();
  if (next == tail_.load(std::memory_order_acquire)) {
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  buf_[head] = r;
  head_.store(next, std::memory_order_release);
  return true;
}

void TickRing::drain(std::vector<TickRecord>& out) {
  std::size_t tail = tail_.load(std::memory_order_relaxed);
  const std::size_t head = head_.load(std::memory_order_acquire);
  while (tail != head) {
    out.push_back(buf_[tail]);
    tail = (tail + 1) % buf_.size();
  }
  tail_.store(tail, std::memory_order_release);
}

// --- LiveSource -----------------------------------------------------------------------------

bool LiveSource::applyControls(double time, LiveSettings& applied) {
  if (!controls_.take(time, applied)) return false;
  onSettings(applied);
  return true;
}

std::vector<TickRecord> LiveSource::takeTicks() {
  std::vector<TickRecord> out;
  ring_.drain(out);
  return out;
}

void periodStats(std::vector<double> p, LiveStats& s) {
  if (p.empty()) return;
  std::sort(p.begin(), p.end());
  s.period_p50 = p[p.size() / 2];
  s.period_p99 = p[static_cast<std::size_t>(0.99 * static_cast<double>(p.size() - 1))];
  s.period_max = p.back();
}

// --- LiveSession ----------------------------------------------------------------------------

LiveSession::LiveSession(std::unique_ptr<Device> device, std::shared_ptr<Clock> clock, ServoConfig servo,
                         GrabController grab)
    : LiveSource(initialSettings(grab, servo)),
      device_(std::move(device)),
      clock_(std::move(clock)),
      servo_(servo, device_->spec()),
      grab_(std::move(grab)) {}

LiveSession::~LiveSession() { stop(); }

void LiveSession::start() {
  if (running_.load()) return;
  device_->open();
  device_->read(latest_);
  latest_tick_ = 0;
  ring_.push({0, latest_, {}, false});  // tick 0: the reading the first steps may use
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
  uint64_t tick = 0;
  while (running_.load()) {
    // One servo period: read, compute, write.
    DeviceState s;
    device_->read(s);
    const ServoOutput o = servo_.tick(s);
    device_->write(o.force);
    // The tick to the simulation thread's ring (haptics.csv, --record): never waits.
    ++tick;
    ring_.push({tick, s, {o.time, s.position, o.target, o.force, held_body_.load(std::memory_order_relaxed), o.energy, o.flags}});
    // Sleep to the next absolute deadline; a late tick is an overrun.
    deadline += T;
    std::this_thread::sleep_until(deadline);
    const auto now = std::chrono::steady_clock::now();
    const double period = std::chrono::duration<double>(now - last).count();
    last = now;
    std::lock_guard<std::mutex> lock(mutex_);
    latest_ = s;
    latest_tick_ = tick;
    stats_.force = o.force;
    ++stats_.ticks;
    if (period > 1.5 / servo_.config().rate) ++stats_.overruns;
    if (periods_.size() < 600000) periods_.push_back(period);  // 10 minutes at 1 kHz
  }
}

void LiveSession::apply(double, double dt, const std::vector<rigid::RigidBody>&, const std::vector<rigid::BodyState>& states,
                        std::vector<BodyWrench>& out) {
  DeviceState s;
  uint64_t tick = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    s = latest_;
    tick = latest_tick_;
  }
  noteStep(tick, states);
  grab_.update(s, states, out, dt);
  held_body_.store(grab_.grabbed(), std::memory_order_relaxed);
}

void LiveSession::publish(const std::vector<rigid::BodyState>& states) {
  servo_.publish(grab_.localModel(clock_->now(), states));
}

void LiveSession::onSettings(const LiveSettings& s) {
  applySettings(grab_, s);
  servo_.setSmoothing(s.smoothing, s.rolling_window);
}

LiveStats LiveSession::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  LiveStats s = stats_;
  s.dropped = ring_.dropped();
  periodStats(periods_, s);
  return s;
}

}  // namespace sph::haptics
