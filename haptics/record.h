// Record and replay of a live haptic run (`sphaptics run --interactive --record FILE`, replayed
// headless by `sphaptics replay FILE`). The servo never touches the simulation's state (only the
// device), so what a replay needs is the device input: every servo tick's reading is stored, each
// simulation step names the tick whose reading it used, the live settings changes (gain, mapping,
// smoothing) name the frame boundary they were applied at, and a state hash per frame (a hash per
// step would read the whole state back from the OpenCL device every step) checks the replay.
//
// File, version 2 (text, one item per line, numbers %.17g: exact):
//   # sphaptics haptic recording v2
//   scene <absolute path>          set <key=value> (repeated)        frames <n>
//   tick <index> <time> <x> <y> <z> <vx> <vy> <vz> <buttons>   (every servo tick; index 0 = at open)
//   step <tick index>                                           (one per simulation step)
//   settings <frame> <gain> <scale> <ox> <oy> <oz> <servo|rolling_average> <window>
//   hash <frame> <16 hex digits>                                (one per frame)
//   end <ticks> <steps> <hashes>                                (a file without it is truncated)
// Version 1 files (`step <time> <x> <y> <z> <vx> <vy> <vz> <buttons>` per step, no ticks) are read too.
#pragma once

#include "core/external_force.h"
#include "haptics/device.h"
#include "haptics/grab.h"
#include "haptics/live.h"

#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace sph::haptics {

/// A recording file that cannot be read or written (bad input: `sphaptics` exits 2), as opposed
/// to a device that fails (DeviceError: exit 3).
struct RecordingError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct Recording {
  std::string scene;                 ///< absolute path of the scene file
  std::vector<std::string> sets;     ///< --set overrides of the recorded run
  int frames = 0;                    ///< frames recorded
  std::vector<std::pair<uint64_t, DeviceState>> ticks;  ///< every servo tick's reading, by tick index (v2)
  std::vector<uint64_t> step_ticks;  ///< the tick each step used (v2)
  std::vector<DeviceState> steps;    ///< the reading each step used (v1; v2: resolved from ticks)
  std::vector<std::pair<int, LiveSettings>> settings;  ///< (frame boundary, settings applied there)
  std::vector<uint64_t> hashes;      ///< Simulation::stateHash() after each frame
};

/// Throws RecordingError when the file cannot be written.
void writeRecording(const std::string& path, const Recording& rec);
/// Throws RecordingError naming the file and line of what is wrong (bad, truncated, unknown version).
Recording readRecording(const std::string& path);

/// Feeds recorded readings, one per step, to a grab controller.
class ReplaySource : public ExternalForceSource {
 public:
  ReplaySource(std::vector<DeviceState> steps, GrabController grab);
  void apply(double time, double dt, const std::vector<rigid::RigidBody>& bodies,
             const std::vector<rigid::BodyState>& states, std::vector<BodyWrench>& out) override;
  std::size_t used() const { return next_; }
  /// Live settings recorded at a frame boundary (gain, mapping, smoothing mode).
  void applySettings(const LiveSettings& s) { haptics::applySettings(grab_, s); }

 private:
  std::vector<DeviceState> steps_;
  GrabController grab_;
  std::size_t next_ = 0;
};

}  // namespace sph::haptics
