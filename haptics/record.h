// Record and replay of a live haptic run: the device reading the simulation used at each step and
// a state hash per frame (`sphaptics run --interactive --record FILE`), replayed headless by
// `sphaptics replay FILE`, which feeds the same readings to the same grab logic and checks every
// hash. The servo never touches the simulation's state (only the device), so the readings the
// simulation consumed are all the input a replay needs.
//
// File (text, one item per line):
//   # sphaptics haptic recording v1
//   scene <absolute path>          set <key=value> (repeated)        frames <n>
//   step <time> <x> <y> <z> <vx> <vy> <vz> <buttons>     (one per simulation step, %.17g)
//   hash <frame> <16 hex digits>                          (one per frame)
#pragma once

#include "core/external_force.h"
#include "haptics/device.h"
#include "haptics/grab.h"

#include <cstdint>
#include <string>
#include <vector>

namespace sph::haptics {

struct Recording {
  std::string scene;                 ///< absolute path of the scene file
  std::vector<std::string> sets;     ///< --set overrides of the recorded run
  int frames = 0;                    ///< frames recorded
  std::vector<DeviceState> steps;    ///< the reading each step used
  std::vector<uint64_t> hashes;      ///< Simulation::stateHash() after each frame
};

/// Throws DeviceError when the file cannot be written.
void writeRecording(const std::string& path, const Recording& rec);
/// Throws DeviceError naming the file and line of what is wrong.
Recording readRecording(const std::string& path);

/// Feeds recorded readings, one per step, to a grab controller.
class ReplaySource : public ExternalForceSource {
 public:
  ReplaySource(std::vector<DeviceState> steps, GrabController grab);
  void apply(double time, double dt, const std::vector<rigid::RigidBody>& bodies,
             const std::vector<rigid::BodyState>& states, std::vector<BodyWrench>& out) override;
  std::size_t used() const { return next_; }

 private:
  std::vector<DeviceState> steps_;
  GrabController grab_;
  std::size_t next_ = 0;
};

}  // namespace sph::haptics
