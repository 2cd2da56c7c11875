// The bridge protocol (haptics/bridge_protocol.h): encode/decode, rejection of malformed and
// stale datagrams, the bridge's own limits whatever the simulation sends, a lossy, reordering,
// delayed channel in virtual time, and real UDP on 127.0.0.1 (loops bounded in count and time).
#include "haptics/backends.h"
#include "haptics/bridge_protocol.h"
#include "haptics/grab.h"
#include "haptics/servo.h"
#include "haptics/udp.h"

#include <catch2/catch.hpp>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <random>
#include <vector>

using namespace sph::haptics;
using namespace sph::haptics::bridge;

namespace {

StatePacket sampleState() {
  StatePacket p;
  p.header.sequence = 1234567;
  p.header.flags = 5;
  p.state.time = 12.345;
  p.state.position = {0.01, -0.02, 0.03};
  p.state.orientation = Eigen::Quaterniond(0.5, 0.5, -0.5, 0.5);
  p.state.velocity = {0.1, 0.2, -0.3};
  p.state.buttons = 3;
  p.force = {0.5, -1.5, 2.5};
  p.servo_rate = 999.5;
  p.overruns = 7;
  return p;
}

LocalModelPacket sampleModel() {
  LocalModelPacket p;
  p.header.sequence = 42;
  p.state_sequence = 1234567;
  p.state_time = 12.345;
  p.model.anchor = {0.02, 0.01, -0.01};
  p.model.anchor_velocity = {0.3, 0, 0};
  p.model.feed_forward = {0, 0, -0.4};
  p.model.stiffness = 250;
  p.model.damping = 1.5;
  p.model.ttl = 0.1;
  p.model.coupled = true;
  p.max_force = 3.0;
  return p;
}

}  // namespace

TEST_CASE("Bridge: State and LocalModel packets survive encode and decode", "[haptics][bridge]") {
  const StatePacket s = sampleState();
  const auto sb = encode(s);
  CHECK(sb.size() == kStateBytes);
  CHECK(std::string(sb.begin(), sb.begin() + 4) == "SPHB");  // the magic on the wire
  StatePacket s2;
  REQUIRE(decode(sb.data(), sb.size(), s2) == DecodeError::None);
  CHECK(s2.header.sequence == s.header.sequence);
  CHECK(s2.header.flags == s.header.flags);
  CHECK(s2.state.time == s.state.time);
  CHECK(s2.state.position == s.state.position);
  CHECK(s2.state.orientation.coeffs() == s.state.orientation.coeffs());
  CHECK(s2.state.velocity == s.state.velocity);
  CHECK(s2.state.buttons == s.state.buttons);
  CHECK(s2.force == s.force);
  CHECK(s2.servo_rate == s.servo_rate);
  CHECK(s2.overruns == s.overruns);

  const LocalModelPacket m = sampleModel();
  const auto mb = encode(m);
  CHECK(mb.size() == kLocalModelBytes);
  LocalModelPacket m2;
  REQUIRE(decode(mb.data(), mb.size(), m2) == DecodeError::None);
  CHECK(m2.header.sequence == 42);
  CHECK(m2.state_sequence == m.state_sequence);
  CHECK(m2.state_time == m.state_time);
  CHECK(m2.model.anchor == m.model.anchor);
  CHECK(m2.model.anchor_velocity == m.model.anchor_velocity);
  CHECK(m2.model.feed_forward == m.model.feed_forward);
  CHECK(m2.model.stiffness == m.model.stiffness);
  CHECK(m2.model.damping == m.model.damping);
  CHECK(m2.model.ttl == m.model.ttl);
  CHECK(m2.model.coupled);
  CHECK(m2.max_force == m.max_force);
}

TEST_CASE("Bridge: short, long, wrong-version, wrong-magic, wrong-type, non-finite and stale packets are rejected",
          "[haptics][bridge]") {
  const auto good = encode(sampleModel());
  LocalModelPacket out;
  out.header.sequence = 999;  // must stay untouched by a rejected packet
  auto bad = good;
  CHECK(decode(bad.data(), bad.size() - 1, out) == DecodeError::Short);
  CHECK(decode(bad.data(), 3, out) == DecodeError::Short);
  CHECK(decode(nullptr, 0, out) == DecodeError::Short);
  bad.push_back(0);
  CHECK(decode(bad.data(), bad.size(), out) == DecodeError::Long);
  bad = good;
  bad[4] = 2;  // version 2
  CHECK(decode(bad.data(), bad.size(), out) == DecodeError::BadVersion);
  bad = good;
  bad[0] = 'X';
  CHECK(decode(bad.data(), bad.size(), out) == DecodeError::BadMagic);
  StatePacket s;
  CHECK(decode(good.data(), good.size(), s) == DecodeError::BadType);  // a LocalModel read as a State
  bad = good;
  bad[6] = 9;  // type 9
  CHECK(decode(bad.data(), bad.size(), out) == DecodeError::BadType);
  LocalModelPacket nan = sampleModel();
  nan.model.stiffness = std::numeric_limits<double>::quiet_NaN();
  const auto nb = encode(nan);
  CHECK(decode(nb.data(), nb.size(), out) == DecodeError::NonFinite);
  CHECK(out.header.sequence == 999);
  // Random garbage of every length up to 300 bytes, and good packets with random bytes flipped:
  // never a crash, and a flipped packet either decodes with finite numbers or is rejected.
  std::mt19937 rng(7);
  for (std::size_t n = 0; n <= 300; ++n) {
    std::vector<uint8_t> junk(n);
    for (auto& b : junk) b = static_cast<uint8_t>(rng());
    CHECK(decode(junk.data(), junk.size(), out) != DecodeError::None);
    auto flipped = good;
    flipped[kHeaderBytes + rng() % (good.size() - kHeaderBytes)] ^= static_cast<uint8_t>(1u + rng() % 255u);
    if (decode(flipped.data(), flipped.size(), out) == DecodeError::None) CHECK(std::isfinite(out.model.stiffness));
  }
  // Stale: newest wins; older and repeated sequence numbers are dropped; the counter may wrap.
  SequenceFilter f;
  CHECK(f.accept(1));
  CHECK(f.accept(2));
  CHECK(f.accept(5));
  CHECK_FALSE(f.accept(4));
  CHECK_FALSE(f.accept(5));
  CHECK(f.accept(6));
  SequenceFilter w;
  CHECK(w.accept(0xfffffffeu));
  CHECK(w.accept(0xffffffffu));
  CHECK(w.accept(0u));
  CHECK_FALSE(w.accept(0xfffffff0u));
  CHECK(f.dropped() == 2);
}

TEST_CASE("Bridge: the device limits hold whatever the simulation sends", "[haptics][bridge]") {
  // The simulation asks for K = 1e9 N/m, B = 1e6 N s/m, 1 kN of feed-forward and anchors metres away,
  // at random; the bridge sanitizes and its servo renders: never above the device's peak force.
  VirtualClock clock;
  SimulatedDevice dev(Trajectory({}, {}), clock);
  dev.open();
  const DeviceSpec spec = dev.spec();
  Servo servo(ServoConfig{}, spec);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  double fmax = 0;
  for (long i = 0; i < 3000; ++i) {
    clock.set(static_cast<double>(i) * 1e-3);
    if (i % 16 == 0 && i > 100) {
      LocalModelPacket p = sampleModel();
      p.model.stiffness = 1e9;
      p.model.damping = 1e6;
      p.model.feed_forward = 1e3 * Eigen::Vector3d(u(rng), u(rng), u(rng));
      p.model.anchor = Eigen::Vector3d(u(rng), u(rng), u(rng));
      p.model.ttl = 1e9;
      p.max_force = 1e9;
      const auto bytes = encode(p);
      LocalModelPacket q;
      REQUIRE(decode(bytes.data(), bytes.size(), q) == DecodeError::None);
      const LocalModel m = sanitize(q, spec, clock.now());
      CHECK(m.stiffness <= spec.max_stiffness);
      CHECK(m.damping <= spec.max_damping);
      CHECK(m.feed_forward.norm() <= spec.max_force * (1 + 1e-12));
      CHECK(m.ttl <= 0.1);
      servo.publish(m);
    }
    fmax = std::max(fmax, servo.step(dev).force.norm());
  }
  CHECK(fmax <= spec.max_force);
  CHECK(fmax <= servo.config().peak_force * (1 + 1e-12));
}

namespace {

// A datagram channel in virtual time: each packet is lost with probability `loss`, else delivered
// after `delay` plus a random 0-10 ms (so packets overtake each other).
struct Channel {
  std::mt19937 rng;
  double loss, delay;
  std::multimap<double, std::vector<uint8_t>> queue;  // arrival time -> datagram
  uint64_t sent = 0, lost = 0;
  void send(double t, std::vector<uint8_t> bytes) {
    ++sent;
    if (std::uniform_real_distribution<double>(0, 1)(rng) < loss) {
      ++lost;
      return;
    }
    queue.emplace(t + delay + std::uniform_real_distribution<double>(0, 0.01)(rng), std::move(bytes));
  }
  std::vector<std::vector<uint8_t>> arrived(double t) {
    std::vector<std::vector<uint8_t>> out;
    while (!queue.empty() && queue.begin()->first <= t) {
      out.push_back(std::move(queue.begin()->second));
      queue.erase(queue.begin());
    }
    return out;
  }
};

// The bridge side: a simulated hand on a 2 cm circle (1 turn/s) and the servo. The simulation
// side, at 60 frames/s: a 0.1 kg body in a viscous medium (0.5 N s/m) grabbed at t = 0, coupled
// to the last device State it received. Both directions go through a channel losing `loss` of
// the datagrams and delaying them by `delay` + 0-10 ms (so reordering them). 4 s in virtual time.
struct LinkRun {
  double fmax = 0, early = 0, late = 0;  ///< peak |F| overall, in [1, 2) s, in [3, 4) s (unit: N)
  double mean = 0;                       ///< mean |F| over [1, 4) s (unit: N)
  uint64_t lost = 0, sent = 0, dropped = 0;
  double peak_limit = 0;                 ///< (unit: N)
};

LinkRun runLink(double loss, double delay, bool compensate) {
  LinkRun r;
  VirtualClock clock;
  Segment circle;
  circle.kind = SegmentKind::Circle;
  circle.t0 = 0.0;
  circle.t1 = 4.0;
  circle.radius = 0.02;
  circle.period = 1.0;
  SimulatedDevice dev(Trajectory({circle}, {{0.0, 0, true}}), clock);
  dev.open();
  ServoConfig cfg;
  cfg.ramp_time = 0.2;
  Servo servo(cfg, dev.spec());
  Channel up{std::mt19937(11), loss, delay, {}}, down{std::mt19937(12), loss, delay, {}};
  SequenceFilter bridge_filter, sim_filter;
  std::vector<sph::rigid::BodyState> states(1);
  states[0].x = Eigen::Vector3d(0.02, 0, 0);
  GrabController grab(Mapping{}, GrabSettings{}, {{0, 0.1, [](const Eigen::Vector3d&) { return Eigen::Vector3d::Zero(); }}});
  DeviceState seen;  // the simulation's latest device State
  seen.position = states[0].x;
  seen.buttons = 1;
  uint32_t state_seq = 0, model_seq = 0;
  const double dt = 1.0 / 240.0;  // 4 steps per 60 Hz frame
  long step = 0;
  for (long i = 0; i < 4000; ++i) {
    const double t = static_cast<double>(i) * 1e-3;
    clock.set(t);
    // Bridge: newest LocalModel in, sanitized; one servo tick; the State out.
    for (const auto& d : down.arrived(t)) {
      LocalModelPacket p;
      if (decode(d.data(), d.size(), p) != DecodeError::None || !bridge_filter.accept(p.header.sequence)) continue;
      // Compensated (as sphaptics-bridge does): stamped with the time of the State it was computed
      // from (the bridge's clock), arrived now: the hold extrapolates over the whole round trip.
      // Not compensated: stamped on arrival.
      servo.publish(compensate ? sanitize(p, dev.spec(), p.state_time, t) : sanitize(p, dev.spec(), t));
    }
    DeviceState s;
    dev.read(s);
    const ServoOutput o = servo.tick(s);
    dev.write(o.force);
    StatePacket sp;
    sp.header.sequence = ++state_seq;
    sp.state = s;
    sp.force = o.force;
    up.send(t, encode(sp));
    r.fmax = std::max(r.fmax, o.force.norm());
    if (t >= 1.0 && t < 2.0) r.early = std::max(r.early, o.force.norm());
    if (t >= 3.0) r.late = std::max(r.late, o.force.norm());
    if (t >= 1.0) r.mean += o.force.norm() / 3000.0;
    // Simulation: newest State in; steps up to t; a LocalModel out at each 60 Hz frame.
    for (const auto& d : up.arrived(t)) {
      StatePacket p;
      if (decode(d.data(), d.size(), p) != DecodeError::None || !sim_filter.accept(p.header.sequence)) continue;
      seen = p.state;
    }
    while (static_cast<double>(step) * dt <= t) {
      std::vector<sph::BodyWrench> out(1);
      grab.update(seen, states, out);
      states[0].v += dt * (out[0].force - 0.5 * states[0].v) / 0.1;
      states[0].x += dt * states[0].v;
      ++step;
      if (step % 4 == 0) {
        LocalModelPacket mp;
        mp.header.sequence = ++model_seq;
        mp.state_sequence = state_seq;
        mp.state_time = seen.time;
        mp.model = grab.localModel(static_cast<double>(step) * dt, states);
        down.send(t, encode(mp));
      }
    }
  }
  r.lost = up.lost + down.lost;
  r.sent = up.sent + down.sent;
  r.dropped = bridge_filter.dropped() + sim_filter.dropped();
  r.peak_limit = servo.config().peak_force;
  return r;
}

}  // namespace

TEST_CASE("Bridge: 10 % loss, reordering and 20 ms delay stay stable", "[haptics][bridge]") {
  // Stable: never above the peak limit, and no growth (the last second's peak within 1.5x the
  // second's). Bounded: below the steady load (0.1 N) plus what the uncompensated round trip would
  // cost, K_d v tau = 250 N/m x 0.126 m/s x (2 x 30 ms + one frame) = 2.4 N. (Measured ~1.1 N.)
  const LinkRun r = runLink(0.1, 0.02, true);
  INFO("felt force peak " << r.fmax << " N; [1, 2) s " << r.early << " N, [3, 4) s " << r.late << " N; lost " << r.lost
                          << " of " << r.sent << "; stale dropped " << r.dropped);
  CHECK(r.lost > 0.08 * static_cast<double>(r.sent));  // the channel did lose
  CHECK(r.dropped > 0);                                 // and reordered
  CHECK(r.fmax <= r.peak_limit);
  const double bound = 0.1 + 250.0 * (2 * M_PI * 0.02) * (2 * 0.03 + 1.0 / 60.0);
  CHECK(r.early < bound);
  CHECK(r.late < bound);
  CHECK(r.late < 1.5 * r.early);
}

TEST_CASE("Bridge: round-trip compensation lowers the felt lag force and survives a round trip beyond the watchdog",
          "[haptics][bridge]") {
  // With the LocalModel stamped at the time of the State it came from, the servo's hold predicts
  // the anchor over the round trip: the mean felt force while tracking the circle (the lag error
  // K_d |a - x| plus the body's load, ~0.1 N) drops. Without loss, 20 ms each way (+0-10 ms):
  // measured 0.63 N compensated, 0.78 N stamped on arrival (0.23 N with no delay). Bound: at
  // least 15 % lower. At 50 ms each way (round trip 100-120 ms, over the 100 ms watchdog) the
  // force must not fade out: the watchdog measures the time since arrival, not the state's age.
  const LinkRun on = runLink(0.0, 0.02, true), off = runLink(0.0, 0.02, false);
  INFO("mean felt force: compensated " << on.mean << " N, stamped on arrival " << off.mean << " N");
  CHECK(on.mean < 0.85 * off.mean);
  const LinkRun slow = runLink(0.0, 0.05, true);
  INFO("50 ms each way: mean " << slow.mean << " N, [3, 4) s peak " << slow.late << " N");
  CHECK(slow.mean > 0.1);
  CHECK(slow.fmax <= slow.peak_limit);
}

TEST_CASE("Bridge: packets cross real UDP on 127.0.0.1", "[haptics][bridge]") {
  // 100 States from one socket to another; the loops end after 100 sends and at most 2 s.
  UdpSocket a, b;
  REQUIRE(a.port() != 0);
  REQUIRE(b.port() != 0);
  StatePacket p = sampleState();
  for (uint32_t k = 1; k <= 100; ++k) {
    p.header.sequence = k;
    a.send(b.port(), encode(p));
  }
  // A long datagram too: rejected by size.
  std::vector<uint8_t> long_packet = encode(p);
  long_packet.resize(long_packet.size() + 100);
  a.send(b.port(), long_packet);
  SequenceFilter filter;
  int good = 0, rejected = 0;
  std::vector<uint8_t> buf;
  const auto t0 = std::chrono::steady_clock::now();
  for (int k = 0; k < 200 && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(2); ++k) {
    const std::size_t n = b.receive(buf, 50);
    if (n == 0) break;
    StatePacket q;
    if (decode(buf.data(), n, q) == DecodeError::None && filter.accept(q.header.sequence)) ++good;
    else ++rejected;
  }
  CHECK(good >= 90);  // loopback drops nothing in practice; 10 % of slack for a loaded machine
  CHECK(rejected >= 1);
}
