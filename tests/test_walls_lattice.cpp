// Closed walls on the particle lattice (core/model.cpp, snapWallsToLattice and the block fill).
// A block holds whole lattice cells, so in a tank whose size is not a whole number of particle
// spacings a block that fills it used to stop short of the far wall; the fluid fell into that gap
// as the run started. These tests check where the walls and the fluid are placed, and that a
// column at rest then stays where it was put.
#include "core/model.h"
#include "io/scene_loader.h"
#include "tests/scene_runs.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>

using namespace sph;

namespace {

// The hydrostatic tank (0.2 m x 0.06 m, water 0.2 m deep) at dx = 7.5 mm: 26.67 spacings across x.
SceneSpec tankAt(double dx) {
  SceneSpec s = io::loadScene(testing::scenePath("hydrostatic.yaml"), {"fluid.particle_spacing=" + std::to_string(dx)});
  return s;
}

float largest(const std::vector<Eigen::Vector3f>& pts, int axis) {
  float v = -1e30f;
  for (const Eigen::Vector3f& p : pts) v = std::max(v, p[axis]);
  return v;
}

}  // namespace

TEST_CASE("Closed walls are placed a whole number of particle spacings apart, and a block that fills the tank reaches them", "[walls][scene]") {
  const double dx = 0.0075;
  const Compiled c = compile(tankAt(dx));
  // x: 0.2 / 0.0075 = 26.67 spacings -> the wall at 27 dx = 0.2025 m (the nearest whole number);
  // y: 0.06 / 0.0075 = 8: unchanged; z: the open top: unchanged.
  CHECK(c.model.spec.domain.max.x() == Approx(27 * dx).margin(1e-12));
  CHECK(c.model.spec.domain.max.y() == 0.06);
  CHECK(c.model.spec.domain.max.z() == 0.3);
  // The block that reached the x wall reaches it still: 27 x 8 x 26 particles (26 layers up to
  // the free surface at 0.2 m: the top is open, a leftover there is harmless), the last layer dx/2
  // from the wall, like the first one from the wall at x = 0 (before: 26 layers, 5 mm = 0.67 dx
  // short of the wall).
  CHECK(c.initial.size() == 27u * 8u * 26u);
  std::vector<Eigen::Vector3f> pts;
  for (std::size_t i = 0; i < c.initial.size(); ++i) pts.push_back(c.initial.pos[i].head<3>());
  CHECK(largest(pts, 0) == Approx(27 * dx - 0.5 * dx).margin(1e-6));
  CHECK(largest(pts, 1) == Approx(0.06 - 0.5 * dx).margin(1e-6));
  // The change is said, with the domain's file:line and both positions.
  REQUIRE(c.model.warnings.size() == 1u);
  CHECK_THAT(c.model.warnings[0], Catch::Contains("hydrostatic.yaml:") && Catch::Contains("x = 0.2 m") &&
                                      Catch::Contains("0.2025 m (27 spacings)"));
  // At the scene's own spacing (20 spacings) nothing moves and nothing is said.
  const Compiled at_1cm = compile(tankAt(0.01));
  CHECK(at_1cm.model.spec.domain.max.x() == 0.2);
  CHECK(at_1cm.model.warnings.empty());
  CHECK(at_1cm.initial.size() == 20u * 6u * 20u);
}

TEST_CASE("A block that ends on a closed wall but starts inside the tank is laid from the wall", "[walls][scene]") {
  // The water fills x in [0.05, 0.2] (a dry strip along x = 0): 0.15 m = 20 dx at 7.5 mm, the tank
  // 27 dx after the wall moved, so the block now ends at 0.2025 m: 20.33 dx. Its lattice starts
  // from the wall (last layer dx/2 from it) and the leftover third of a spacing lies at its inner
  // face, over the dry strip, where the water is free to spread anyway.
  const double dx = 0.0075;
  SceneSpec s = tankAt(dx);
  s.fluid.blocks[0].min.x() = 0.05;
  const Compiled c = compile(s);
  std::vector<Eigen::Vector3f> pts;
  float smallest_x = 1e30f;
  for (std::size_t i = 0; i < c.initial.size(); ++i) {
    pts.push_back(c.initial.pos[i].head<3>());
    smallest_x = std::min(smallest_x, c.initial.pos[i].x());
  }
  CHECK(largest(pts, 0) == Approx(27 * dx - 0.5 * dx).margin(1e-6));
  CHECK(smallest_x >= 0.05f + 0.5f * static_cast<float>(dx));                 // inside the block
  CHECK(smallest_x == Approx(27 * dx - 19.5 * dx).margin(1e-6));              // 20 layers from the wall
  CHECK(c.initial.size() == 20u * 8u * 26u);
}

TEST_CASE("A column at rest in a tank that is not a whole number of spacings wide stays where it was put", "[walls][dfsph]") {
  // The hydrostatic tank at dx = 7.5 mm with DFSPH, gravity ramped in over 0.4 s, to 0.3 s. The
  // water is incompressible to the density bound (0.05 %: 0.05 mm of the column's 0.1 m centre
  // height); the cubic lattice's own settling, which begins after ~0.3 s, lowers the centre by
  // ~0.3 mm more (docs/dfsph.md). With the wall 0.67 dx beyond the last layer, the column would
  // fall to fill the gap: its centre by 0.0975 m x 0.67 / 26.67 = 2.4 mm.
  // Bound: 0.1 dx = 0.75 mm, between the two.
  // Measured: the centre falls 0.01 mm by 0.3 s (0.33 mm by 0.6 s, the lattice settling).
  // Mutation: without snapWallsToLattice it falls 2.5 mm by 0.3 s (2.7 mm by 0.6 s; WCSPH 2.8 mm):
  // fails.
  const double dx = 0.0075;
  double z0 = -1.0, z_end = 0.0;
  app::RunOptions o = testing::quietRun("hydrostatic.yaml", {"fluid.particle_spacing=0.0075", "fluid.solver=dfsph"});
  o.duration = 0.3;
  const app::RunResult r = app::runScene(o, [&](Simulation& sim, const FrameReport&) {
    const ParticleFrame f = sim.readFrame();
    double zs = 0.0;
    for (std::size_t p = 0; p < f.size(); ++p) zs += f.z[p];
    z_end = zs / static_cast<double>(f.size());
    if (z0 < 0.0) z0 = z_end;  // the first frame (0.05 s, g still 1.5 % of its value)
  });
  REQUIRE(r.exit_code == 0);
  INFO("centre of the column: " << z0 << " m at the first frame, " << z_end << " m at 0.3 s; fell "
                                << (z0 - z_end) * 1e3 << " mm");
  CHECK(std::abs(z0 - z_end) < 0.1 * dx);
}
