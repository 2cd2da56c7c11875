// sphaptics-bridge: the device side of the bridge protocol (haptics/bridge_protocol.h). It runs
// the 1 kHz servo next to the device with absolute-deadline sleeps, takes LocalModels from the
// simulation over UDP on 127.0.0.1 (newest wins, capped to the device's spec) and sends the device
// State back every tick. The device is the simulated hand (a 0.15 kg mass on a grip spring to a
// 2 cm circle, button 0 held: tests) or, with --device touch, an OpenHaptics device
// (haptics/tools/openhaptics_device.cpp, built only when the vendor's HD/hd.h is found).
//
//   sphaptics-bridge --listen 47001 --send 47002 --duration 30
//
// At the end it prints the servo period p50 / p99 / max, the overruns (periods over 1.5x T) and the
// packets accepted and rejected.
#include "haptics/backends.h"
#include "haptics/bridge_protocol.h"
#include "haptics/servo.h"
#include "haptics/udp.h"
#ifdef SPHAPTICS_HAVE_OPENHAPTICS
#include "haptics/tools/openhaptics_device.h"
#endif

#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <csignal>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <thread>
#include <vector>

using namespace sph::haptics;

namespace {
// SIGINT / SIGTERM end the loop at the next tick (the device is closed, the statistics printed).
volatile std::sig_atomic_t g_stop = 0;
extern "C" void onStop(int) { g_stop = 1; }
}  // namespace

int main(int argc, char** argv) {
  // Options: --listen PORT, --send PORT, --duration S, --rate HZ.
  int listen_port = 47001, send_port = 47002;
  double duration = 10.0, rate = 1000.0, ramp = 2.0;
  std::string device_kind = "simulated", device_name;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> const char* {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "error: %s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--listen") listen_port = std::atoi(next());
    else if (a == "--send") send_port = std::atoi(next());
    else if (a == "--duration") duration = std::atof(next());
    else if (a == "--rate") rate = std::atof(next());
    else if (a == "--ramp") ramp = std::atof(next());
    else if (a == "--device") device_kind = next();
    else if (a == "--device-name") device_name = next();
    else if (a == "--help" || a == "-h") {
      std::printf("usage: sphaptics-bridge [--listen PORT] [--send PORT] [--duration S] [--rate HZ] [--ramp S]\n"
                  "                        [--device simulated|touch] [--device-name NAME]\n"
                  "  --device: simulated (a hand mass on a 2 cm circle, button 0 held; tests) or touch (OpenHaptics,\n"
                  "            built only when HD/hd.h was found); --device-name: the OpenHaptics configuration name\n"
                  "  --duration: seconds to run (SIGINT/SIGTERM end it earlier); --ramp: start-up force ramp (unit: s)\n");
      return 0;
    } else {
      std::fprintf(stderr, "error: --%s: unknown option (see --help)\n", a.c_str() + (a.rfind("--", 0) == 0 ? 2 : 0));
      return 2;
    }
  }
  if (listen_port <= 0 || listen_port > 65535 || send_port <= 0 || send_port > 65535 || !(duration > 0) ||
      !(rate >= 100 && rate <= 10000) || !(ramp >= 0 && ramp <= 60)) {
    std::fprintf(stderr, "error: ports must be 1-65535, duration > 0 s, rate 100-10000 Hz, ramp 0-60 s\n");
    return 2;
  }
  if (device_kind != "simulated" && device_kind != "touch") {
    std::fprintf(stderr, "error: --device: '%s' is not simulated or touch\n", device_kind.c_str());
    return 2;
  }
#ifndef SPHAPTICS_HAVE_OPENHAPTICS
  if (device_kind == "touch") {
    std::fprintf(stderr, "error: --device touch: this sphaptics-bridge was built without OpenHaptics (HD/hd.h and libHD "
                         "were not found when it was configured; install the OpenHaptics SDK and build again)\n");
    return 2;
  }
#endif
  std::signal(SIGINT, onStop);
  std::signal(SIGTERM, onStop);
  try {
    // The device, the servo, the socket.
    SteadyClock clock;
    std::unique_ptr<Device> device;
    if (device_kind == "simulated") {
      Segment circle;
      circle.kind = SegmentKind::Circle;
      circle.t0 = 0.0;
      circle.t1 = duration;
      device = std::make_unique<SimulatedDevice>(Trajectory({circle}, {{0.0, 0, true}}), clock);
    }
#ifdef SPHAPTICS_HAVE_OPENHAPTICS
    else {
      device = makeOpenHapticsDevice(device_name);
    }
#endif
    device->open();
    ServoConfig cfg;
    cfg.rate = rate;
    cfg.ramp_time = ramp;
    Servo servo(cfg, device->spec());
    UdpSocket socket(static_cast<uint16_t>(listen_port));
    bridge::SequenceFilter filter;
    uint64_t rejected = 0, overruns = 0;
    uint32_t seq = 0;
    std::vector<double> periods, ages;
    std::vector<uint8_t> buf(2048);

    // Real-time priority when permitted (SCHED_FIFO), else the ordinary scheduler.
    sched_param prio{};
    prio.sched_priority = std::max(1, sched_get_priority_max(SCHED_FIFO) - 1);
    const bool realtime = pthread_setschedparam(pthread_self(), SCHED_FIFO, &prio) == 0;
    // The loop: absolute deadlines T apart; a late tick counts as an overrun, the schedule goes on.
    const auto T = std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(1.0 / rate));
    auto deadline = std::chrono::steady_clock::now();
    auto last = deadline;
    const long ticks = static_cast<long>(duration * rate);
    for (long k = 0; k < ticks && !g_stop; ++k) {
      // Every datagram waiting: the newest valid LocalModel wins.
      for (int n = 0; n < 64; ++n) {
        const std::size_t len = socket.receive(buf, 0);
        if (len == 0) break;
        bridge::LocalModelPacket p;
        if (len > buf.size() || bridge::decode(buf.data(), len, p) != bridge::DecodeError::None ||
            !filter.accept(p.header.sequence)) {
          ++rejected;
          continue;
        }
        // Round-trip compensation: the model is stamped with the time of the State it was built
        // from (this clock), so the hold extrapolates over the whole round trip. Never trusted:
        // a stamp in the future or more than 1 s old is clamped (a stale one then fades out).
        const double now = clock.now();
        const double stamp = std::clamp(p.state_time, now - 1.0, now);
        ages.push_back(now - stamp);
        servo.publish(bridge::sanitize(p, device->spec(), stamp, now));
      }
      const ServoOutput o = servo.step(*device);
      bridge::StatePacket sp;
      sp.header.sequence = ++seq;
      sp.header.flags = o.flags;  // the servo's flags (haptics.csv `flags` on the simulation side)
      device->read(sp.state);
      sp.force = o.force;
      sp.servo_rate = rate;
      sp.overruns = static_cast<uint32_t>(overruns);
      socket.send(static_cast<uint16_t>(send_port), bridge::encode(sp));
      // Sleep to the next absolute deadline.
      deadline += T;
      std::this_thread::sleep_until(deadline);
      const auto now = std::chrono::steady_clock::now();
      const double period = std::chrono::duration<double>(now - last).count();
      last = now;
      periods.push_back(period);
      if (period > 1.5 / rate) ++overruns;
    }
    device->close();
    // Servo period statistics.
    std::sort(periods.begin(), periods.end());
    auto pct = [&](double q) { return periods.empty() ? 0.0 : periods[static_cast<std::size_t>(q * (periods.size() - 1))]; };
    std::printf("%s: ", realtime ? "real-time priority" : "no real-time priority");
    std::printf("ticks %zu  period p50 %.3f ms  p99 %.3f ms  max %.3f ms  overruns %llu  models accepted %llu  rejected %llu\n",
                periods.size(), 1e3 * pct(0.5), 1e3 * pct(0.99), 1e3 * (periods.empty() ? 0.0 : periods.back()),
                static_cast<unsigned long long>(overruns), static_cast<unsigned long long>(filter.accepted()),
                static_cast<unsigned long long>(rejected));
    // The round trip the hold compensated: the age of each model's State on its arrival here.
    std::sort(ages.begin(), ages.end());
    if (!ages.empty())
      std::printf("model age on arrival (round trip): p50 %.1f ms  max %.1f ms\n", 1e3 * ages[ages.size() / 2], 1e3 * ages.back());
    std::fflush(stdout);
  } catch (const std::exception& e) {  // the device failed (or the socket): exit 3
    std::fprintf(stderr, "device error: %s\n", e.what());
    return 3;
  }
  return 0;
}
