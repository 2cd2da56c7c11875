#include "haptics/bridge_client.h"

#include <algorithm>
#include <chrono>

namespace sph::haptics {

namespace {
double seconds(std::chrono::steady_clock::duration d) { return std::chrono::duration<double>(d).count(); }
}  // namespace

BridgeSession::BridgeSession(BridgeSettings settings, ServoConfig servo, GrabController grab)
    : LiveSource(initialSettings(grab, servo)), settings_(settings), grab_(std::move(grab)) {}

BridgeSession::~BridgeSession() { stop(); }

std::string BridgeSession::deviceName() const {
  return "bridge 127.0.0.1:" + std::to_string(settings_.bridge_port) + " (States on port " +
         std::to_string(settings_.listen_port) + ")";
}

void BridgeSession::start() {
  if (running_.load()) return;
  socket_ = std::make_unique<UdpSocket>(settings_.listen_port);
  // The first State: the bridge must be running (bounded wait: `timeout`).
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<uint8_t> buf(2048);
  while (!have_state_) {
    const double left = settings_.timeout - seconds(std::chrono::steady_clock::now() - t0);
    if (left <= 0)
      throw DeviceError(deviceName() + ": no State from sphaptics-bridge within " + std::to_string(settings_.timeout) +
                        " s (is it running? sphaptics-bridge --listen " + std::to_string(settings_.bridge_port) +
                        " --send " + std::to_string(settings_.listen_port) + ")");
    const std::size_t n = socket_->receive(buf, std::max(1, static_cast<int>(1e3 * std::min(left, 0.05))));
    bridge::StatePacket p;
    if (n == 0) continue;
    if (n > buf.size() || bridge::decode(buf.data(), n, p) != bridge::DecodeError::None || !filter_.accept(p.header.sequence)) {
      ++rejected_;
      continue;
    }
    latest_ = p;
    latest_arrival_ = std::chrono::steady_clock::now();
    have_state_ = true;
    ++received_;
    ring_.push({p.header.sequence, p.state, {}, false});  // the reading the first steps use
  }
  running_ = true;
  thread_ = std::thread([this] { receive(); });
}

void BridgeSession::stop() {
  if (!running_.exchange(false)) return;
  if (thread_.joinable()) thread_.join();
  // The bridge's watchdog fades the force out once the LocalModels stop (its own 100 ms + 200 ms).
  socket_.reset();
}

void BridgeSession::receive() {
  // Every datagram: a valid, newer State becomes the latest and a tick record. Polls in 5 ms
  // slices so that stop() is answered quickly; silence longer than `timeout` is a failure.
  std::vector<uint8_t> buf(2048);
  while (running_.load()) {
    const std::size_t n = socket_->receive(buf, 5);
    const auto now = std::chrono::steady_clock::now();
    std::lock_guard<std::mutex> lock(mutex_);
    if (n == 0) {
      if (seconds(now - latest_arrival_) > settings_.timeout && !failed_.load()) {
        failure_ = deviceName() + ": no State from sphaptics-bridge for " + std::to_string(settings_.timeout) +
                   " s (the bridge stopped answering)";
        failed_ = true;
      }
      continue;
    }
    bridge::StatePacket p;
    if (n > buf.size() || bridge::decode(buf.data(), n, p) != bridge::DecodeError::None || !filter_.accept(p.header.sequence)) {
      ++rejected_;
      continue;
    }
    if (intervals_.size() < 600000) intervals_.push_back(seconds(now - latest_arrival_));
    latest_ = p;
    latest_arrival_ = now;
    ++received_;
    // The bridge's tick as haptics.csv writes it: the anchor is the last one sent (the bridge's
    // own hold is not sent back), the passivity energy is the bridge's and stays there (0 here).
    ring_.push({p.header.sequence, p.state,
                {p.state.time, p.state.position, anchor_, p.force, held_body_.load(std::memory_order_relaxed), 0.0, p.header.flags}});
  }
}

void BridgeSession::check() {
  if (!failed_.load()) return;
  std::lock_guard<std::mutex> lock(mutex_);
  throw DeviceError(failure_);
}

void BridgeSession::apply(double, double dt, const std::vector<rigid::RigidBody>&, const std::vector<rigid::BodyState>& states,
                          std::vector<BodyWrench>& out) {
  DeviceState s;
  uint64_t tick = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    s = latest_.state;
    tick = latest_.header.sequence;
  }
  noteStep(tick, states);
  grab_.update(s, states, out, dt);
  held_body_.store(grab_.grabbed(), std::memory_order_relaxed);
}

void BridgeSession::publish(const std::vector<rigid::BodyState>& states) {
  // The LocalModel, stamped with the bridge time of the newest State seen (round-trip compensation:
  // the bridge's hold extrapolates from then).
  bridge::LocalModelPacket p;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    p.state_sequence = latest_.header.sequence;
    p.state_time = latest_.state.time;
    if (ages_.size() < 600000) ages_.push_back(seconds(std::chrono::steady_clock::now() - latest_arrival_));
  }
  p.header.type = bridge::PacketType::LocalModel;
  p.header.sequence = ++model_seq_;
  p.model = grab_.localModel(p.state_time, states);
  p.max_force = settings_.max_force;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    anchor_ = p.model.anchor;
  }
  if (socket_) socket_->send(settings_.bridge_port, bridge::encode(p));
}

void BridgeSession::onSettings(const LiveSettings& s) {
  // Gain and mapping act here; the smoothing mode lives in the bridge's servo (not sent).
  applySettings(grab_, s);
}

LiveStats BridgeSession::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  LiveStats s;
  s.ticks = received_;
  s.overruns = latest_.overruns;
  s.force = latest_.force;
  s.servo_rate = latest_.servo_rate;
  s.rejected = rejected_;
  s.dropped = ring_.dropped();
  periodStats(intervals_, s);
  if (!ages_.empty()) {
    std::vector<double> a = ages_;
    std::nth_element(a.begin(), a.begin() + static_cast<long>(a.size() / 2), a.end());
    s.round_trip = a[a.size() / 2];
  }
  return s;
}

}  // namespace sph::haptics
