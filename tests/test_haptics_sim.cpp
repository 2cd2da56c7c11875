// Haptics in the simulation (batch mode, virtual time): grab, drag and hold a body in water and
// read what the hand feels from haptics.csv; scenes without `haptics` run no haptic stage; scene
// errors of the section. Scenes: scenes/tests/haptic_drag.yaml, scenes/tests/haptic_hold.yaml,
// scenes/haptic_stir.yaml (DFSPH stability).
#include "cli/runner.h"
#include "core/scene_spec.h"
#include "core/simulation.h"
#include "tests/haptics_csv.h"
#include "tests/run_binary.h"
#include "tests/scene_issues.h"
#include "tests/temp_dir.h"

#include <catch2/catch.hpp>

#include <chrono>
#include <cmath>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

using namespace sph;
using sph::testing::TempDir;

namespace {

const std::filesystem::path kSourceDir = SPHAPTICS_SOURCE_DIR;

using sph::testing::readHaptics;
using sph::testing::Tick;

// haptic_drag.yaml at `speed` (unit: m/s in the scene): the mean felt force while the ball is in
// the blob (device x in [-3, 3] cm: the ball's centre 3.4 to 4.6 dm, the blob 3 to 5 dm).
Eigen::Vector3d feltDrag(double speed) {
  TempDir tmp;
  app::RunOptions o;
  o.scene = (kSourceDir / "scenes" / "tests" / "haptic_drag.yaml").string();
  o.out = tmp.path.string();
  o.quiet = true;
  const double end = 0.3 / speed;  // 30 cm in the scene (15 cm at the hand, scale 2)
  o.sets = {"haptics.path[0].end=" + std::to_string(end)};
  o.duration = end;
  const app::RunResult r = app::runScene(o);
  REQUIRE(r.exit_code == 0);
  REQUIRE(r.haptics);
  const auto rows = readHaptics(tmp.path / "haptics.csv");
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  int n = 0;
  for (const Tick& t : rows) {
    if (t.x.x() < -0.03 || t.x.x() > 0.03) continue;
    REQUIRE(t.body == 0);  // held all the way
    sum += t.f;
    ++n;
  }
  REQUIRE(n > 50);
  return sum / n;
}

}  // namespace

TEST_CASE("Haptics: dragging a grabbed ball through still water, the felt force opposes the motion and grows with speed",
          "[haptics][physics]") {
  // The hand drags a neutrally buoyant 2.5 cm ball along +x at 0.5 and 1 m/s through a free blob
  // (gravity off). The hand holds the ball against the drag: it feels it backwards (-x), mostly
  // along x (sideways below half the drag: the off-centre grasp and the irregular surface sampling
  // tilt it). Pressure drag goes as U^2, so doubling U must more than double the felt force (ratio
  // between 2, linear Stokes drag, and a generous 8, as tests/test_rigid.cpp's kinematic drag).
  const Eigen::Vector3d slow = feltDrag(0.5), fast = feltDrag(1.0);
  INFO("felt at 0.5 m/s " << slow.transpose() << " N, at 1 m/s " << fast.transpose() << " N");
  CHECK(slow.x() < 0);
  CHECK(fast.x() < 0);
  CHECK(slow.tail<2>().norm() < 0.5 * std::abs(slow.x()));
  CHECK(fast.tail<2>().norm() < 0.5 * std::abs(fast.x()));
  const double ratio = fast.x() / slow.x();
  CHECK(ratio > 2.0);
  CHECK(ratio < 8.0);
}

TEST_CASE("Haptics: dragging a grabbed ball through syrup, the hand feels Stokes' drag (DFSPH, implicit viscosity by "
          "default)",
          "[haptics][physics][dfsph]") {
  // scenes/tests/haptic_syrup_tow.yaml: the hand drags a neutrally buoyant ball (R = 3 cm = 3 dx) at 1 cm/s
  // through a closed 20 cm box of syrup (nu = 0.05 m^2/s; Re = 0.012), grabbed at its front point so the pull
  // is in line with the drag. DFSPH's default (fluid.dfsph.viscosity_solve: auto) solves the viscosity
  // implicitly at 5 ms steps (the explicit bound is 0.25 ms), the grabbed ball an unknown of the solve.
  // Stokes: the ball at its own speed U_b feels 6 pi mu R U_b K, K the box's wall factor; the band is the
  // towed-ball tests' (app::TowCheck: 1.47-3.75, the no-slip surface within R -+ dx/2; the bracket at R
  // itself 2.04-2.57). The hand feels that drag (felt = gain x coupling force, gain 1) within 5 % of the
  // fluid's force on the ball (what is left is the ball's own m a). Sideways: below 5 % of the drag.
  // Measured (session 39, over 0.6-1 s): felt -0.657 N at U_b 9.6 mm/s, ratio 2.44, sideways 0.4 %;
  // the explicit solve at its 0.25 ms bound reads the felt force within 0.3 % (docs/forces.md, session 39).
  // Grabbed at its centre instead (the grab takes the closest surface point), the pull and the drag make a
  // couple: the ball turns and the hand feels a third of the drag sideways (measured; not a fluid defect).
  // Mutation: haptics.gain 0.5 (the hand feels half the coupling force): ratio 1.24, and felt half the fluid's
  // force: fails.
  TempDir tmp;
  app::RunOptions o;
  o.scene = (kSourceDir / "scenes" / "tests" / "haptic_syrup_tow.yaml").string();
  o.out = tmp.path.string();
  o.quiet = true;
  const double R = 0.03, mu = 1000.0 * 0.05, from = 0.6;
  double speed = 0, fluid_x = 0;
  int frames = 0;
  bool implicit = false;
  const app::RunResult r = app::runScene(o, [&](Simulation& sim, const FrameReport& rep) {
    implicit = sim.model().spec.fluid.dfsph.viscosity_solve == ViscositySolve::Implicit;
    if (rep.time < from - 1e-9) return;
    speed += sim.bodies()[0].v.x();
    fluid_x += sim.bodies()[0].fluid_force.x();
    ++frames;
  });
  REQUIRE(r.exit_code == 0);
  CHECK(implicit);
  {  // run.json's scene says what ran: `auto` resolved
    std::ifstream in(tmp.path / "run.json");
    const std::string json((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    CHECK(json.find("\"viscosity_solve\": \"implicit\"") != std::string::npos);
    CHECK(json.find("viscosity solved implicitly (fluid.dfsph.viscosity_solve: auto)") != std::string::npos);
  }
  REQUIRE(frames > 10);
  speed /= frames;
  fluid_x /= frames;
  Eigen::Vector3d felt = Eigen::Vector3d::Zero();
  int n = 0;
  for (const Tick& t : readHaptics(tmp.path / "haptics.csv"))
    if (t.t >= from) {
      REQUIRE(t.body == 0);  // held all the way
      felt += t.f;
      ++n;
    }
  REQUIRE(n > 300);
  felt /= n;
  const double stokes = 6.0 * M_PI * mu * R * speed;
  INFO("felt " << felt.transpose() << " N, the fluid's force on the ball along x " << fluid_x << " N, ball speed " << speed
               << " m/s: felt / 6 pi mu R U = " << -felt.x() / stokes);
  CHECK(speed > 0.009);  // it follows the hand (1 cm/s) by then
  CHECK(-felt.x() / stokes > 1.47);
  CHECK(-felt.x() / stokes < 3.75);
  CHECK(std::abs(felt.x() - fluid_x) < 0.05 * std::abs(fluid_x));
  CHECK(std::abs(felt.y()) < 0.05 * std::abs(felt.x()));
  WARN("ball dragged through syrup by the hand (DFSPH, implicit viscosity): felt " << -felt.x() << " N = " << -felt.x() / stokes
                                                                                   << " x 6 pi mu R U_b, sideways "
                                                                                   << std::abs(felt.y() / felt.x()));
}

TEST_CASE("Haptics: a grabbed ball held under water pulls up with its buoyancy minus its weight",
          "[haptics][physics]") {
  // haptic_hold.yaml: a 3 cm ball of 500 kg/m^3 held by its lowest point, its top 5 cm under the
  // surface. Archimedes: the hand feels gain (rho_w V - m) |g| upwards (V, m of the body's mesh).
  // Tolerance 10 % of (B - W), i.e. 5 % of the buoyancy B: issue 5's bound for Archimedes at
  // dx = 1 cm (a ball of radius 3 dx). The coupling itself is exact: in the steady state the felt
  // force equals gain (F_fluid - m g) from the simulation within 3 % (the servo renders the spring).
  TempDir tmp;
  app::RunOptions o;
  o.scene = (kSourceDir / "scenes" / "tests" / "haptic_hold.yaml").string();
  o.out = tmp.path.string();
  o.quiet = true;
  double volume = 0, mass = 0;
  Eigen::Vector3d fluid = Eigen::Vector3d::Zero();
  int frames = 0;
  const app::RunResult r = app::runScene(o, [&](Simulation& sim, const FrameReport& rep) {
    volume = sim.model().bodies[0].volume;
    mass = sim.model().bodies[0].mass;
    if (rep.time < 0.7 - 1e-9) return;
    fluid += sim.bodies()[0].fluid_force;
    ++frames;
  });
  REQUIRE(r.exit_code == 0);
  REQUIRE(frames > 5);
  fluid /= frames;
  const auto rows = readHaptics(tmp.path / "haptics.csv");
  Eigen::Vector3d felt = Eigen::Vector3d::Zero();
  int n = 0;
  for (const Tick& t : rows)
    if (t.t >= 0.7) {
      felt += t.f;
      ++n;
    }
  REQUIRE(n > 200);
  felt /= n;
  const double g = 9.81, rho = 1000.0;
  const double archimedes = (rho * volume - mass) * g;
  INFO("felt " << felt.transpose() << " N; Archimedes B - W = " << archimedes << " N; fluid " << fluid.transpose());
  CHECK(felt.z() == Approx(archimedes).epsilon(0.10));
  CHECK(felt.head<2>().norm() < 0.1 * archimedes);
  CHECK(felt.z() == Approx(fluid.z() - mass * g).epsilon(0.03));
}

// haptic_brush.yaml: the painting demo's brush lying level in the air, grabbed by the tip of one end
// and held still. The orientation hold (haptics/grab.h) is an angular spring K_r = I_perp K_s / m
// (I_perp the inertia about the horizontal axis normal to the brush, from the compiled mesh;
// K_s = K_d / (g s)): the brush settles where K_r theta = m g d cos(theta), d the distance from the
// centre of mass to the grasp point (the tip, 4.2 cm). Tolerance 10 % of theta (about 4.3 deg):
// the mesh's inertia and the grasp point on its facets differ from the smooth capsule's by a few
// per cent, and the linear coupling's sag (m g / K_s = 1 mm) leaves the angle as it is.
// Without the hold (haptics.hold_orientation: false) the brush swings down from its tip: more than
// 45 deg within the 0.4 s (a pendulum of length 4.2 cm swings a quarter period in ~0.1 s).
TEST_CASE("Haptics: a grabbed brush held at its tip keeps its orientation against gravity (hold_orientation)",
          "[haptics][physics]") {
  // The tilt: the angle of the body's z axis (towards the held tip) above the horizontal, as the
  // centre of mass sinks below the grasp point (unit: rad).
  auto tiltOf = [](const Eigen::Quaterniond& q) { return std::asin((q * Eigen::Vector3d::UnitZ()).z()); };
  double expected = 0, settled = 0, max_free = 0;
  for (const bool hold : {true, false}) {
    TempDir tmp;
    app::RunOptions o;
    o.scene = (kSourceDir / "scenes" / "tests" / "haptic_brush.yaml").string();
    o.out = tmp.path.string();
    o.quiet = true;
    o.write_output = false;
    if (!hold) o.sets = {"haptics.hold_orientation=false"};
    double sum = 0;
    int n = 0;
    const app::RunResult r = app::runScene(o, [&](Simulation& sim, const FrameReport& rep) {
      const rigid::RigidBody& body = sim.model().bodies[0];
      const double tilt = tiltOf(sim.bodies()[0].q);
      if (hold && rep.time > 0.25) {
        sum += tilt;
        ++n;
      }
      if (!hold) max_free = std::max(max_free, tilt);
      // The closed form: K_r theta = m g d cos(theta), solved by fixed-point iteration.
      const double m = body.mass, ks = 250.0 / (1.0 * 1.0);  // K_d / (gain scale)
      const Eigen::Vector3d axis = Eigen::Vector3d::UnitY();  // body y = world y: the axis it tilts about
      const double kr = axis.dot(body.inertia * axis) * ks / m, d = 0.03 + 0.012;
      expected = 0;
      for (int i = 0; i < 50; ++i) expected = m * 9.81 * d * std::cos(expected) / kr;
    });
    REQUIRE(r.exit_code == 0);
    REQUIRE(r.haptics);
    if (hold) {
      REQUIRE(n > 3);
      settled = sum / n;
    }
  }
  INFO("held: settled tilt " << settled * 180 / M_PI << " deg, closed form " << expected * 180 / M_PI
                             << " deg; not held: largest tilt " << max_free * 180 / M_PI << " deg");
  CHECK(settled == Approx(expected).epsilon(0.10));
  CHECK(max_free > 45 * M_PI / 180);
}

TEST_CASE("Haptics: a scene without a haptics section runs no haptic stage", "[haptics]") {
  app::RunOptions o;
  o.scene = (kSourceDir / "scenes" / "tests" / "tiny_tank.yaml").string();
  o.quiet = true;
  o.write_output = false;
  o.duration = 0.05;
  bool stage_on = true;
  const app::RunResult r = app::runScene(o, [&](Simulation& sim, const FrameReport&) {
    stage_on = sim.stages().on(Stage::Haptics);
  });
  REQUIRE(r.exit_code == 0);
  CHECK_FALSE(stage_on);
  CHECK_FALSE(r.haptics);  // no session, so no servo and no thread
  CHECK(r.haptic_ticks == 0);
  CHECK(r.profile.seconds[static_cast<std::size_t>(Stage::Haptics)] == 0.0);
}

TEST_CASE("Haptics: batch runs are deterministic and tick the servo at its rate", "[haptics]") {
  // haptic_drag.yaml for 0.2 s, twice: the same state hash and the same haptics.csv, byte for byte;
  // 1 kHz virtual time: ticks 0, 1 ms, ..., 200 ms.
  auto once = [](const std::filesystem::path& dir, uint64_t& hash) {
    app::RunOptions o;
    o.scene = (kSourceDir / "scenes" / "tests" / "haptic_drag.yaml").string();
    o.out = dir.string();
    o.quiet = true;
    o.duration = 0.2;
    const app::RunResult r = app::runScene(o);
    REQUIRE(r.exit_code == 0);
    CHECK(r.haptic_ticks == 201);
    hash = r.state_hash;
    std::ifstream in(dir / "haptics.csv");
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  TempDir a, b;
  uint64_t ha = 0, hb = 0;
  const std::string ca = once(a.path, ha), cb = once(b.path, hb);
  CHECK(ha == hb);
  CHECK(ca == cb);
  CHECK(ca.size() > 1000);
}

TEST_CASE("Haptics: bad values in the haptics section are reported at file:line:col", "[haptics][io]") {
  TempDir tmp;
  const std::string yaml =
      "domain: {min: [0, 0, 0], max: [1, 1, 1]}\n"                        // 1
      "haptics:\n"                                                         // 2
      "  stiffness: 900\n"                                                 // 3
      "  smoothing: median\n"                                              // 4
      "  continuous_force: 2\n"                                            // 5
      "  peak_force: 1\n"                                                  // 6
      "  path:\n"                                                          // 7
      "    - {type: circle, start: 1, end: 0.5, axis: [0, 0, 0]}\n"        // 8
      "  waypoints:\n"                                                     // 9
      "    - {time: 1, position: [0, 0, 0]}\n"                             // 10
      "    - {time: 0.5, position: [0, 0, 0]}\n";                          // 11
  const auto issues = sph::testing::issuesOf(tmp, yaml);
  INFO(sph::testing::dump(issues));
  CHECK(sph::testing::hasIssue(issues, 3, {"haptics.stiffness", "out of range"}));
  CHECK(sph::testing::hasIssue(issues, 4, {"haptics.smoothing", "median"}));
  CHECK(sph::testing::hasIssue(issues, 5, {"haptics.continuous_force", "must not exceed"}));
  CHECK(sph::testing::hasIssue(issues, 8, {"haptics.path[0].end", "greater than its start"}));
  CHECK(sph::testing::hasIssue(issues, 8, {"haptics.path[0].axis", "nonzero"}));
  CHECK(sph::testing::hasIssue(issues, 11, {"haptics.waypoints[1].time", "greater than the previous"}));
  // The command line: exit code 2 with the location.
  tmp.write("bad.yaml", yaml);
  const auto v = sph::testing::sphaptics(tmp.path, {"validate", "bad.yaml"});
  CHECK(v.code == 2);
  CHECK(v.err.find("bad.yaml:3:") != std::string::npos);
}

TEST_CASE("Haptics: --interactive runs the servo thread live and stops it, and needs a haptics section",
          "[haptics][live]") {
  // haptic_drag.yaml for 0.3 s of simulated time, paced to the wall clock: the servo thread ticks
  // at 1 kHz meanwhile (at least a third of the ticks even on a loaded machine), then joins.
  app::RunOptions o;
  o.scene = (kSourceDir / "scenes" / "tests" / "haptic_drag.yaml").string();
  o.quiet = true;
  o.write_output = false;
  o.duration = 0.3;
  o.interactive = true;
  const auto t0 = std::chrono::steady_clock::now();
  const app::RunResult r = app::runScene(o);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  REQUIRE(r.exit_code == 0);
  CHECK(r.haptics);
  CHECK(r.haptic_ticks > 100);
  CHECK(wall >= 0.3);  // frames are not run ahead of real time
  // A scene without a haptics section: exit 2, naming the option.
  o.scene = (kSourceDir / "scenes" / "tests" / "tiny_tank.yaml").string();
  const app::RunResult bad = app::runScene(o);
  CHECK(bad.exit_code == 2);
  CHECK(bad.message.find("--interactive") != std::string::npos);
}

TEST_CASE("Haptics: a recorded live session replays with identical state hashes", "[haptics][live]") {
  // haptic_drag.yaml live for 0.25 s with --record; the replay feeds the recorded readings to the
  // same grab logic and checks the bodies' hash at every step and the whole state's after every
  // frame. A recording with one reading moved by 1 mm must fail the check at the next step.
  TempDir tmp;
  const std::string file = (tmp.path / "session.rec").string();
  app::RunOptions o;
  o.scene = (kSourceDir / "scenes" / "tests" / "haptic_drag.yaml").string();
  o.quiet = true;
  o.write_output = false;
  o.duration = 0.25;
  o.interactive = true;
  o.record = file;
  const app::RunResult live = app::runScene(o);
  REQUIRE(live.exit_code == 0);
  const haptics::Recording rec = haptics::readRecording(file);
  CHECK(rec.frames == live.frames);
  CHECK(rec.hashes.size() == static_cast<std::size_t>(live.frames));
  CHECK(rec.steps.size() >= static_cast<std::size_t>(live.frames));
  CHECK(rec.step_hashes.size() == rec.steps.size());
  CHECK(rec.hashes.back() == live.state_hash);

  app::RunOptions r;
  r.scene = rec.scene;
  r.sets = rec.sets;
  r.replay = &rec;
  r.quiet = true;
  r.write_output = false;
  const app::RunResult replay = app::runScene(r);
  CHECK(replay.exit_code == 0);
  CHECK(replay.replay_frames_checked == live.frames);
  CHECK(replay.state_hash == live.state_hash);

  haptics::Recording tampered = rec;
  tampered.steps[tampered.steps.size() / 2].position.x() += 1e-3;
  r.replay = &tampered;
  const app::RunResult bad = app::runScene(r);
  CHECK(bad.exit_code != 0);
  CHECK(bad.message.find("state hash differs") != std::string::npos);
  // The per-step body hash names the step after the moved reading (the first whose start differs).
  INFO(bad.message);
  CHECK(bad.message.find("at step " + std::to_string(tampered.steps.size() / 2 + 2)) != std::string::npos);
}

TEST_CASE("Haptics with DFSPH: a light spoon held in a pour does not swing up (the fictitious inertia in rotation "
          "when staggered, the implicit grab when strong)",
          "[haptics][dfsph][rigid][stability]") {
  // scenes/haptic_stir.yaml with DFSPH: the hand holds a wooden spoon (700 kg/m^3, 8 mm radius, held
  // at its top) still while the tap fills the bowl around its tip (0-1.2 s). At 300 frames/s (one
  // 3.3 ms step per frame) the solve answers the spoon's turn one step late; the water's added
  // inertia about the spoon's centre (a cylinder in cross flow: rho_w / rho_b of its own inertia) is
  // larger than the spoon's, and without the fictitious inertia J = (M / m) I in its rotation
  // (core/rigid.h, fictitiousTorque) the spoon swung with period 2, growing ~1.7x a step (0.35 to
  // 29 rad/s in 10 steps), until a particle it struck moved more than h in one step (exit 4 at
  // t = 0.67 s; session 16). The bound: the water cannot turn the spoon faster than the stream that
  // strikes it moves its tip, |w| <= v / L, v = sqrt(0.4^2 + 2 g 0.038) = 0.95 m/s (the tap's 0.4 m/s
  // after falling 3.8 cm to the tip), L = 0.116 m from the hand to the tip: 8.2 rad/s. Measured:
  // the largest |w| at a frame's end 0.94 rad/s (the stream's first impact, ~0.15 s). Mutation (the
  // rotation without J, dL = dt T): exit 4 at t = 0.67 s, fails.
  // Session 26: the same with the strong body coupling (the default since), which has no fictitious
  // inertia; there the grab's spring-damper, implicit in the spoon's motion (haptics/grab.h), holds it.
  // Measured: largest |w| 1.26 rad/s staggered, 1.12 strong. With the grab explicit (session 25's)
  // the strong run blew up (docs/forces.md, session 25).
  const std::string coupling = GENERATE(std::string("staggered"), std::string("strong"));
  INFO("fluid.dfsph.body_coupling " << coupling);
  TempDir tmp;
  app::RunOptions o;
  o.scene = (kSourceDir / "scenes" / "haptic_stir.yaml").string();
  o.out = tmp.path.string();
  o.quiet = true;
  o.write_output = false;
  o.sets = {"fluid.solver=dfsph", "fluid.dfsph.pressure_cfl=0.7", "simulation.frame_rate=300",
            "fluid.dfsph.body_coupling=" + coupling};
  o.duration = 1.0;
  double w_max = 0.0;
  int frames = 0;
  const app::RunResult r = app::runScene(o, [&](Simulation& sim, const FrameReport&) {
    w_max = std::max(w_max, sim.bodies()[1].w.norm());
    ++frames;
  });
  INFO(r.message << "; " << frames << " frames, largest |w| of the spoon " << w_max << " rad/s");
  REQUIRE(r.exit_code == 0);
  CHECK(frames == 300);
  const double v_tip = std::sqrt(0.4 * 0.4 + 2 * 9.81 * 0.038), lever = 0.116;
  CHECK(w_max < v_tip / lever);
}
