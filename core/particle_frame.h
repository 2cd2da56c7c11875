// A host-side copy of the particles at one output frame (structure of arrays, n entries each): the
// fluid, read back from the device by Simulation::readFrame(), and for particles.h5part also the
// rigid bodies' particles and the cloth nodes (the runner appends them, with their type).
#pragma once

#include <cstdint>
#include <vector>

namespace sph {

/// What a particle is (the `type` dataset of particles.h5part).
enum ParticleType : int32_t { kFluid = 0, kBoundary = 1, kRigid = 2, kCloth = 3, kSoft = 4 };

struct ParticleFrame {
  double time = 0.0;                 ///< simulated time (unit: s)
  std::vector<float> x, y, z;        ///< position (unit: m)
  std::vector<float> vx, vy, vz;     ///< velocity (unit: m/s)
  std::vector<float> density;        ///< mass density (unit: kg/m^3)
  std::vector<float> pressure;       ///< pressure (unit: Pa)
  std::vector<int32_t> phase;        ///< index into FluidSpec::phases
  std::vector<int64_t> id;           ///< stable particle id (creation order)
  std::vector<float> r, g, b;        ///< colour, linear RGB in [0,1]
  std::vector<int32_t> type;         ///< ParticleType of each entry; empty = all fluid
  std::size_t size() const { return x.size(); }
};

}  // namespace sph
