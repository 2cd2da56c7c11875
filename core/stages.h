// The stages of one time step, in the order Simulation::step() runs them. The stage mask is
// compiled from the scene (a stage runs only when the scene calls for it) and `--disable` removes
// stages from it. A stage that is off enqueues no kernel.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>

namespace sph {

enum class Stage : int {
  Inflow = 0,       ///< emit particles from nozzles (host, then upload)
  Grid,             ///< neighbour grid: count, scan, sort, reorder
  Density,          ///< number density, mass density, equation of state
  Probes,           ///< pressure probes and height gauges sampled (scenes with a probes section)
  Pressure,         ///< pressure force (and gravity); solver wcsph only
  DivergenceSolve,  ///< DFSPH: factors alpha, then the velocity made divergence-free (Bender & Koschier 2017, Alg. 2)
  Viscosity,        ///< artificial or laminar viscosity
  ColourDiffusion,  ///< colour mixing between particles
  DensitySolve,     ///< DFSPH: v* = v + dt a, then the constant-density solve (Bender & Koschier 2017, Alg. 3)
  RigidCoupling,    ///< moving bodies' particles follow their pose; fluid forces on them, summed per body
  Haptics,          ///< external forces on bodies (a grabbed body's coupling spring), core/external_force.h
  ClothCoupling,    ///< cloth nodes are boundary particles for the fluid; fluid forces on each node
  Integrate,        ///< semi-implicit Euler, closed walls
  RigidDynamics,    ///< rigid bodies: momenta and poses on the host (Eigen); scripted bodies follow their motion
  Cloth,            ///< cloth: springs (XPBD or explicit), anchors, tearing (kernels/cloth.cl)
  Diagnostics,      ///< NaN/inf, escapes, CFL violations (once per frame)
  Count
};

constexpr int kNumStages = static_cast<int>(Stage::Count);

/// Lower-case names used in profiles, `--disable` and messages ("colour_diffusion").
const char* stageName(Stage s);
std::optional<Stage> stageFromName(const std::string& name);
/// "inflow, grid, density, ..." for messages.
std::string stageNameList();

class StageMask {
 public:
  bool on(Stage s) const { return (bits_ >> static_cast<int>(s)) & 1u; }
  void set(Stage s, bool enabled) {
    const uint32_t b = 1u << static_cast<int>(s);
    bits_ = enabled ? (bits_ | b) : (bits_ & ~b);
  }
  uint32_t bits() const { return bits_; }
  std::string str() const;  ///< the enabled stages, comma separated

 private:
  uint32_t bits_ = 0;
};

}  // namespace sph
