// The settle before t = 0 (simulation.settle_time; Simulation::settle): a scene at rest starts at
// rest. A fluid block starts on a cubic lattice that is not stable under the water's weight (the
// bottom layers give way 0.2-0.6 s after the load is on: docs/dfsph.md, sessions 12 and 21), so a
// tank started from it rings (WCSPH) or bounces by kPa (DFSPH) long after t = 0. Checked against
// the closed form rho0 g (H - z) from the first sample on, against the same scene without the
// settle (which must fail the same checks), and against Archimedes for a body held through it.
#include "cli/runner.h"
#include "core/cl_context.h"
#include "core/model.h"
#include "core/simulation.h"
#include "io/scene_loader.h"
#include "core/rigid.h"
#include "tests/scene_issues.h"
#include "tests/scene_runs.h"
#include "tests/temp_dir.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

using namespace sph;

namespace {


/// The hydrostatic tank (scenes/tests/hydrostatic.yaml) with gravity on from the start (no ramp),
/// probed at every step (probes.rate 1000/s, above the step rate) from t = 0 to 0.5 s.
struct TankStart {
  std::size_t samples = 0;
  double first_time = 0;   // the first sample's time (unit: s)
  double worst = 0;        // worst |p / (rho0 g (H - z)) - 1| of the probes p02 .. p11 over every sample
  double worst_step = 0;   // largest change of one of those probes between consecutive samples (unit: Pa)
  double p_bottom = 0;     // rho0 g H (unit: Pa)
  Profile profile;
};

TankStart tankStart(const std::string& solver, double settle) {
  SceneSpec spec = io::loadScene(testing::scenePath("hydrostatic.yaml"),
                                 {"fluid.solver=" + solver, "simulation.gravity_ramp=0", "probes.rate=1000",
                                  "simulation.settle_time=" + std::to_string(settle)});
  Compiled c = compile(spec);
  ClContext cl;
  Simulation sim(c.model, c.initial, cl);
  // The probes p02, p05, p08, p11 (z = 0.02 .. 0.11 m, the deeper half of the 0.2 m column: more than
  // 2h under the surface, where the kernel is full), every step from t = 0 (the settle samples none)
  const std::vector<double> probe_z{0.02, 0.05, 0.08, 0.11};
  sim.recordProbeSamples(true);
  for (int frame = 0; frame < 10; ++frame) sim.advanceFrame();  // 0.5 s at 20 frames/s
  const std::vector<ProbeSample> samples = sim.takeProbeSamples();
  TankStart out;
  out.profile = sim.profile();
  out.samples = samples.size();
  out.first_time = samples.empty() ? NAN : samples.front().time;
  // The column's height from its particles at rest density (the tank 0.2 m x 0.06 m)
  const double rho0 = 1000, g = 9.81, dx = 0.01, area = 0.2 * 0.06;
  const double H = static_cast<double>(sim.numFluid()) * dx * dx * dx / area;
  out.p_bottom = rho0 * g * H;
  for (std::size_t s = 0; s < samples.size(); ++s)
    for (std::size_t k = 0; k < probe_z.size(); ++k) {
      const double p = samples[s].points[k].pressure, p_ref = rho0 * g * (H - probe_z[k]);
      out.worst = std::max(out.worst, std::isfinite(p) ? std::abs(p / p_ref - 1) : std::numeric_limits<double>::infinity());
      if (s > 0) out.worst_step = std::max(out.worst_step, std::abs(p - samples[s - 1].points[k].pressure));
    }
  return out;
}

}  // namespace

TEST_CASE("Settle: a DFSPH tank with gravity on from t = 0 starts at rest at its hydrostatic pressure", "[settle][dfsph]") {
  // The issue's band for the hydrostatic tank: the pressure within 5 % of rho0 g (H - z), here at every
  // step from t = 0 (not averaged after 1 s as the ramped tank tests do), and calm: a probe's change
  // between consecutive steps below 5 % of rho0 g H (the calm tank tests' bound, test_dfsph.cpp).
  // Without the settle the same run bounces from its first step (the lattice takes the load at once:
  // a probe 249 % off, 4.6 kPa between steps), and gives way again at 0.25-0.75 s (docs/dfsph.md,
  // session 22). Measured with the settle (1 s, damping 0.2 s): every probe within 1.5 %, 12.6 Pa
  // between steps (the bottom probe 1,762-1,790 Pa for 1,766 Pa).
  const TankStart s = tankStart("dfsph", 1.0);
  INFO("settled: " << s.samples << " samples, worst probe " << 100 * s.worst << " %, largest step-to-step change "
       << s.worst_step << " Pa (rho0 g H = " << s.p_bottom << " Pa), settle " << s.profile.settle_steps << " steps");
  CHECK(s.samples >= 100);
  CHECK(s.first_time == 0.0);
  CHECK(s.profile.settle_steps > 0);
  CHECK(s.worst <= 0.05);
  CHECK(s.worst_step < 0.05 * s.p_bottom);
  // the same scene from the lattice: fails both
  const TankStart u = tankStart("dfsph", 0.0);
  INFO("from the lattice: worst probe " << 100 * u.worst << " %, largest step-to-step change " << u.worst_step << " Pa");
  CHECK(u.profile.settle_steps == 0);
  CHECK(u.worst > 0.05);
  CHECK(u.worst_step > 0.05 * u.p_bottom);
  WARN("settle, DFSPH tank from t = 0: worst probe " << 100 * s.worst << " % (" << 100 * u.worst
       << " % without), step-to-step " << s.worst_step << " Pa (" << u.worst_step << " Pa without)");
}

TEST_CASE("Settle: a WCSPH tank with gravity on from t = 0 starts without its acoustic ringing", "[settle]") {
  // WCSPH answers the load coming on at t = 0 with an acoustic ringing (its lattice starts at rho0,
  // p = 0 everywhere; the bottom probe 0-3,331 Pa in the first 0.1 s, still +-40 Pa at 1 s); settled
  // first (1 s, damping 0.2 s) the column starts in its compressed hydrostatic state: measured over
  // 0-0.5 s every probe within 1.8 % of the closed form, 4.7 Pa between steps. The same bounds as the
  // DFSPH case above (with the settle's gravity ramped over its first half instead of its first
  // quarter, 1 s left the shallower probes drifting: -4.9 %).
  const TankStart s = tankStart("wcsph", 1.0);
  INFO("settled: " << s.samples << " samples, worst probe " << 100 * s.worst << " %, largest step-to-step change "
       << s.worst_step << " Pa (rho0 g H = " << s.p_bottom << " Pa)");
  CHECK(s.samples >= 100);
  CHECK(s.worst <= 0.05);
  CHECK(s.worst_step < 0.05 * s.p_bottom);
  const TankStart u = tankStart("wcsph", 0.0);
  INFO("from the lattice: worst probe " << 100 * u.worst << " %, largest step-to-step change " << u.worst_step << " Pa");
  CHECK(u.worst > 0.05);
  WARN("settle, WCSPH tank from t = 0: worst probe " << 100 * s.worst << " % (" << 100 * u.worst
       << " % without), step-to-step " << s.worst_step << " Pa (" << u.worst_step << " Pa without)");
}

TEST_CASE("Settle: a body is held through it, and released at t = 0 into water at rest it feels its Archimedes force",
          "[settle][rigid]") {
  // scenes/tests/floating_block.yaml: a 500 kg/m^3 block placed at its Archimedes draft (half its
  // height), free from t = 0. Through the settle it stays at its pose with zero velocity while the
  // water around it comes to rest; at t = 0 every fluid velocity is 0. From the first frame on the
  // fluid then carries the block's weight: within 5 % at every frame end over 0.5 s (the issue's
  // hydrostatic band; the draft is within 2 % of Archimedes' at this resolution, README, Rigid bodies).
  // Measured: within 0.74 % of 4.238 N. Without the settle the water rings from the lattice: up to 34 %
  // off in the first frames, which fails the same bound.
  struct Start {
    double worst = 0;             // worst |F_z / (m g) - 1| at the frame ends (unit: 1)
    double fluid_speed = 0;       // the fluid's largest speed at t = 0 (unit: m/s)
    double body_moved = 0;        // |x(0) - x_compiled| + |v(0)| of the body (m, m/s)
    double time = 0;              // simulated time after the settle (unit: s)
    uint64_t settle_steps = 0;
  };
  auto start = [](double settle) {
    SceneSpec spec = io::loadScene(testing::scenePath("floating_block.yaml"), {"simulation.settle_time=" + std::to_string(settle)});
    Compiled c = compile(spec);
    ClContext cl;
    Simulation sim(c.model, c.initial, cl);
    sim.settle();
    Start out;
    out.time = sim.time();
    out.settle_steps = sim.profile().settle_steps;
    const ParticleFrame f = sim.readFrame();
    for (std::size_t i = 0; i < f.size(); ++i)
      out.fluid_speed = std::max(out.fluid_speed, Eigen::Vector3d(f.vx[i], f.vy[i], f.vz[i]).norm());
    const rigid::RigidBody& body = sim.model().bodies[0];
    out.body_moved = (sim.bodies()[0].x - rigid::initialState(body).x).norm() + sim.bodies()[0].v.norm();
    const double weight = body.mass * 9.81;
    for (int frame = 0; frame < 15; ++frame) {  // 0.5 s at 30 frames/s
      sim.advanceFrame();
      out.worst = std::max(out.worst, std::abs(sim.bodies()[0].fluid_force.z() / weight - 1));
    }
    return out;
  };
  const Start s = start(0.5);
  INFO("settled: t = " << s.time << " s after " << s.settle_steps << " settle steps, fluid speed " << s.fluid_speed
       << " m/s, body moved " << s.body_moved << ", worst force " << 100 * s.worst << " % of the weight");
  CHECK(s.settle_steps > 0);
  CHECK(s.time == 0.0);
  CHECK(s.fluid_speed == 0.0);
  CHECK(s.body_moved == 0.0);
  CHECK(s.worst <= 0.05);
  const Start u = start(0.0);
  INFO("from the lattice: worst force " << 100 * u.worst << " % of the weight");
  CHECK(u.settle_steps == 0);
  CHECK(u.worst > 0.05);
  WARN("settle, floating block: worst fluid force " << 100 * s.worst << " % of the weight from t = 0 (" << 100 * u.worst
       << " % without)");
}

TEST_CASE("Settle: bad values and a settle with a gravity ramp are reported at file:line:col", "[settle]") {
  testing::TempDir dir;
  const std::string head = "domain: {min: [0, 0, 0], max: [0.1, 0.1, 0.1]}\nfluid:\n  particle_spacing: 0.02\n"
                           "  blocks: [{min: [0, 0, 0], max: [0.1, 0.1, 0.06]}]\nsimulation:\n";
  auto issues = testing::issuesOf(dir, head + "  settle_time: -1\n");
  INFO(testing::dump(issues));
  CHECK(testing::hasIssue(issues, 6, {"settle_time"}));
  issues = testing::issuesOf(dir, head + "  settle_time: .inf\n");
  CHECK(testing::hasIssue(issues, 6, {"settle_time"}));
  issues = testing::issuesOf(dir, head + "  settle_time: 0.5\n  settle_damping: 0\n");
  CHECK(testing::hasIssue(issues, 7, {"settle_damping"}));
  // both a settle and a gravity ramp: reported at the settle's key
  issues = testing::issuesOf(dir, head + "  gravity_ramp: 0.4\n  settle_time: 0.5\n");
  CHECK(testing::hasIssue(issues, 7, {"settle_time", "gravity_ramp"}));
  // a settle alone loads
  CHECK(testing::issuesOf(dir, head + "  settle_time: 0.5\n  settle_damping: 0.1\n").empty());
}
