// The three-balls check (scenes/tests/three_balls.yaml), shared by the WCSPH test (test_rigid.cpp)
// and the DFSPH one (test_dfsph.cpp): one scene, one criterion, any solver through --set overrides.
#pragma once

#include "cli/runner.h"
#include "core/model.h"
#include "core/rigid.h"
#include "tests/scene_runs.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <string>
#include <vector>

namespace sph::testing {

/// Balls of radius r = 2.5 cm and density 500, 1000, 4000 kg/m^3 dropped from 18 cm into water
/// 12 cm deep (dx = 1.5 cm, a coarse test). After 1.2 s: light above neutral above heavy; the light
/// one floats at the surface (its centre within r of the water level, 12 cm plus the ~0.6 cm the
/// submerged balls raise it); the heavy one lies on the floor with at most one particle layer under
/// it (bottom within 1.5 dx of the floor), carried by floor contact and fluid together (their sum
/// within 10 % of its weight: it has come to rest).
inline void checkThreeBallsOrder(const std::vector<std::string>& sets) {
  app::RunOptions o = quietRun("three_balls.yaml", sets);
  std::vector<rigid::BodyState> end;
  double heavy_weight = 0;
  const app::RunResult r = app::runScene(o, [&](Simulation& sim, const FrameReport&) {
    end = sim.bodies();
    heavy_weight = sim.model().bodies[2].mass * 9.81;
  });
  INFO(r.message);
  REQUIRE(r.exit_code == 0);
  REQUIRE(end.size() == 3);
  const double radius = 0.025, dx = 0.015, level = 0.12 + 0.006;
  INFO("centres z: light " << end[0].x.z() << ", neutral " << end[1].x.z() << ", heavy " << end[2].x.z()
                           << " m; heavy: fluid " << end[2].fluid_force.z() << " N + contact "
                           << end[2].contact_force.z() << " N, weight " << heavy_weight << " N");
  CHECK(end[0].x.z() > end[1].x.z());
  CHECK(end[1].x.z() > end[2].x.z());
  CHECK(std::abs(end[0].x.z() - level) < radius);
  CHECK(end[2].x.z() - radius < 1.5 * dx);
  CHECK(std::abs(end[2].fluid_force.z() + end[2].contact_force.z() - heavy_weight) < 0.1 * heavy_weight);
}

}  // namespace sph::testing
