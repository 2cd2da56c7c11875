// Forces on bodies in water (issue 15): transients against closed forms. Added mass of a released
// buoyant ball, buoyancy of a free body against the same body held, a buoyant block placed flush
// on the floor rising to its Archimedes draft, the Stokes drag and sideways force of a towed
// ball, a dense ball sinking from rest, and the Stokes terminal velocity of a falling ball. The
// checks themselves are in cli/force_checks.cpp (the `bench` force table runs them at more
// resolutions). Tolerances are derived next to each check; each check fails when the
// coupling force (kernels/rigid.cl, rigid_fluid_forces) is halved (docs/forces.md).
#include "cli/force_checks.h"
#include "cli/runner.h"
#include "core/model.h"
#include "io/scene_loader.h"
#include "tests/scene_issues.h"
#include "tests/scene_runs.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

using namespace sph;
using testing::scenePath;

namespace {

// The sinking-ball check of the tests below (R = 3 cm, the 20 cm tank): every step from 20 ms
// after the release inside the envelope of added mass (C_m 0.375 .. 0.725) and drag (C_d 0 ..
// app::sinkingDragBound at this dx), the hold's ringing as margin, and past 0.4 m/s at 0.2 s.
app::SinkCheck checkSinkingBall(const std::string& scene, double dx, const std::vector<std::string>& sets) {
  const double cd_hi = app::sinkingDragBound(0.03, dx, 0.2);
  const app::SinkCheck c = app::sinkingBall(scenePath(scene), dx, 0.02, 0.2, 0.375, 0.725, 0.0, cd_hi, sets);
  INFO(c.message);
  REQUIRE(c.exit_code == 0);
  INFO(scene << " at dx " << dx << ": v(" << c.window << " s) " << c.v_end << " m/s (closed form " << c.v_lo << " .. "
             << c.v_hi << ", ringing +-" << c.ringing << "), mean C_d " << c.cd_effective << "; " << c.worst
             << " m/s outside at " << c.worst_time << " s; above the fast side by " << c.above << " m/s; "
             << c.wall_seconds << " s");
  CHECK(c.v_end > 0.4);
  CHECK(c.worst == 0.0);
  CHECK(c.above <= 0.0);
  return c;
}

}  // namespace

TEST_CASE("Forces: a ball shaken in still water feels the added mass C_m = 1/2", "[forces]") {
  // A kinematic ball, radius 3 cm, in a tank settled before t = 0, at rest 0.05 s, then shaken along x,
  // x = x0 + A (1 - cos w t), A = 3 mm, 10 Hz, two periods (scenes/tests/accel_ball.yaml; inviscid). The
  // force needed is (m + C_m rho V) a; the fluid's part is F_x = -C_m rho V a, C_m = 1/2 in unbounded
  // fluid. The nearest wall (the floor, 8 cm from the centre) raises it: in a concentric sphere of that
  // radius C_m = 0.58 (Lamb 1932, art. 92), an upper bound for the box. F_x is fitted as -M a - B v at
  // the shaking's frequency (F, a and v projected on its cos and sin over the two periods: added mass
  // and drag separate; since session 34, when a least-squares fit on the per-step a read WCSPH's C_m ~4 %
  // low: the keyframed path's acceleration ripple, which the force does not follow, counted in sum a^2).
  // Both solvers with fluid.body_ambient_pressure: subtract (WCSPH's default; DFSPH's default is keep,
  // whose closure error reads here as a spurious drag B = 1.0-1.2 N s/m and, at R / dx = 3, 0.03 less C_m).
  // DFSPH, R / dx = 3 and 4: 10 % outside [0.5, 0.58] (the sampled surface at R / dx = 3 and the fit over
  // two periods). The scene bounds DFSPH's step by the pressure (fluid.dfsph.pressure_cfl 0.7): at R / dx
  // = 5 its column bounced at 5 ms steps and a third of the water left the tank (C_m -0.48). Measured
  // (session 34): 0.459 and 0.477, B 0.21 / 0.25 N s/m (at 5 ms steps 0.477 and 0.487; session 33, 0.3 s
  // at rest and the regression: 0.484 and 0.503).
  // WCSPH reads ~8 % under 1/2 in the settled tank: 0.460 at R / dx = 3 (B 0.34; the regression read
  // 0.442), at c0 = 30 m/s too (session 33: 0.437 by the regression): not the fluid's compressibility. Not
  // explained yet (not Adami's wall acceleration a_w, 11.8 m/s^2 here, which the body's wall pressure
  // leaves out: with it the plain sum read 0.418 by the regression; docs/forces.md, session 33). Its check
  // is the resolution's own: the fluid meets the
  // sampled surface within dx/2 of R, so C_m rho V lies between 1/2 rho V (1 - dx / 2R)^3 and the box's
  // value with (1 + dx / 2R)^3. Until session 33 the tank was not settled (gravity on at t = 0) and
  // A = 1 mm: the inviscid tank's ringing moved the fit by +-0.05, and WCSPH passed the 10 % band on it
  // (0.476 at R / dx = 3 with `keep`, 0.442 with `subtract`). Until session 34 the settled tank was held
  // 0.3 s more before the shaking (0.05 s now: 84 -> 44 s for the three runs).
  // Both rules' spurious drag: `keep` fits B = 0.9-1.2 N s/m where potential flow has none, `subtract`
  // 0.2-0.3. Halving the coupling force (kernels/rigid.cl, rigid_fluid_forces) halves C_m (the body is
  // kinematic): 0.245, 0.242 and 0.250 (session 34), below every band.
  struct Run {
    const char* solver;
    double dx;
  };
  // WCSPH at R / dx = 3 only (its R / dx = 4 run, 0.450, takes ~100 s here: the bench's `added-mass` rows).
  for (const Run run : {Run{"dfsph", 0.01}, Run{"dfsph", 0.0075}, Run{"wcsph", 0.01}}) {
    const app::AccelCheck c = app::acceleratedBall(scenePath("accel_ball.yaml"), run.dx,
                                                   {std::string("fluid.solver=") + run.solver,
                                                    "fluid.body_ambient_pressure=subtract"});
    INFO(c.message);
    REQUIRE(c.exit_code == 0);
    const bool dfsph = std::string(run.solver) == "dfsph";
    const double surface = 0.5 * run.dx / c.radius;
    const double lo = dfsph ? 0.9 * c.cm_unbounded : c.cm_unbounded * std::pow(1.0 - surface, 3);
    const double hi = dfsph ? 1.1 * c.cm_confined : c.cm_confined * std::pow(1.0 + surface, 3);
    INFO(run.solver << " dx " << run.dx << " m (R/dx " << c.radius / run.dx << "): C_m " << c.cm << " (expected "
                    << c.cm_unbounded << " - " << c.cm_confined << ", checked " << lo << " - " << hi
                    << "), drag coefficient B " << c.damping << " N s/m, |a| up to " << c.accel << " m/s^2; "
                    << c.wall_seconds << " s");
    CHECK(c.cm > lo);
    CHECK(c.cm < hi);
  }
}

TEST_CASE("Forces: a free body at rest feels the fluid force it felt while held", "[forces]") {
  // A ball of the water's density (scenes/tests/release_ball.yaml) in a tank settled 0.5 s before t = 0
  // (simulation.settle_time): held 0.25 s, the fluid carries its weight (Archimedes); released, it stays
  // put, and the mean fluid force over its first 0.1 s free must equal the held one over the last 0.1 s
  // held. Tolerance: 8 % of the buoyancy for held against free and for held against rho g V, as before
  // (the sampled surface at R / dx = 3 and the tank's remaining slosh). Measured settled (session 33):
  // held 1.080 N = 0.984 rho g V, free 1.088 N. Until session 33 the tank was not settled: gravity came on at t = 0 and
  // the column rang at its quarter-wave period 4 H / c0 = 0.05 s, +-35 % of the force; two periods per
  // window left ~5 %, and the held force read 0.93 rho g V (`keep`) / 0.91 (`subtract`), which the
  // comments put down to the sampled volume. Settled it reads 0.99 with either rule (docs/forces.md,
  // sessions 32-33). Halving the coupling force halves both forces and fails the second check.
  const app::ReleaseCheck c =
      app::releasedBall(scenePath("release_ball.yaml"), 0.01, 1000.0, 0.1, {"simulation.settle_time=0.5"});
  INFO(c.message);
  REQUIRE(c.exit_code == 0);
  INFO("held " << c.held_force << " N, free " << c.free_force << " N, buoyancy " << c.buoyancy << " N, weight "
               << c.weight << " N, first acceleration " << c.a0 << " m/s^2");
  CHECK(std::abs(c.free_force - c.held_force) < 0.08 * c.buoyancy);
  CHECK(std::abs(c.held_force - c.buoyancy) < 0.08 * c.buoyancy);
}

TEST_CASE("Forces: a buoyant block placed flush on the floor is lifted to a gap of dx, rises and floats at its draft",
          "[forces]") {
  // scenes/tests/rising_block.yaml: the Archimedes block (12 x 12 x 6 cm, 500 kg/m^3) with its
  // underside on the floor. Compile moves it up by dx (a note says so), so one layer of fluid
  // lies beneath; it must then rise and float at the Archimedes draft, half its height, with the
  // tolerance of the Archimedes test (5 %, test_rigid.cpp), over the last 0.3 s (it has settled
  // by 0.5 s; the heave is gone to under 0.1 mm). Before this, flush on the floor it never rose.
  // Halving the coupling force halves its buoyancy: it floats 4.5 cm deep (measured), outside.
  app::RunOptions o = testing::quietRun("rising_block.yaml");
  double z_sum = 0, z_min = 1e9, z_first = -1;
  int n = 0;
  std::size_t particles = 0;
  double mass = 0;
  std::vector<std::string> notes;
  const app::RunResult r = app::runScene(o, [&](Simulation& sim, const FrameReport&) {
    if (z_first < 0) {
      z_first = sim.model().bodies[0].spec.position.z();
      notes = sim.model().notes;
    }
    particles = sim.numFluid();
    mass = sim.model().bodies[0].mass;
    z_min = std::min(z_min, sim.bodies()[0].x.z());
    if (sim.time() < 0.6 - 1e-9) return;
    z_sum += sim.bodies()[0].x.z();
    ++n;
  });
  REQUIRE(r.exit_code == 0);
  const double dx = 0.01, area = 0.24 * 0.24, h = 0.06, rho = 1000;
  bool noted = false;
  for (const std::string& s : notes) noted = noted || s.find("rigid body 'block' lay closer than one spacing") != std::string::npos;
  CHECK(noted);
  CHECK(z_first == Approx(0.03 + dx).margin(1e-9));  // moved up by exactly the missing gap
  const double level = (particles * dx * dx * dx + mass / rho) / area;
  const double draft = level - (z_sum / n - 0.5 * h);
  INFO("start z " << z_first << " m, lowest " << z_min << " m, water level " << level << " m, draft " << draft
                  << " m (expected " << 0.5 * h << " m)");
  CHECK(std::abs(draft - 0.5 * h) < 0.05 * 0.5 * h);
}

TEST_CASE("Forces: the Stokes drag of a towed ball matches 6 pi mu R U with the box's wall factor", "[forces]") {
  // scenes/tests/stokes_tow.yaml: a ball, R = 3 cm, towed at U = 1 cm/s through a closed 20 cm
  // box of liquid of nu = 0.05 m^2/s (Re = 0.012), laminar viscosity, no-slip ghost velocities at
  // the body and the walls (fluid.boundary_velocity: auto; Adami, Hu & Adams 2012 eq. 22-23).
  // Closed form: F = 6 pi mu R U K, K the wall factor of the box, bracketed by Haberman & Sayre's
  // (1958) sphere in a concentric sphere of the box's volume (K = 2.04) and the one inscribed in
  // it (2.57). Resolution: the no-slip surface of a ball sampled at R / dx = 3 lies within dx/2
  // of R (its particles dx/2 inside, the fluid's first layer dx/2 outside), so the expected drag
  // / 6 pi mu R U is (R_eff / R) K(R_eff) with R_eff in R -+ dx/2: 1.47 .. 3.75 at R / dx = 3
  // (TowCheck::expected_lo/hi). Measured: 1.53 (0.88 before issue 15's ghost velocities, wall
  // pressure and c0; 1.24 with fluid.boundary_velocity: wall, below the band: the test sees the
  // no-slip condition). Halving the coupling force gives 0.77: below. The sideways force is reported, not tested here
  // (the sphere's surface sampling: 0-14 % of the drag, docs/forces.md).
  const app::TowCheck c = app::towedBall(scenePath("stokes_tow.yaml"), 0.01);
  INFO(c.message);
  REQUIRE(c.exit_code == 0);
  INFO("R/dx " << c.radius / c.dx << ", Re " << c.reynolds << ": drag " << c.drag << " N = " << c.drag / c.stokes
               << " x 6 pi mu R U (expected " << c.expected_lo << " .. " << c.expected_hi << "; K " << c.wall_factor_lo
               << " .. " << c.wall_factor_hi << " at R), sideways " << c.side << " N +- " << c.side_noise << "; "
               << c.wall_seconds << " s");
  CHECK(c.drag / c.stokes > c.expected_lo);
  CHECK(c.drag / c.stokes < c.expected_hi);
}

TEST_CASE("Forces: with a background pressure the towed ball's Stokes drag in a closed box does not depend on it",
          "[forces]") {
  // The Stokes tow above (scenes/tests/stokes_tow.yaml, R / dx = 3) with the box's top closed, so the fluid
  // has no free surface, and fluid.background_pressure (Morris, Fox & Zhu 1997) of 1 and 3 kPa. In exact
  // physics a uniform pressure changes no force on the ball. SPH's symmetric pressure force is unstable
  // under tension, and at zero ambient pressure the suction behind the ball (the flow's pressure scale
  // 3/2 mu U / R = 25 Pa) is tension: there the drag reads 1.32 x 6 pi mu R U, below the resolution's band
  // (the open-top box's 1.51 and WCSPH's rise with the hydrostatic load: docs/forces.md, session 35).
  // Checked: both runs inside the resolution's band (as the test above), and equal within 5 % of each
  // other (the spread of the loaded tows over R / dx 3 - 4.5, 2.05-2.13, docs/forces.md). Measured
  // (session 35): 2.065 and 2.110, inside the bracket at R itself (2.04 - 2.57). Mutation: with the
  // background pressure 0 the first run reads 1.317 and fails the band.
  double drag[2] = {0, 0};
  const double pressures[2] = {1000.0, 3000.0};
  for (int k = 0; k < 2; ++k) {
    const app::TowCheck c =
        app::towedBall(scenePath("stokes_tow.yaml"), 0.01,
                       {"domain.closed.z_max=true", "fluid.background_pressure=" + std::to_string(pressures[k])});
    INFO(c.message);
    REQUIRE(c.exit_code == 0);
    drag[k] = c.drag / c.stokes;
    INFO("background " << pressures[k] << " Pa: drag " << drag[k] << " x 6 pi mu R U (expected " << c.expected_lo
                       << " .. " << c.expected_hi << "; K " << c.wall_factor_lo << " .. " << c.wall_factor_hi
                       << " at R); " << c.wall_seconds << " s");
    CHECK(drag[k] > c.expected_lo);
    CHECK(drag[k] < c.expected_hi);
  }
  INFO("1 kPa: " << drag[0] << ", 3 kPa: " << drag[1]);
  CHECK(std::abs(drag[1] - drag[0]) < 0.05 * drag[0]);
}

TEST_CASE("fluid.background_pressure: negative, with DFSPH or with an open wall is reported at file:line:col",
          "[forces]") {
  testing::TempDir dir;
  const std::string head = "domain: {min: [0, 0, 0], max: [0.1, 0.1, 0.1]}\nfluid:\n  particle_spacing: 0.02\n"
                           "  blocks: [{min: [0, 0, 0], max: [0.1, 0.1, 0.1]}]\n";
  auto issues = testing::issuesOf(dir, head + "  background_pressure: -5\n");
  INFO(testing::dump(issues));
  CHECK(testing::hasIssue(issues, 5, {"background_pressure"}));
  // the default domain's top is open
  issues = testing::issuesOf(dir, head + "  background_pressure: 1000\n");
  CHECK(testing::hasIssue(issues, 5, {"background_pressure", "closed", "z_max"}));
  const std::string closed = "domain: {min: [0, 0, 0], max: [0.1, 0.1, 0.1], closed: {z_max: true}}\nfluid:\n"
                             "  particle_spacing: 0.02\n  blocks: [{min: [0, 0, 0], max: [0.1, 0.1, 0.1]}]\n";
  issues = testing::issuesOf(dir, closed + "  solver: dfsph\n  background_pressure: 1000\n");
  CHECK(testing::hasIssue(issues, 6, {"background_pressure", "wcsph"}));
  CHECK(testing::issuesOf(dir, closed + "  background_pressure: 1000\n").empty());
  // 0 (the default) is fine anywhere
  CHECK(testing::issuesOf(dir, head + "  solver: dfsph\n  background_pressure: 0\n").empty());
  CHECK(io::loadScene(dir.write("d.yaml", head).string()).fluid.background_pressure == 0.0);
}

TEST_CASE("Forces: a buoyant ball released from rest mid-water accelerates with the added mass C_m = 1/2", "[forces]") {
  // scenes/tests/release_ball.yaml: a 500 kg/m^3 ball (R = 3 cm = 3 dx) held 0.25 s mid-water,
  // then released, and the same run with the ball held throughout. In a fluid at rest it would
  // start at a0 = (rho_w - rho_b) g / (rho_b + rho_w / 2) = 4.9 m/s^2. A single run showed a
  // ~0.02 s stall, then ~5.4 m/s^2. The cause is the tank's ringing (the water column's
  // quarter-wave mode, 4 H / c0 = 0.05 s, still +-40 % of the buoyancy at 0.25 s, weakly damped):
  // the release fell on a downswing of the buoyancy (the held force averages 0.73 rho g V over the
  // first 10 ms after 0.25 s, 0.62 over 20 ms, against the ball's weight 0.5). Not the release
  // itself: the free and held runs are bitwise equal up to it, the first free step feels the held
  // force (a = 10 m/s^2: the fluid has not answered yet), and within ~R/c0 = 2 ms the added mass
  // builds up, the ball then oscillating on the liquid's compressibility at a ~4 ms period.
  // So the test compares with the held run, in momentum form over T = 10 ms (5 R/c0; v < 2.5 cm/s,
  // drag negligible): C_m = -int (F_free - F_held) dt / (rho V v(T)), expected 1/2 .. 0.58 (Lamb's
  // concentric sphere at the nearest boundary, the free surface 10 cm above), with 25 % (R / dx =
  // 3; the shaken ball's tolerance before session 7: this check's 10 ms window is shorter than a
  // period of the tank's ringing, so it keeps it). Measured 0.56 (0.59 with the body contact range dx, before issue
  // 15's fix; over 20-50 ms it grows, the drag of alpha = 0.1 then counting). The mean acceleration v(T) / T then equals (mean F_held - m g) /
  // (m + C_m rho V) (momentum): reported, the same check in the issue's terms. Halving the
  // coupling force: the held force falls below the weight and the ball does not rise.
  const app::ReleaseMassCheck c = app::releasedBallAddedMass(scenePath("release_ball.yaml"), 0.01, 500.0, 0.01);
  INFO(c.message);
  REQUIRE(c.exit_code == 0);
  INFO("R/dx " << c.radius / c.dx << ": C_m " << c.cm << " (expected 0.5 .. " << c.cm_confined << "); a0 " << c.a0
               << " m/s^2 (expected from the held force " << c.a0_expected_lo << " .. " << c.a0_expected_hi
               << ", in still water " << c.a0_still << "); held force " << c.held_over_buoyancy << " rho g V; "
               << c.wall_seconds << " s");
  CHECK(c.cm > 0.75 * 0.5);
  CHECK(c.cm < 1.25 * c.cm_confined);
}

TEST_CASE("Forces: a buoyant ball released one spacing above the floor accelerates with the wall's added mass", "[forces]") {
  // As the mid-water test, with the ball's underside one spacing dx above the floor (centre at
  // h = 4 cm = 1.33 R). Near a wall the added mass for motion normal to it grows: the method of
  // images (app::sphereWallAddedMass; Milne-Thomson's doublet image in a sphere) gives C_m = 1/2
  // (1 + 3/8 (R/h)^3 + 3/64 (R/h)^6 + ...) = 0.586 here (0.579 to leading order, 0.803 at contact).
  // Resolution: the gap h - R is known to dx/2 (the sampled ball's surface within R -+ dx/2, as the
  // Stokes checks; the floor's at its wall), so C_m(h + dx/2) .. C_m(h - dx/2) = 0.559 .. 0.639,
  // and 10 % beyond (the shaken ball's: the sampled ball's displaced volume is known to ~7 % at
  // R / dx = 3). Measured 0.594 (session 7). At R / dx = 4 (bench) 0.693 against 0.578 .. 0.660:
  // 5 % over, inside the 10 %. Why it is above the centre value and grows with resolution (docs/forces.md): not the artificial viscosity's squeeze film (laminar water gives 0.75 at
  // R / dx = 4, measured), but the 10 ms window: the estimate moves with it (0.59, 0.69, 0.78,
  // 0.84 over 5, 10, 15, 20 ms at R / dx = 4 with alpha = 0.1; laminar 0.64, 0.75, 0.53, 0.55 as
  // the ball rings on the liquid's compressibility).
  // Halving the coupling force: the ball does not rise.
  const app::ReleaseMassCheck c = app::releasedBallAddedMass(scenePath("release_ball.yaml"), 0.01, 500.0, 0.01,
                                                             {"rigid_bodies[0].position=[0.1, 0.1, 0.04]"});
  INFO(c.message);
  REQUIRE(c.exit_code == 0);
  INFO("R/dx " << c.radius / c.dx << ": C_m " << c.cm << " (images " << c.cm_floor << ", gap -+ dx/2: " << c.cm_floor_lo
               << " .. " << c.cm_floor_hi << "); a0 " << c.a0 << " m/s^2 (expected from the held force "
               << c.a0_expected_lo << " .. " << c.a0_expected_hi << "); held force " << c.held_over_buoyancy
               << " rho g V; " << c.wall_seconds << " s");
  CHECK(c.cm > 0.9 * c.cm_floor_lo);
  CHECK(c.cm < 1.1 * c.cm_floor_hi);
}

TEST_CASE("Forces: a released buoyant ball rises and floats at its Archimedes draft with a damped heave", "[forces]") {
  // release_ball.yaml (500 kg/m^3 ball, R = 3 cm = 3 dx, released mid-water at 0.25 s) run to
  // 1.5 s: it rises, overshoots the surface and heaves about its float position.
  //  - Draft: half its density, so half submerged: its centre at the water level, the level being
  //    the fluid's volume at rest density plus the ball's displaced volume m / rho over the floor
  //    area (as the flush block's test). Tolerance dx/2: where a free surface lies is known to
  //    about half a spacing. Measured: 1.3 mm below.
  //  - Damped: each crest lower than the one before. Measured 14.2 then 3.5 mm above the mean.
  //  - Period: k = rho g pi R^2 (waterplane), m + a33 with a33 between 0.38 and 0.83 of the
  //    displaced mass rho V / 2 over all frequencies (Hulme 1982, the floating hemisphere), so
  //    T0 = 2 pi sqrt((m + a33) / k) = 0.333 .. 0.384 s; the waterplane radius is known to dx/2
  //    (R^2 to +-33 %, T to +-17 %). The measured crest-to-crest period is corrected for its
  //    damping, T0 = T sqrt(1 - zeta^2), zeta from the logarithmic decrement. Measured 0.36 s,
  //    zeta 0.22, T0 = 0.351 s.
  // Halving the coupling force halves the buoyancy: the ball no longer rises to the surface.
  const app::HeaveCheck c = app::floatingBallHeave(scenePath("release_ball.yaml"), 0.01, 1.5);
  INFO(c.message);
  REQUIRE(c.exit_code == 0);
  INFO("R/dx " << c.radius / c.dx << ": level " << c.level << " m, mean z over the last 0.2 s " << c.mean << " m; "
               << c.crests << " crests, the first two " << c.crest1 * 1000 << ", " << c.crest2 * 1000
               << " mm above the mean");
  CHECK(std::abs(c.offset) < 0.5 * c.dx);
  REQUIRE(c.crests >= 2);
  CHECK(c.crest2 < c.crest1);
  INFO("period " << c.period << " s, zeta " << c.zeta << ", undamped " << c.period_undamped << " s; expected "
                 << c.period_lo << " .. " << c.period_hi << " s, +-17 %; " << c.wall_seconds << " s");
  CHECK(c.period_undamped > c.period_lo / 1.17);
  CHECK(c.period_undamped < c.period_hi * 1.17);
}

TEST_CASE("Forces: a dense ball sinking from rest follows added mass and a sphere's drag in its tank", "[forces]") {
  // scenes/tests/sink_ball.yaml: a 2000 kg/m^3 ball (R = 3 cm = 3 dx) held 0.25 s 5 cm under the
  // surface of water (laminar, nu = 1e-6 m^2/s) in a 20 cm square tank, released, 0.2 s free.
  // Closed form: (m + C_m rho V) dv/dt = (m - rho V) g - 1/2 rho C_d pi R^2 v^2,
  // v(t) = v_t tanh(a0 t / v_t).
  //  - C_m: 1/2 .. 0.58 (as the released buoyant ball) with the added-mass tests' 25 % at
  //    R / dx = 3: 0.375 .. 0.725.
  //  - C_d: a sphere's steady drag at Re = 2 R v / nu ~ 1e4 is 0.4 .. 0.5; started from rest, its
  //    wake takes several diameters of travel to form (it travels ~1.5 D here), so its mean is
  //    lower: from 0. Upper end (app::sinkingDragBound): 0.5 x (1 + dx / 2R)^2 (the sampled
  //    surface within dx/2 of R; form drag goes with the frontal area) x 1.43 (the tank: Munroe's
  //    wall factor 1 / (1 - (d/D)^1.5)^2 for d / D = 0.3) = 0.97 at R / dx = 3.
  // Envelope: slowest with (0.725, 0.97), fastest with (0.375, 0); margin: the tank's ringing
  // measured over the hold (SinkCheck::ringing). Every step from 20 ms to the end (0.2 s) must lie
  // inside it, and v(0.2 s) > 0.4 m/s (the issue: a dense block settled at 0.20-0.27 m/s).
  // Before issue 15's contact range (the fluid-body contact within dx of a body particle, now
  // dx/2: shared/pair_loops.h) the ball's mean C_d was 3.9 and v(0.2 s) 0.44 m/s, below this
  // envelope from ~50 ms on (measured; docs/forces.md). Measured now: v(0.2 s) 0.61 in
  // 0.60 .. 0.83 m/s, mean C_d 1.14 (from momentum with C_m = 1/2), ringing margin 0.057 m/s.
  // This scene switches gravity on at t = 0 and the laminar water still rings at the release
  // (+-40 % of rho g d at the ball's depth over the hold's last 0.1 s). Released into a tank at
  // rest (sink_ball_rest.yaml: gravity ramped in over 0.4 s, held to 0.6 s; session 12) the same
  // ball reads 0.572 m/s (0.551 held to 0.7 s), 0.026 m/s below this envelope's slow side beyond
  // its ringing margin there (0.008 m/s), mean C_d 1.65: this check passes at R / dx = 3 on the
  // start-up's ringing; at rest it passes at R / dx = 4 (0.644 in 0.603 .. 0.825; bench
  // `--force-checks sink-rest`, docs/forces.md). Not loosened; the scene is the lead's call.
  // Halving the coupling force: a0 = (m - rho V / 2) g / (m + C_m rho V / 2), 1.7 x faster, and half
  // the drag: above the envelope.
  const double dx = 0.01, radius = 0.03, tank = 0.2;
  const double cd_hi = app::sinkingDragBound(radius, dx, tank);
  const app::SinkCheck c = app::sinkingBall(scenePath("sink_ball.yaml"), dx, 0.02, 0.2, 0.375, 0.725, 0.0, cd_hi);
  INFO(c.message);
  REQUIRE(c.exit_code == 0);
  for (std::size_t k = 0; k < c.t.size(); k += 20)
    UNSCOPED_INFO("t " << c.t[k] << " s: v " << c.v[k] << " m/s in " << c.lo[k] << " .. " << c.hi[k]);
  INFO("v(" << c.window << " s) " << c.v_end << " m/s (closed form " << c.v_lo << " .. " << c.v_hi << " with C_d 0 .. "
            << cd_hi << ", ringing +-" << c.ringing << "), Re " << c.reynolds << ", mean C_d " << c.cd_effective
            << "; " << c.worst << " m/s outside at " << c.worst_time << " s; above the fast side by " << c.above
            << " m/s; " << c.wall_seconds << " s");
  CHECK(c.v_end > 0.4);
  CHECK(c.worst == 0.0);
  CHECK(c.above <= 0.0);
}

TEST_CASE("Forces: a dense ball falls through a viscous liquid at the Stokes terminal velocity with the box's wall factor",
          "[forces]") {
  // scenes/tests/stokes_fall.yaml: a 2000 kg/m^3 ball, R = 3 cm = 3 dx, in the towed ball's closed
  // 20 cm box of liquid (nu = 0.05 m^2/s), held 0.25 s, then falling 0.3 s. Terminal velocity
  // U = (m - rho V) g / (6 pi mu R K) (Stokes; Re ~ 0.02), so (m - rho V) g / (6 pi mu R U) = K is
  // the towed ball's quantity, with its band: the box's wall factor bracketed by Haberman & Sayre's
  // (1958) two spherical containers, the no-slip surface within R -+ dx/2: 1.47 .. 3.75 at R / dx = 3.
  // Averaged over the last 0.15 s (the speed is steady within ~50 ms of the release). Measured
  // 2.07 (2.19 with the body contact range dx, before issue 15's fix). The sampled ball's
  // buoyancy (the held force, 0.92 rho g V at R / dx = 3) is reported with the drag it implies (2.22).
  // Halving the coupling force halves the drag and the buoyancy: U more than doubles.
  const app::FallCheck c = app::fallingBall(scenePath("stokes_fall.yaml"), 0.01);
  INFO(c.message);
  REQUIRE(c.exit_code == 0);
  INFO("R/dx " << c.radius / c.dx << ": U " << c.speed << " m/s (unbounded Stokes " << c.speed_stokes << "), Re "
               << c.reynolds << ", (m - rho V) g / 6 pi mu R U = " << c.ratio << " (expected " << c.expected_lo
               << " .. " << c.expected_hi << "); with the held force as buoyancy (" << c.held_over_buoyancy
               << " rho g V) " << c.ratio_held << "; sideways " << c.side << " m/s; " << c.wall_seconds << " s");
  CHECK(c.ratio > c.expected_lo);
  CHECK(c.ratio < c.expected_hi);
}

TEST_CASE("Forces with DFSPH and extrapolated walls: a free body feels its held force", "[forces]") {
  // The WCSPH checks above with `fluid.solver: dfsph`, `fluid.dfsph.walls: extrapolated` (the
  // wall's pressure extrapolated from the fluid, Adami et al. 2012 eq. 27, as WCSPH's walls; the
  // viscous terms see the walls' own velocities and, since session 10, the no-slip ghost velocities
  // at a moving body whose term is laminar, sink_ball.yaml's: `boundary_velocity: auto` with
  // DFSPH), R / dx = 3, with the same closed forms and tolerances:
  //  - the neutral ball of release_ball.yaml: held force against rho g V and free against held,
  //    8 % (measured 0.95 and 1.03);
  //  - (until session 41; now the next tests' at rest) the dense ball of sink_ball.yaml: every step inside the envelope of added mass (C_m 0.375 ..
  //    0.725) and drag (C_d 0 .. 0.97) with the hold's ringing as margin, past 0.4 m/s at 0.2 s
  //    (measured 0.582 m/s against 0.589 .. 0.812, inside the margin; mean C_d 1.41; before
  //    session 10's ghost velocities at the body, 0.573 m/s and 1.6; session 12's default
  //    coarse_rest_start 1: 0.558 m/s, ringing margin 0.32 m/s, where plain Jacobi converged to
  //    1e-5 reads 0.571: the release meets the column's start-up bounce, docs/dfsph.md session 12).
  //    On main at 2929065: 0.537 m/s, ringing margin 0.31 m/s (bench row sink_speed_0.2s_mps).
  //    Released into a tank at rest instead (sink_ball_rest.yaml, session 12: the held force
  //    0.96 rho g V over the hold's last 0.1 s where this scene's column is in free flight, 0.52;
  //    ringing margin 0.024 m/s against 0.31) the ball reads 0.556 m/s (0.539 held to 0.7 s),
  //    0.029 m/s outside the envelope's slow side: this check passes at R / dx = 3 on its margin
  //    (docs/forces.md). With session 12's default fictitious mass (body_added_mass 0.5, main at
  //    d196c81): 0.546 m/s here, 0.535 at rest. Not loosened; the scene is the lead's call.
  //    Session 26 (the strong body coupling the default; the scene bounds DFSPH's step by the
  //    pressure, pressure_cfl 0.7, after its start-up blew up at 0.105 s with it): 0.595 m/s in
  //    0.591 .. 0.816, inside without the margin, mean C_d 1.36; held 1.03 N, free 1.09 N.
  // The Stokes drag with DFSPH and the released buoyant ball's added mass (which needs the
  // fictitious mass fluid.dfsph.body_added_mass, session 11): the next tests.
  // Halving the coupling force halves the held force (0.52 N against rho g V = 1.10 N; measured): fails
  // the held check. (It also sped the sinking ball, checked here until session 41, above its envelope.)
  const std::vector<std::string> dfsph = {"fluid.solver=dfsph", "fluid.dfsph.walls=extrapolated"};
  // The neutral ball in the tank settled 0.5 s before t = 0, as the WCSPH test (session 33): held 1.072 N =
  // 0.978 rho g V, free 1.092 N (the 0.95 / 1.03 above were the ringing tank's).
  std::vector<std::string> calm = dfsph;
  calm.push_back("simulation.settle_time=0.5");
  const app::ReleaseCheck r = app::releasedBall(scenePath("release_ball.yaml"), 0.01, 1000.0, 0.1, calm);
  INFO(r.message);
  REQUIRE(r.exit_code == 0);
  INFO("held " << r.held_force << " N, free " << r.free_force << " N, buoyancy " << r.buoyancy << " N");
  CHECK(std::abs(r.free_force - r.held_force) < 0.08 * r.buoyancy);
  CHECK(std::abs(r.held_force - r.buoyancy) < 0.08 * r.buoyancy);
  // The dense ball of sink_ball.yaml (the start-up's ringing tank) was checked here until session 41; the
  // same ball released into a tank at rest, with DFSPH at R / dx = 3 and 4, is the next tests' and
  // checks the same envelope without the start-up's margin (this run: ~10 s of the suite's time).
}

TEST_CASE("Forces: a dense ball released into a tank at rest sinks as added mass and a sphere's drag allow, without the "
          "ambient pressure's drag (R/dx 3)",
          "[forces]") {
  // scenes/tests/sink_ball_rest.yaml (gravity ramped in over 0.4 s, the ball held to 0.6 s, then 0.2 s
  // free) at dx = 1 cm, R / dx = 3, WCSPH: the envelope of the sinking-ball test above, every step from
  // 20 ms after the release inside it. A real sphere (C_m 1/2, C_d 0.45 x Munroe's 1.43 for the tank)
  // reaches ~0.67 m/s at 0.2 s. Until session 32 the ball fell below the envelope's slow side here (0.572
  // m/s against 0.596; it passed only on sink_ball.yaml's start-up): its pressure force summed over its
  // sampled surface took the ambient pressure (~800 Pa at its depth) times the surface's closure error,
  // which the fluid crowding in front of the moving ball makes a drag. fluid.body_ambient_pressure:
  // subtract takes that out (kernels/rigid.cl, rigid_reduce; docs/forces.md, session 32; opt-in then, the
  // default since session 33; named here so that the test keeps its meaning).
  // Measured: v(0.2 s) 0.685 m/s in 0.596 .. 0.825. Mutation: `keep` (the plain pair sum): 0.572,
  // below the slow side: fails.
  const app::SinkCheck c = checkSinkingBall("sink_ball_rest.yaml", 0.01, {"fluid.body_ambient_pressure=subtract"});
  WARN("WCSPH R/dx 3 at rest: v(0.2 s) " << c.v_end << " m/s in " << c.v_lo << " .. " << c.v_hi << "; " << c.worst
                                         << " outside; " << c.wall_seconds << " s");
}

TEST_CASE("Forces with DFSPH: a dense ball released into a tank at rest sinks as added mass and a sphere's drag allow, "
          "without the ambient pressure's drag (R/dx 3)",
          "[forces]") {
  // The WCSPH test above with `fluid.solver: dfsph` (its defaults: extrapolated walls, the strong body
  // coupling). DFSPH's sampled surface has the same closure error while the ball sinks (G_z +1.5e-4 ..
  // +5.2e-4 N/Pa, session 32); since session 33 fluid.body_ambient_pressure subtract corrects the force the
  // body is integrated with (its motion inside the solves keeps the plain sum; docs/forces.md, session 33).
  // Measured (this check): v(0.2 s) 0.648 m/s in 0.589 .. 0.812. Mutation, run: `keep` reads 0.582, 0.036 m/s
  // below the slow side: fails. (`sphaptics run` of the scene itself: 0.664 / 0.590; 28 cm deep 0.617 /
  // 0.514.)
  const app::SinkCheck c =
      checkSinkingBall("sink_ball_rest.yaml", 0.01, {"fluid.solver=dfsph", "fluid.body_ambient_pressure=subtract"});
  WARN("DFSPH R/dx 3 at rest: v(0.2 s) " << c.v_end << " m/s in " << c.v_lo << " .. " << c.v_hi << "; " << c.worst
                                         << " outside; " << c.wall_seconds << " s");
}

TEST_CASE("Forces with DFSPH: a dense ball released into a tank at rest sinks as added mass and a sphere's drag allow (R/dx 4)",
          "[forces]") {
  // scenes/tests/sink_ball_rest.yaml (gravity ramped in over 0.4 s, the ball held to 0.6 s, then
  // 0.2 s free) at dx = 7.5 mm, R / dx = 4, DFSPH with its defaults: the closed form and envelope of
  // the sinking-ball test above (C_m 0.375 .. 0.725, C_d 0 .. app::sinkingDragBound at this dx, the
  // hold's ringing as margin), every step from 20 ms after the release inside it.
  // Why this scene and resolution: at R / dx = 3 the ball released into a tank at rest falls below
  // the envelope with both solvers (its drag is too high there; the R / dx = 3 tests above pass on
  // sink_ball.yaml's start-up; docs/forces.md, session 12). At R / dx = 4 the 20 cm tank was
  // 26.67 spacings and the water fell into a 5 mm gap at two walls as the run started; with the
  // walls on the lattice (session 13) the tank is at rest at the release and the ball inside.
  // Measured (bench, session 13): v(0.2 s) 0.617 m/s in 0.599 .. 0.817, 0 m/s outside, held-
  // subtracted mean C_d 0.85 (band top 0.91).
  // Session 50: that pass was the tank's noise. DFSPH's automatic body_ambient_pressure is `keep` (the
  // plain pair sum, session 33: the towed Stokes ball reads 4 % under its band with subtract), whose
  // closure error is a drag while the ball moves (the R / dx 3 tests above). In a calm tank (the pressure
  // step bound 0.8) `keep` read 0.596 m/s at 0.2 s against the slow side 0.599, and 0.599 with 1 ms
  // steps: the drag just past a sphere's, converged in the step; main's defaults then (cfl 0.4, no
  // pressure bound) read 0.629 on a tank whose particles still moved at ~0.2 m/s; cfl 0.8 without the
  // pressure bound 0.488 on a noisier one. So this test names `subtract`, as the R / dx 3 one does.
  // Measured (this check, session 50's defaults: cfl 0.8, pressure_cfl 0.5): v(0.2 s) 0.700 m/s in
  // 0.600 .. 0.820, 0 outside; 86 s wall here (the bound's shorter steps in this 28 cm tank).
  // Mutations (run): the pressure step bound off (pressure_cfl 0): 0.50 m/s, the tank noisy: fails; the
  // body's fluid force halved (core/simulation.cpp, the reduced sums; session 50): 1.165 m/s, 0.35 m/s above
  // the envelope's fast side: fails.
  const app::SinkCheck c = checkSinkingBall("sink_ball_rest.yaml", 0.0075,
                                            {"fluid.solver=dfsph", "fluid.body_ambient_pressure=subtract"});
  WARN("R/dx 4 at rest: v(0.2 s) " << c.v_end << " m/s in " << c.v_lo << " .. " << c.v_hi << "; " << c.worst
                                   << " outside; " << c.wall_seconds << " s");
}

TEST_CASE("Forces with DFSPH: a buoyant ball released from rest accelerates with the added mass, mid-water and above "
          "the floor",
          "[forces]") {
  // The two WCSPH release tests above with `fluid.solver: dfsph`, `fluid.dfsph.walls:
  // extrapolated`, R / dx = 3, the same check and tolerances: C_m = -int (F_free - F_held) dt /
  // (rho V v(T)) over T = 10 ms against 1/2 .. Lamb's 0.58 (25 %) mid-water and the method of
  // images' 0.559 .. 0.639 (10 %) one spacing above the floor; and the mean acceleration v(T) / T
  // against (mean F_held - m g) / (m + C_m rho V) over the same C_m range (the issue's a0).
  // DFSPH settings (session 11, measured):
  //  - fluid.dfsph.body_added_mass: 0.5 (the fictitious mass 1/2 rho V, Baek & Karniadakis 2012),
  //    needed: the solve answers the ball's last step's acceleration at once, so the staggered update
  //    reads a_n = (F0 - m_a a_{n-1}) / m; for this ball m_a (~0.8 rho V in one 3.3 ms step) exceeds
  //    m = 0.5 rho V and the free ball swings with period 2 steps, growing (+-6 rho g V within 6
  //    steps; C_m -0.18 here without it, 49 in the session-9 bench). Not the step length: at
  //    max_time_step 1 ms it swings the same way.
  //  - fluid.dfsph.coarse_interval: 4: at the default bound the plain Jacobi solve leaves the tank
  //    ringing (the held force swings 0.19 .. 1.86 rho g V, period ~20 ms, at 3.3 ms steps); the
  //    two-level solve calms it (0.93 .. 0.95 at 3.3 ms; +-40 % at 2 ms, like WCSPH's tank, which
  //    the held run takes out) and is cheaper.
  //  - fluid.dfsph.max_time_step: 0.002, 5 steps in the window: the ball's own acceleration lags
  //    the fluid's answer by about one step, so v(T) / T reads a larger C_m than the force does:
  //    0.63 / 0.47 at the default 3.3 ms (3 steps; a0 below its range), 0.59 / 0.50 at 2 ms, 0.54 /
  //    0.51 at 1 ms (converging; 1 ms costs twice as much).
  //  - the two-level solve's schedule of session 10 (coarse_start 1, coarse_rest_travel 0: a
  //    correction after iterations 1, 5, 9, ... of every solve). With session 11's default (one
  //    correction per step at rest) R/dx 3 reads C_m 0.538 / 0.607, but at R/dx 4 the held ball's
  //    tank rings at 2 ms steps (held force ~2 rho g V over the window) and C_m reads 0.640 mid-water,
  //    10 % above its band (bench).
  // Measured: mid-water C_m 0.528, a0 5.04 m/s^2 (4.95 .. 6.43); above the floor 0.564, a0 3.33
  // (3.18 .. 4.48) (before session 11's two-level changes, whose corrections are now always followed
  // by a checked iteration: 0.502, 0.569). Bench at R / dx = 4: 0.565 and 0.638 (inside), a0
  // mid-water 3.65 against 3.70 .. 4.81 (1.2 % below: the lag), floor 3.37 (3.33 .. 4.79).
  // Session 12: the fictitious force M (a_{n-1} - a_n) counts in the fluid force (so C_m here is the
  // one the ball moves with, the scheme's one-step lag included) and its reaction goes to the fluid;
  // body_added_mass 0.5 is the default. Measured: mid-water C_m 0.589, a0 5.17 m/s^2; above the floor
  // 0.554, a0 3.72 (bench at R/dx 4: 0.617 and 0.677, a0 3.77 and 3.56, inside their ranges).
  // Mutations (session 11): halving the coupling force (kernels/rigid.cl) fails (the ball does not
  // rise); body_added_mass 0 fails (C_m -0.18 / -0.27, a0 13.6 / 19.0 m/s^2).
  // (body_added_mass is at its default, 0.5, since session 12: not set here.)
  const std::vector<std::string> dfsph = {"fluid.solver=dfsph", "fluid.dfsph.walls=extrapolated",
                                          "fluid.dfsph.coarse_interval=4",
                                          "fluid.dfsph.coarse_start=1", "fluid.dfsph.coarse_rest_travel=0",
                                          "fluid.dfsph.max_time_step=0.002"};
  const app::ReleaseMassCheck c = app::releasedBallAddedMass(scenePath("release_ball.yaml"), 0.01, 500.0, 0.01, dfsph);
  INFO(c.message);
  REQUIRE(c.exit_code == 0);
  INFO("mid-water, R/dx " << c.radius / c.dx << ": C_m " << c.cm << " (expected 0.5 .. " << c.cm_confined << "); a0 "
                          << c.a0 << " m/s^2 (expected from the held force " << c.a0_expected_lo << " .. "
                          << c.a0_expected_hi << "); held force " << c.held_over_buoyancy << " rho g V; "
                          << c.wall_seconds << " s");
  CHECK(c.cm > 0.75 * 0.5);
  CHECK(c.cm < 1.25 * c.cm_confined);
  CHECK(c.a0 > c.a0_expected_lo);
  CHECK(c.a0 < c.a0_expected_hi);
  std::vector<std::string> floor_sets = dfsph;
  floor_sets.push_back("rigid_bodies[0].position=[0.1, 0.1, 0.04]");
  const app::ReleaseMassCheck f = app::releasedBallAddedMass(scenePath("release_ball.yaml"), 0.01, 500.0, 0.01, floor_sets);
  INFO(f.message);
  REQUIRE(f.exit_code == 0);
  INFO("above the floor: C_m " << f.cm << " (images " << f.cm_floor << ", gap -+ dx/2: " << f.cm_floor_lo << " .. "
                               << f.cm_floor_hi << "); a0 " << f.a0 << " m/s^2 (expected from the held force "
                               << f.a0_expected_lo << " .. " << f.a0_expected_hi << "); held force "
                               << f.held_over_buoyancy << " rho g V; " << f.wall_seconds << " s");
  CHECK(f.cm > 0.9 * f.cm_floor_lo);
  CHECK(f.cm < 1.1 * f.cm_floor_hi);
  CHECK(f.a0 > f.a0_expected_lo);
  CHECK(f.a0 < f.a0_expected_hi);
}

TEST_CASE("Forces with DFSPH and no-slip ghost velocities: the Stokes drag of a towed and a falling ball match 6 pi mu "
          "R U with the box's wall factor",
          "[forces]") {
  // The WCSPH Stokes tests above with `fluid.solver: dfsph`, `fluid.dfsph.walls: extrapolated`
  // and `fluid.boundary_velocity: ghost` (Adami, Hu & Adams 2012 eq. 22-23 at every wall and
  // body), R / dx = 3, against the same band (TowCheck::expected_lo/hi: Haberman & Sayre's wall
  // factor of the 20 cm box, bracketed by two spherical containers, with the no-slip surface
  // within R -+ dx/2: 1.47 .. 3.75).
  //  - Towed (stokes_tow.yaml) under gravity: DFSPH corrects compressions only (p >= 0), so in the
  //    scene's weightless box (p = 0 at rest) there is no suction behind the ball and the expansion
  //    there goes uncorrected (drag 1.06 x 6 pi mu R U with ghost velocities, below the band;
  //    measured). Gravity gives the closed box
  //    an ambient pressure (rho g z ~ 1 kPa at the ball against the flow's 3/2 mu U / R = 25 Pa);
  //    the drag along x is the same in exact physics. Measured 2.13 (2.19, 2.20 at R / dx = 3.75,
  //    4.5, bench): inside the bracket at R itself (2.04 .. 2.57), so converged within it. With
  //    `boundary_velocity: wall` at the walls and body, 1.69 (the no-slip surface ~0.3 dx inside).
  //  - Falling (stokes_fall.yaml): (m - rho V) g / (6 pi mu R U), measured 2.13 (2.20 at
  //    R / dx = 3.75, bench), as WCSPH's 2.07 / 2.12; 1.66 / 1.79 without ghost velocities. Since
  //    session 41 the explicit fall is the bench's (`sphaptics bench --force-checks fall --force-solvers dfsph-ghost`), not this test's:
  //    at the explicit viscous bound it took 81 s of the test's 154 (the tow 50 s), the implicit runs 5-10 s
  //    each. The implicit falls below are held to the explicit *tow*: the same sphere at the centre of the
  //    same cube at Re << 1, whose Stokes resistance is the same for motion along x and along z (the
  //    cube's symmetry), so tow and fall read one wall factor K. Measured with the explicit solve at
  //    R / dx = 3: tow 2.093, fall 2.066 (1.3 % apart: the scheme's own tow-fall difference).
  // Halving the coupling force (kernels/rigid.cl, rigid_fluid_forces): the tow's drag halves
  // (below the band) and the falling ball's buoyancy and drag halve, U more than doubles (ratio
  // below the band); measured in the note of session 10.
  // (the explicit viscosity, which the `auto` default would replace here: session 39)
  const std::vector<std::string> ghost = {"fluid.solver=dfsph", "fluid.dfsph.walls=extrapolated",
                                          "fluid.boundary_velocity=ghost", "fluid.dfsph.viscosity_solve=explicit"};
  std::vector<std::string> tow_sets = ghost;
  tow_sets.push_back("simulation.gravity=[0, 0, -9.81]");
  const app::TowCheck t = app::towedBall(scenePath("stokes_tow.yaml"), 0.01, tow_sets);
  INFO(t.message);
  REQUIRE(t.exit_code == 0);
  INFO("towed: R/dx " << t.radius / t.dx << ", Re " << t.reynolds << ": drag " << t.drag / t.stokes
                      << " x 6 pi mu R U (expected " << t.expected_lo << " .. " << t.expected_hi << "), sideways |F_y| "
                      << t.side_y / t.drag << " of it; " << t.wall_seconds << " s");
  CHECK(t.drag / t.stokes > t.expected_lo);
  CHECK(t.drag / t.stokes < t.expected_hi);
  // The implicit viscosity (fluid.dfsph.viscosity_solve: implicit) at steps of 2.5 ms, 10x the explicit
  // viscous bound 0.125 h^2 / nu = 0.25 ms: the same band, and tow and fall within 5 % of the explicit
  // tow's drag (the same resolution and boundary: what is left is the time discretisation, and for the
  // fall the 1.3 % above; the bracket at R is
  // 2.04 .. 2.57, +-12 % about its middle, and the step may cost less than half of that; the explicit
  // tow's own mean moves by ~2 % with the window's per-step noise). Measured: towed 2.149 against 2.093
  // explicit, the falling ball 2.056 (0.01888 m/s; the explicit fall 0.01878), in about a seventh of the wall time; with the
  // plain splitting (viscosity, then the density solve) the tow reads 1.885, 10 % low (docs/dfsph.md,
  // session 36).
  std::vector<std::string> implicit_sets = tow_sets;
  implicit_sets.insert(implicit_sets.end(), {"fluid.dfsph.viscosity_solve=implicit", "fluid.dfsph.max_time_step=0.0025"});
  const app::TowCheck ti = app::towedBall(scenePath("stokes_tow.yaml"), 0.01, implicit_sets);
  INFO(ti.message);
  REQUIRE(ti.exit_code == 0);
  INFO("towed, implicit viscosity at 2.5 ms: drag " << ti.drag / ti.stokes << " x 6 pi mu R U (explicit "
                                                   << t.drag / t.stokes << "); " << ti.wall_seconds << " s against "
                                                   << t.wall_seconds << " s");
  CHECK(ti.drag / ti.stokes > ti.expected_lo);
  CHECK(ti.drag / ti.stokes < ti.expected_hi);
  CHECK(std::abs(ti.drag / t.drag - 1.0) < 0.05);
  std::vector<std::string> fall_implicit = ghost;
  fall_implicit.insert(fall_implicit.end(), {"fluid.dfsph.viscosity_solve=implicit", "fluid.dfsph.max_time_step=0.0025"});
  const app::FallCheck fi = app::fallingBall(scenePath("stokes_fall.yaml"), 0.01, fall_implicit);
  INFO(fi.message);
  REQUIRE(fi.exit_code == 0);
  INFO("falling, implicit viscosity at 2.5 ms: U " << fi.speed << " m/s, ratio " << fi.ratio << " (explicit tow " << t.drag / t.stokes
                                                  << "); " << fi.wall_seconds << " s");
  CHECK(fi.ratio > fi.expected_lo);
  CHECK(fi.ratio < fi.expected_hi);
  CHECK(std::abs(fi.ratio / (t.drag / t.stokes) - 1.0) < 0.05);
  // Free bodies are unknowns of the implicit viscosity solve (session 38; kernels/viscosity.cl,
  // viscosity_cg_body_*), their start taking their weight and the last pressure's force as the fluid's
  // incremental start does. Held at their velocity during the solve and given its reaction after it (up to
  // session 37), a ball overshot at long steps: this one, released at DFSPH's default 5 ms step, jumped to
  // 0.38 m/s upward where it falls at 0.019, and a 300 kg/m^3 one blew up at its release at 2.5 ms. At the
  // default step (20x the explicit bound) the falling ball must stay within 5 % of the explicit solve (its
  // tow, above), and a 300 kg/m^3 ball must rise inside the same band ((rho V - m) g / 6 pi mu R U).
  // Measured: falling 2.076 against the explicit tow's 2.093 (-0.8 %; the explicit fall 2.066; 2.056 at
  // 2.5 ms), rising 2.233 at 0.0122 m/s, ~5.7 s each against the explicit fall's 33-81 s. Mutation: the bodies
  // held in the solve: the falling ball's ratio 2.617 (+25 % on the tow), and the rising one blew up (exit 4): fails.
  std::vector<std::string> fall5 = ghost;
  fall5.push_back("fluid.dfsph.viscosity_solve=implicit");
  const app::FallCheck f5 = app::fallingBall(scenePath("stokes_fall.yaml"), 0.01, fall5);
  INFO(f5.message);
  REQUIRE(f5.exit_code == 0);
  INFO("falling, implicit viscosity at 5 ms: U " << f5.speed << " m/s, ratio " << f5.ratio << " (explicit tow " << t.drag / t.stokes
                                                << "); " << f5.wall_seconds << " s");
  CHECK(f5.ratio > f5.expected_lo);
  CHECK(f5.ratio < f5.expected_hi);
  CHECK(std::abs(f5.ratio / (t.drag / t.stokes) - 1.0) < 0.05);
  std::vector<std::string> rise5 = fall5;
  rise5.push_back("rigid_bodies[0].density=300");
  const app::FallCheck r5 = app::fallingBall(scenePath("stokes_fall.yaml"), 0.01, rise5);
  INFO(r5.message);
  REQUIRE(r5.exit_code == 0);
  INFO("rising 300 kg/m^3 ball, implicit viscosity at 5 ms: U " << r5.speed << " m/s, ratio " << r5.ratio << "; "
                                                                << r5.wall_seconds << " s");
  CHECK(r5.ratio > r5.expected_lo);
  CHECK(r5.ratio < r5.expected_hi);
  WARN("Stokes fall, implicit viscosity at 5 ms: falling ratio " << f5.ratio << " (explicit tow " << t.drag / t.stokes << "), rising 300 kg/m^3 "
                                                                 << r5.ratio << " (band " << r5.expected_lo << " .. " << r5.expected_hi
                                                                 << ")");
}

TEST_CASE("Forces: the method of images' added mass of a sphere moving normal to a wall", "[forces]") {
  // app::sphereWallAddedMass against its known limits: 1/2 far from the wall; the series'
  // leading terms 1/2 (1 + 3/8 e^3 + 3/64 e^6), e = R / h, where the rest is O(e^8) (h = 4 R); and
  // the value at contact, 0.803 (the sphere touching the wall, moving normal to it: finite, as
  // the closed-form solution near contact shows, "The virtual mass of a sphere moving toward a
  // plane wall", J. Appl. Mech. 44, 166, 1977; 0.803 is the value the bubble-wall literature uses).
  CHECK(app::sphereWallAddedMass(1e3) == Approx(0.5).margin(1e-9));
  const double e = 0.25;
  CHECK(app::sphereWallAddedMass(4.0) == Approx(0.5 * (1 + 0.375 * std::pow(e, 3) + 3.0 / 64.0 * std::pow(e, 6))).margin(1e-5));
  CHECK(app::sphereWallAddedMass(1.0) == Approx(0.803).margin(0.001));
}

TEST_CASE("Forces: DFSPH takes the no-slip ghost velocities at every boundary with boundary_velocity: ghost, at its "
          "moving bodies with auto",
          "[forces]") {
  // scenes/tests/tow_re20.yaml (dfsph, laminar, boundary_velocity: ghost): the ghost velocities
  // (Adami, Hu & Adams 2012 eq. 22-23) for every boundary particle (mode 1); with `auto` DFSPH
  // takes them at the moving bodies' particles only (mode 2, session 10: the Stokes drag of a
  // towed or falling ball is 0.75-0.82 / 1.66-1.79 x 6 pi mu R U without them, inside the wall
  // factor's band with them), the walls keeping their own velocity (as before), and none in a
  // scene with no moving body or with the artificial viscosity; WCSPH's `auto` with the laminar
  // model takes them everywhere. At Re = 20 in that scene the drag is 3.20 x 6 pi mu R U with
  // them and 2.55 without (docs/forces.md; a bench row, minutes per run).
  const std::string scene = scenePath("tow_re20.yaml");
  CHECK(compile(io::loadScene(scene)).model.ghost_velocity_mode == 1u);
  CHECK(compile(io::loadScene(scene, {"fluid.boundary_velocity=auto"})).model.ghost_velocity_mode == 2u);
  CHECK(compile(io::loadScene(scene, {"fluid.boundary_velocity=wall"})).model.ghost_velocity_mode == 0u);
  CHECK(compile(io::loadScene(scene, {"fluid.boundary_velocity=auto", "fluid.viscosity_model=artificial"}))
            .model.ghost_velocity_mode == 0u);
  // (the walls only: scenes/peer/dam_break_50k.yaml, dfsph and laminar, no body; its steps unchanged)
  CHECK(compile(io::loadScene(scenePath("../peer/dam_break_50k.yaml"), {"fluid.particle_spacing=0.02"}))
            .model.ghost_velocity_mode == 0u);
  CHECK(compile(io::loadScene(scene, {"fluid.boundary_velocity=auto", "fluid.solver=wcsph"})).model.ghost_velocity_mode ==
        1u);
}

TEST_CASE("Forces: a body's per-particle fluid forces (readBodyParticles) sum to its fluid force", "[forces]") {
  // The diagnostic read-back that session 9 used for the pressure distribution on the sinking ball
  // (docs/forces.md): each moving particle's position, volume ratio, fluid force and
  // wall pressure, in body order. Its forces must add up to the body's fluid force of the same
  // step (rigid_reduce sums the same numbers in float, in the same order: rounding only), its
  // volume ratios be positive and its positions lie dx/2 inside the ball's surface (compile's inset).
  app::RunOptions o = testing::quietRun("sink_ball.yaml", {"simulation.duration=0.02"});
  std::vector<Eigen::Vector4f> pos, force;
  Eigen::Vector3d body_force = Eigen::Vector3d::Zero(), centre = Eigen::Vector3d::Zero();
  std::size_t n_model = 0;
  const app::RunResult r = app::runScene(o, [&](Simulation& sim, const FrameReport&) {
    sim.readBodyParticles(pos, force);
    body_force = sim.bodies()[0].fluid_force;
    centre = sim.bodies()[0].x;
    n_model = sim.model().bodies[0].particles.size();
  });
  INFO(r.message);
  REQUIRE(r.exit_code == 0);
  REQUIRE(pos.size() == n_model);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double worst_radius = 0;
  for (std::size_t k = 0; k < pos.size(); ++k) {
    sum += force[k].head<3>().cast<double>();
    CHECK(pos[k].w() > 0.0f);
    worst_radius = std::max(worst_radius, std::abs((pos[k].head<3>().cast<double>() - centre).norm() - 0.025));
  }
  INFO("sum " << sum.transpose() << " N, body " << body_force.transpose() << " N; particles " << pos.size()
              << ", largest |r - (R - dx/2)| " << worst_radius << " m");
  CHECK((sum - body_force).norm() < 1e-4 * body_force.norm());
  CHECK(body_force.norm() > 0.0);  // (at 0.02 s the start-up waves still swing it: not yet the buoyancy)
  CHECK(worst_radius < 0.001);  // the sphere's mesh (edges dx/2) is within 1 mm of the sphere
}
