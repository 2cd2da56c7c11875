// Issue 14 (DFSPH): thin layers of water on a floor must not pass through it
// (scenes/tests/dfsph_floor.yaml; kernels/dfsph.cl, dfsph_wall_impulse).
#include "tests/scene_runs.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>

using namespace sph;

TEST_CASE("DFSPH extrapolated walls: a sheet one particle thick lands on a dry floor and stays above it", "[dfsph]") {
  // A sheet of 10 x 10 particles thrown at the floor at 1 m/s (it lands at ~1.4 m/s), then a
  // 3 x 3 x 3 block landing on the layer it leaves, 0.5 s. The sheet's support is cut (rho ~ 0.5
  // rho0 in flight, 0.8 rho0 on the floor), so the density solve gives it no pressure (p >= 0 acts
  // on compressions only): before the wall's non-penetration contact (dfsph_wall_impulse) the
  // sheet went through the floor on landing and the layer on the floor sank into it afterwards:
  // 447 wall crossings repaired in this run (WCSPH: 0). Checked, every frame:
  // - no wall crossing (a crossing is a particle the integrator put back: not physics);
  // - every particle centre at least the contact's gap, dx/4, above the floor to float rounding
  //   (1e-4 dx; core/dfsph.cpp, kWallGap: the first layer of a fluid at rest sits at dx/2);
  // - the contact adds no energy (it only removes approach velocity, an inelastic impact), and
  //   viscosity and the impacts dissipate: the total mechanical energy sum m (v^2/2 + g z) never
  //   exceeds its initial value (float sums over ~130 particles: 1e-4 relative margin);
  // and at the end the water lies on the floor, nothing bounced off it: no particle higher than 3 dx
  //   (an elastic bounce would send the sheet back to ~10 dx, its drop height plus v0^2 / 2g; the
  //   block's 27 particles over the layer's 100 pile up at most ~2 layers).
  // Measured: 0 crossings, lowest centre 0.25 dx, no energy gained, top particle at 0.72 dx (the
  // water spread into one layer), in ~0.3 s.
  // Mutation: the contact off (densitySolve without dfsph_wall_impulse): 447 crossings, the lowest
  // centre at the floor's plane (2e-4 dx): fails.
  const double dx = 0.01, g = 9.81;
  uint64_t crossings = 0;
  double lowest = 1.0, e0 = -1.0, worst_gain = -1e9;
  float top = 0.0f;
  std::size_t n0 = 0, n_end = 0;
  auto energy = [&](const ParticleFrame& f) {
    double e = 0.0;
    for (std::size_t p = 0; p < f.size(); ++p)
      e += 0.5 * (double(f.vx[p]) * f.vx[p] + double(f.vy[p]) * f.vy[p] + double(f.vz[p]) * f.vz[p]) + g * f.z[p];
    return e;
  };
  app::RunOptions o = testing::quietRun("dfsph_floor.yaml");
  const app::RunResult r = app::runScene(o, [&](Simulation& sim, const FrameReport& rep) {
    crossings += rep.wall_crossings;
    const ParticleFrame f = sim.readFrame();
    if (e0 < 0.0) {
      // the first frame's energy stands in for the start's, plus what the 0.02 s before could lose
      n0 = f.size();
      e0 = energy(f);
    }
    worst_gain = std::max(worst_gain, energy(f) / e0 - 1.0);
    for (std::size_t p = 0; p < f.size(); ++p) lowest = std::min(lowest, double(f.z[p]));
    top = 0.0f;
    for (std::size_t p = 0; p < f.size(); ++p) top = std::max(top, f.z[p]);
    n_end = f.size();
  });
  INFO(crossings << " wall crossings; lowest centre " << lowest / dx << " dx; energy gain at worst " << worst_gain
                 << " (relative, from the first frame); at the end the top particle at " << top / dx
                 << " dx; " << n0 << " -> " << n_end << " particles");
  REQUIRE(r.exit_code == 0);
  CHECK(n_end == n0);
  CHECK(crossings == 0);
  CHECK(lowest >= (0.25 - 1e-4) * dx);
  CHECK(worst_gain <= 1e-4);
  CHECK(top <= 3 * dx);
  // The contact is one pass per step, after the density solve, with the default walls only.
  CHECK(r.dispatch_counts.at("dfsph_wall_impulse") == r.profile.steps);
  WARN(crossings << " wall crossings; lowest centre " << lowest / dx << " dx; energy gain at worst " << worst_gain
                 << "; top " << top / dx << " dx");
}

TEST_CASE("DFSPH floor contact: only with extrapolated walls", "[dfsph]") {
  // Mirrored and single walls keep their own behaviour (tests/test_dfsph.cpp counts their wall
  // crossings): no dfsph_wall_impulse pass there.
  for (const char* walls : {"mirrored", "single"}) {
    app::RunOptions o = testing::quietRun("dfsph_floor.yaml", {std::string("fluid.dfsph.walls=") + walls});
    o.duration = 0.04;
    const app::RunResult r = app::runScene(o);
    INFO(walls);
    REQUIRE(r.exit_code == 0);
    CHECK(r.dispatch_counts.count("dfsph_wall_impulse") == 0);
  }
}
