// The Archimedes check (scenes/tests/floating_block.yaml), shared by the WCSPH test (test_rigid.cpp)
// and the DFSPH one (test_dfsph.cpp): one scene, one criterion, any solver through --set overrides.
#pragma once

#include "cli/runner.h"
#include "core/model.h"
#include "tests/scene_runs.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <string>
#include <vector>

namespace sph::testing {

/// A 12 x 12 x 6 cm block of 500 kg/m^3, dx = 1 cm. At rest its weight equals the fluid force and
/// its draft is rho_s / rho_f h = 3 cm (shared/reference/rigid_body_analytic_checks.csv, Archimedes
/// row). The water level follows from mass conservation: N dx^3 of fluid (at rest density:
/// hydrostatic compression is rho g H / (rho c0^2) = 0.4 % with WCSPH, 0.05 % with DFSPH) plus the
/// submerged volume m / rho_f, over the tank's area. Averaged over the last 0.6 s (the heave has
/// decayed to under 0.1 mm). Tolerance: the 5 %. The error is one of resolution, at the
/// block's edges: measured with WCSPH 4.8 % short at dx = 1.5 cm, 1.9 % at 1 cm, 0.8 % at 7.5 mm.
/// The fluid force: its mean at the frame ends (`frame_end_force`), and its time average over
/// every step of the same 0.6 s (`step_force`: DFSPH's per-step force chatters around the weight,
/// a frame end samples one step of it), each within 2 % of the weight: at rest the fluid carries it.
struct FloatingBlock {
  int exit_code = 0;
  double draft = 0;            // (unit: m)
  double frame_end_force = 0;  // mean vertical fluid force at the frame ends (unit: N)
  double step_force = 0;       // time average of the vertical fluid force over the steps (unit: N)
  double weight = 0;           // (unit: N)
};

inline FloatingBlock floatingBlock(const std::vector<std::string>& sets) {
  app::RunOptions o = quietRun("floating_block.yaml", sets);
  double z_sum = 0, force_sum = 0, impulse = 0, span = 0, last_t = -1, last_f = 0;
  int n = 0;
  std::size_t particles = 0;
  FloatingBlock out;
  double mass = 0;
  const app::RunResult r = app::runScene(o, [&](Simulation& sim, const FrameReport&) {
    particles = sim.numFluid();
    mass = sim.model().bodies[0].mass;
    sim.recordStepForces(true);
    // each step's force acts from its start to the next step's start
    for (const StepForce& s : sim.takeStepForces()) {
      if (last_t >= 0.9 - 1e-9) impulse += last_f * (s.time - last_t), span += s.time - last_t;
      last_t = s.time, last_f = s.force.z();
    }
    if (sim.time() < 0.9 - 1e-9) return;
    z_sum += sim.bodies()[0].x.z();
    force_sum += sim.bodies()[0].fluid_force.z();
    ++n;
  });
  out.exit_code = r.exit_code;
  const double dx = 0.01, area = 0.24 * 0.24, h = 0.06, rho = 1000;
  const double level = (particles * dx * dx * dx + mass / rho) / area;
  out.draft = n ? level - (z_sum / n - 0.5 * h) : 0.0;
  out.frame_end_force = n ? force_sum / n : 0.0;
  out.step_force = span > 0 ? impulse / span : 0.0;
  out.weight = mass * 9.81;
  INFO("water level " << level << " m, draft " << out.draft << " m (expected " << 0.5 * h << " m), mean fluid force "
                      << out.frame_end_force << " N at frame ends, " << out.step_force << " N over the steps, weight "
                      << out.weight << " N");
  return out;
}

}  // namespace sph::testing
