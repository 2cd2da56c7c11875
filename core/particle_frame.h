// A host-side copy of the fluid particles at one output frame (structure of arrays, n entries each),
// read back from the device by Simulation::readFrame() and handed to exporters.
#pragma once

#include <cstdint>
#include <vector>

namespace sph {

struct ParticleFrame {
  double time = 0.0;                 ///< simulated time (unit: s)
  std::vector<float> x, y, z;        ///< position (unit: m)
  std::vector<float> vx, vy, vz;     ///< velocity (unit: m/s)
  std::vector<float> density;        ///< mass density (unit: kg/m^3)
  std::vector<float> pressure;       ///< pressure (unit: Pa)
  std::vector<int32_t> phase;        ///< index into FluidSpec::phases
  std::vector<int64_t> id;           ///< stable particle id (creation order)
  std::vector<float> r, g, b;        ///< colour, linear RGB in [0,1]
  std::size_t size() const { return x.size(); }
};

}  // namespace sph
