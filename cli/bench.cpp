// `sphaptics bench`: what speed costs and what accuracy costs.
//
//  1. Speed: the dam break (scenes/dam_break.yaml) scaled to ~10k, 50k and 100k particles, with
//     the scene's substeps set to 2 and 4 (CFL control may add steps: the table shows the steps per
//     frame actually taken). Reports frames/s, particle-steps/s, time per stage and memory.
//  2. Accuracy against time: the dam-break surge front against Martin & Moyce (1952) at three
//     resolutions x two step sizes (Courant number 0.4 and 0.2, i.e. 1x and 2x the steps) x both
//     equations of state, next to the wall time of each run.
//  3. Isosurface: the same dam break (by default at 50k, the target size) with the surface off, on (meshed on the
//     device and read back, nothing written) and on + OBJ export (written on the writer thread):
//     frames/s of each, the isosurface time per frame and the share of the frame it costs.
//  4. Cloth stability (issue 11): a 16 x 16 cloth hung by one edge, no fluid, stiffness from 10 N/m
//     to 10^7 N/m (10^6 times stiffer) x steps of 1/240 s and of the whole frame (1/60 s), both
//     solvers: steps taken (explicit: subdivided below its limit), largest strain, energy gain
//     (none may grow: the cloth only loses energy to its dashpots), NaN, wall time.
//  5. Forces on bodies (issue 15): the checks of tests/test_forces.cpp (cli/force_checks.h) at
//     R / dx = 3, 4 and 5 (the tests run 3 and 4): added mass of an accelerated ball, free against
//     held, added mass of a released ball (mid-water and near the floor, R / dx = 3, 4), Stokes
//     drag and sideways force of a towed ball (R / dx = 3, 3.75, 4.5), a dense ball sinking from
//     rest (R / dx = 3, 4, 4.5, and 7.95 with --force-checks sink-fine; its drag split into added
//     mass, quadratic and linear parts; released into a tank at rest, R / dx = 3, 4: sink-rest), a buoyant block placed flush on the floor (h / dx = 6, 8),
//     the released buoyant ball's float and heave (R / dx = 3, 4.05), the Stokes terminal velocity
//     of a falling ball (R / dx = 3, 3.75), the Re-20 tow in the 80 cm tank (DFSPH; --no-long-tank) and
//     the towed ball's drag at Re = 20 (two sound speeds), each against its closed form, with
//     the wall time of the run: what accuracy costs. One row per check, solver and resolution.
//  6. Impact pressure (issue 14, with the accuracy table): the pressure on the far wall during the
//     dam-break impact with each solver, against the hydrostatic value of the local water height.
// The tables are printed and written as CSV; scripts/plot_bench.py draws error against seconds.
#include "cli/analysis.h"
#include "cli/commands.h"
#include "cli/force_checks.h"
#include "cli/runner.h"
#include "core/errors.h"
#include "core/model.h"
#include "core/simulation.h"
#include "io/scene_loader.h"

#include <sys/resource.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

namespace fs = std::filesystem;

namespace sph::app {

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

double peakRssMiB() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss / 1024.0;
}

std::string sourcePath(const std::string& rel) {
  // The benchmark runs from the repository root or from the build folder.
  for (const char* base : {".", "..", SPHAPTICS_SOURCE_DIR_DEFAULT})
    if (fs::exists(fs::path(base) / rel)) return (fs::path(base) / rel).string();
  throw InputError(rel, 0, 0, "not found: run the benchmark from the repository root");
}

// Particle spacing that puts about `target` particles in the scene's blocks, snapped so that the
// column base a (the first block's x extent) holds a whole number of spacings.
double spacingFor(const SceneSpec& spec, double target) {
  double volume = 0;
  for (const BlockSpec& b : spec.fluid.blocks) volume += (b.max - b.min).prod();
  const double a = spec.fluid.blocks.at(0).max.x() - spec.fluid.blocks.at(0).min.x();
  return a / std::max(1.0, std::round(a / std::cbrt(volume / target)));
}

std::string fmtd(double v, int prec = 3) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", prec, v);
  return buf;
}

// 4b. Cloth cost next to the fluid's at the paper's demo size: scenes/balls_on_cloth.yaml (about
// 49k particles with the boundary: 32k fluid, a 51 x 51 cloth, three balls), `frames` frames from
// the start, per stage in ms per step and kernel launches per step; the XPBD solve fused into one
// launch per step (default) and as one launch per colour and sweep. Medians of `repeats` runs.
int clothCost(const BenchOptions& opt, ClContext& cl) {
  const std::string scene = sourcePath("scenes/balls_on_cloth.yaml");
  const Compiled comp = compile(io::loadScene(scene));
  const fs::path csv = fs::path(opt.out) / "cloth_cost.csv";
  std::ofstream out(csv);
  out << "# sphaptics " << SPHAPTICS_VERSION << " cloth cost: " << scene << ", " << comp.initial.size()
      << " fluid particles, " << comp.model.boundary.size() << " wall and body particles, " << comp.model.cloth.nodes()
      << " cloth nodes; " << opt.frames << " frame(s), medians of " << opt.repeats << " runs\n";
  std::string header = "xpbd_solve,steps,ms_per_step,launches_per_step,cloth_launches_per_step";
  for (int st = 0; st < kNumStages; ++st) header += std::string(",ms_per_step_") + stageName(static_cast<Stage>(st));
  out << header << "\n";
  std::printf("\ncloth cost: %s (%zu fluid particles, %zu cloth nodes), %d frame(s), medians of %d runs\n", scene.c_str(),
              comp.initial.size(), comp.model.cloth.nodes(), opt.frames, opt.repeats);
  std::printf("%-10s %-6s %-9s %-9s %-9s %-8s %-8s %-8s %-8s\n", "solve", "steps", "ms/step", "launch/st", "cloth l/st",
              "fluid", "cloth", "coupling", "rigid");
  for (bool fused : {true, false}) {
    std::vector<double> total, per_stage[kNumStages];
    uint64_t steps = 0, launches = 0, cloth_launches = 0;
    for (int r = 0; r < opt.repeats; ++r) {
      Simulation sim(comp.model, comp.initial, cl);
      if (!fused) sim.cloth()->setFusedMaxNodes(0);
      for (int f = 0; f < opt.frames; ++f) sim.advanceFrame();
      const Profile& p = sim.profile();
      steps = p.steps;
      total.push_back(1e3 * p.total() / double(p.steps));
      for (int st = 0; st < kNumStages; ++st) per_stage[st].push_back(1e3 * p.seconds[st] / double(p.steps));
      launches = cloth_launches = 0;
      for (const auto& [name, count] : sim.dispatchCounts()) {
        launches += count;
        if (name.rfind("cloth_", 0) == 0) cloth_launches += count;
      }
    }
    double stage_ms[kNumStages];
    for (int st = 0; st < kNumStages; ++st) stage_ms[st] = median(per_stage[st]);
    const double fluid = stage_ms[int(Stage::Grid)] + stage_ms[int(Stage::Density)] + stage_ms[int(Stage::Pressure)] +
                         stage_ms[int(Stage::Viscosity)] + stage_ms[int(Stage::Integrate)];
    const char* name = fused ? "fused" : "per_colour";
    out << name << "," << steps << "," << median(total) << "," << double(launches) / steps << ","
        << double(cloth_launches) / steps;
    for (int st = 0; st < kNumStages; ++st) out << "," << stage_ms[st];
    out << "\n";
    std::printf("%-10s %-6llu %-9.2f %-9.1f %-9.1f %-8.2f %-8.2f %-8.2f %-8.2f\n", name,
                static_cast<unsigned long long>(steps), median(total), double(launches) / steps,
                double(cloth_launches) / steps, fluid, stage_ms[int(Stage::Cloth)], stage_ms[int(Stage::ClothCoupling)],
                stage_ms[int(Stage::RigidCoupling)]);
    std::fflush(stdout);
  }
  std::cout << "wrote " << csv.string() << " (fluid: grid + density + pressure + viscosity + integrate; wall times on "
               "this machine)\n";
  return kExitOk;
}

// 4. Cloth stability sweep: stiffness x step x solver on a cloth hung by one edge (no fluid).
int clothSweep(const BenchOptions& opt) {
  fs::create_directories(opt.out);
  const fs::path csv = fs::path(opt.out) / "cloth_stability.csv";
  std::ofstream out(csv);
  out << "# sphaptics " << SPHAPTICS_VERSION << " cloth stability sweep: 16 x 16 nodes, 0.25 m square, 0.2 kg/m^2, "
         "hung by its y_max edge, 1 s simulated at 60 frames/s, medians of " << opt.repeats << " runs\n";
  out << "solver,stiffness_N_per_m,dt_s,steps,max_strain,energy_gain_rel,energy_drift_rel,nonfinite,wall_s\n";
  std::printf("\n%-9s %-10s %-9s %-8s %-10s %-12s %-12s %-5s %-8s\n", "solver", "k N/m", "dt s", "steps", "max strain",
              "energy gain", "energy drift", "NaN", "wall s");
  ClContext cl(opt.device);
  for (ClothSolver solver : {ClothSolver::Xpbd, ClothSolver::Explicit})
    for (double k : {1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7})
      for (int substeps : {4, 1}) {
        SceneSpec s;
        s.domain.max = Eigen::Vector3d(1, 1, 1);
        s.fluid.phases.resize(1);
        s.fluid.phases[0].name = "water";
        s.simulation.frame_rate = 60;
        s.simulation.substeps = substeps;
        s.simulation.duration = 1.0;
        ClothSpec c;
        c.name = "sheet";
        c.width = c.length = 0.25;
        c.resolution_x = c.resolution_y = 16;
        c.position = Eigen::Vector3d(0.5, 0.5, 0.7);
        c.areal_density = 0.2;
        c.stretch_stiffness = k;
        c.shear_stiffness = 0.1 * k;
        c.bend_stiffness = 0.01 * k;
        c.damping = 0.0;
        c.solver = solver;
        ClothAnchorSpec edge;
        edge.type = AnchorType::Edge;
        edge.edge = ClothEdge::YMax;
        c.anchors.push_back(edge);
        s.cloth.push_back(c);
        const Compiled comp = compile(s);
        const Eigen::Vector3d g(0, 0, -9.81);
        // Energy scale: the cloth's weight times its length (the drop of its centre when it hangs).
        const double scale = c.areal_density * c.width * c.length * 9.81 * c.length;
        std::vector<double> walls;
        uint64_t steps = 0;
        double max_strain = 0, gain = 0, drift = 0;
        bool nonfinite = false;
        for (int r = 0; r < opt.repeats; ++r) {
          Simulation sim(comp.model, comp.initial, cl);
          const double e0 = sim.cloth()->report(0, g).energy();
          uint64_t sub = 0;
          max_strain = 0;
          gain = 0;
          const auto t0 = std::chrono::steady_clock::now();
          for (int f = 0; f < comp.model.num_frames; ++f) {
            for (int k2 = 0; k2 < substeps; ++k2) {
              sim.step(comp.model.frame_dt / substeps);
              sub += static_cast<uint64_t>(std::max(1, sim.cloth()->lastSubsteps()));
            }
            const cloth::ClothReport rep = sim.cloth()->report(0, g);
            if (!std::isfinite(rep.energy())) nonfinite = true;
            max_strain = std::max(max_strain, rep.max_strain);
            gain = std::max(gain, (rep.energy() - e0) / scale);
            drift = (rep.energy() - e0) / scale;
          }
          walls.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
          steps = sub;
        }
        const char* name = solver == ClothSolver::Xpbd ? "xpbd" : "explicit";
        const double dt = 1.0 / (60.0 * substeps);
        out << name << "," << k << "," << dt << "," << steps << "," << max_strain << "," << gain << "," << drift << ","
            << (nonfinite ? 1 : 0) << "," << median(walls) << "\n";
        std::printf("%-9s %-10.0e %-9.5f %-8llu %-10.4f %-12.2e %-12.2e %-5s %-8.3f\n", name, k, dt,
                    static_cast<unsigned long long>(steps), max_strain, gain, drift, nonfinite ? "yes" : "no",
                    median(walls));
        std::fflush(stdout);
      }
  std::cout << "wrote " << csv.string() << " (energy gain: largest E(t) - E(0) over the run; drift: E(1 s) - E(0); "
               "both over m g L; steps: time steps, explicit: its substeps)\n";
  return clothCost(opt, cl);
}

// 5. Force checks of bodies in water against resolution (cli/force_checks.h).
int forceChecks(const BenchOptions& opt) {
  fs::create_directories(opt.out);
  const fs::path csv = fs::path(opt.out) / "force_checks.csv";
  std::ofstream out(csv);
  out << "# sphaptics " << SPHAPTICS_VERSION << " force checks of bodies in water (issue 15): measured against the "
         "closed form's range [expected_lo, expected_hi]; rel_error = distance outside that range / its middle "
         "(0 inside; for a range at 0, the measured value; for a range centred on 0, / its half-width); wall_s: the "
         "run's simulation wall time\n";
  out << "check,solver,dx_m,R_over_dx,measured,expected_lo,expected_hi,rel_error,wall_s\n";
  std::printf("\n%-22s %-6s %-7s %-5s %-10s %-21s %-9s %-7s\n", "force check", "solver", "dx m", "R/dx", "measured",
              "expected", "rel err", "wall s");
  auto row = [&](const std::string& check, const std::string& solver, double dx, double r_dx, double v, double lo,
                 double hi, double wall) {
    const double mid = 0.5 * (lo + hi), outside = v < lo ? lo - v : (v > hi ? v - hi : 0.0);
    // (a range at 0, the sideways force: the measured value itself; a range centred on 0, the
    // no-slip offset: over its half-width)
    const double err = lo == 0.0 && hi == 0.0 ? std::abs(v) : outside / (mid != 0.0 ? mid : 0.5 * (hi - lo));
    out << check << "," << solver << "," << dx << "," << r_dx << "," << v << "," << lo << "," << hi << "," << err << ","
        << wall << "\n";
    std::printf("%-22s %-6s %-7.4f %-5.1f %-10.4g [%-8.4g, %-8.4g] %-9.3f %-7.1f\n", check.c_str(), solver.c_str(), dx,
                r_dx, v, lo, hi, err, wall);
    std::fflush(stdout);
  };
  const std::string accel = sourcePath("scenes/tests/accel_ball.yaml");
  const std::string release = sourcePath("scenes/tests/release_ball.yaml");
  const std::string tow = sourcePath("scenes/tests/stokes_tow.yaml");
  const std::string sink = sourcePath("scenes/tests/sink_ball.yaml");
  const std::string sink_rest = sourcePath("scenes/tests/sink_ball_rest.yaml");
  const std::string fall = sourcePath("scenes/tests/stokes_fall.yaml");
  // --force-checks: the groups to run (all when none is named).
  auto on = [&](const char* group) {
    return opt.force_checks.empty() ||
           std::find(opt.force_checks.begin(), opt.force_checks.end(), group) != opt.force_checks.end();
  };
  for (const std::string& solver : opt.force_solvers) {
    // DFSPH with extrapolated walls: the wall's pressure from the fluid, as WCSPH's (the right
    // pressure on bodies: docs/forces.md); its viscous terms see the walls' own
    // velocities and, where the body's term is laminar, the no-slip ghost velocities at moving
    // bodies (`boundary_velocity: auto` with DFSPH, session 10). `dfsph-ghost`: the ghost
    // velocities (Adami, Hu & Adams 2012 eq. 22-23) at every wall and body, as WCSPH's laminar runs.
    // `dfsph-strong`: the bodies move inside the solves (fluid.dfsph.body_coupling strong, session 23; the
    // default since session 26, named here as well); `dfsph-staggered`: in their own step after them.
    // A suffix `-subtract` or `-keep` sets fluid.body_ambient_pressure (session 32: wcsph-subtract;
    // session 33: either rule with either solver).
    std::string name = solver, rule;
    for (const char* suffix : {"-subtract", "-keep"}) {
      const std::string sfx(suffix);
      if (name.size() > sfx.size() && name.compare(name.size() - sfx.size(), sfx.size(), sfx) == 0) {
        rule = sfx.substr(1);
        name.resize(name.size() - sfx.size());
      }
    }
    const bool ghost = name == "dfsph-ghost", strong = name == "dfsph-strong", staggered = name == "dfsph-staggered";
    const std::string base = ghost || strong || staggered ? "dfsph" : name;
    std::vector<std::string> sets = {"fluid.solver=" + base};
    if (base == "dfsph") sets.push_back("fluid.dfsph.walls=extrapolated");
    // the rows measure the explicit viscosity (its `auto` default solves syrups implicitly, session 39); the
    // implicit rows below set their own
    if (base == "dfsph") sets.push_back("fluid.dfsph.viscosity_solve=explicit");
    if (ghost) sets.push_back("fluid.boundary_velocity=ghost");
    if (strong) sets.push_back("fluid.dfsph.body_coupling=strong");
    if (staggered) sets.push_back("fluid.dfsph.body_coupling=staggered");
    if (!rule.empty()) sets.push_back("fluid.body_ambient_pressure=" + rule);
    for (double dx : {0.01, 0.0075, 0.006}) {
      if (!on("added-mass")) break;
      // Added mass: C_m between the unbounded 1/2 and Lamb's concentric-sphere value.
      const AccelCheck a = acceleratedBall(accel, dx, sets, opt.device);
      if (a.exit_code != 0) std::printf("added mass at dx %g (%s): %s\n", dx, solver.c_str(), a.message.c_str());
      else row("added_mass_Cm", solver, dx, a.radius / dx, a.cm, a.cm_unbounded, a.cm_confined, a.wall_seconds);
    }
    for (double dx : {0.01, 0.0075}) {
      if (!on("free-held")) break;
      // A neutral ball: free against held, and held against rho g V (as fractions of rho g V), in the
      // tank settled 0.5 s before t = 0 (session 33: with gravity on at t = 0 the tank rang at the
      // release and the held force read 0.91-0.95 rho g V; settled, 0.99).
      std::vector<std::string> calm = sets;
      calm.push_back("simulation.settle_time=0.5");
      const ReleaseCheck r = releasedBall(release, dx, 1000.0, 0.1, calm, opt.device);
      if (r.exit_code != 0) {
        std::printf("free vs held at dx %g (%s): %s\n", dx, solver.c_str(), r.message.c_str());
        continue;
      }
      row("held_over_buoyancy", solver, dx, r.radius / dx, r.held_force / r.buoyancy, 1.0, 1.0, r.wall_seconds);
      row("free_over_held", solver, dx, r.radius / dx, r.free_force / r.held_force, 1.0, 1.0, r.wall_seconds);
    }
    for (double dx : {0.01, 0.0075}) {
      if (!on("release")) break;
      // A 500 kg/m^3 ball released mid-water and one spacing above the floor, against the same
      // ball held: C_m from the momentum over the first 10 ms (cli/force_checks.h).
      // DFSPH (session 11): the fictitious mass 1/2 rho0 V (fluid.dfsph.body_added_mass): without it the
      // staggered coupling's lagged added mass (m_a > m for this ball) swings the released ball with
      // period 2 steps, growing (C_m 0.04 over 10 ms); and the two-level solve (coarse_interval 4), so
      // that the held ball's tank is calm at the default step (+-1 % of rho g V instead of +-80 % at the
      // plain Jacobi's bound); and steps of at most 2 ms, 5 in the window (the ball's acceleration lags
      // the fluid's answer by one step: at the artificial viscosity's 3.3 ms, 3 steps, v(T) / T reads
      // C_m 0.66 where the force reads 0.47; at 2 ms 0.59 and 0.50). The two-level solve's schedule
      // of session 10 (a correction after iterations 1, 5, 9, ... of every solve: coarse_start 1,
      // coarse_rest_travel 0): with the default rest rule alone the held ball's tank rings at 2 ms
      // steps and R/dx 4 (held force ~2 rho g V over the window; C_m 0.64 mid-water, 10 % above its
      // band). As tests/test_forces.cpp.
      std::vector<std::string> release_sets = sets;
      if (base == "dfsph")
        // (the fictitious mass and coarse_interval 4 are the defaults)
        for (const char* s : {"fluid.dfsph.coarse_start=1", "fluid.dfsph.coarse_rest_travel=0",
                              "fluid.dfsph.max_time_step=0.002"})
          release_sets.push_back(s);
      for (const bool floor : {false, true}) {
        std::vector<std::string> s2 = release_sets;
        if (floor) s2.push_back("rigid_bodies[0].position=[0.1, 0.1, " + std::to_string(0.03 + dx) + "]");
        const ReleaseMassCheck m = releasedBallAddedMass(release, dx, 500.0, 0.01, s2, opt.device);
        const std::string name = floor ? "release_Cm_floor" : "release_Cm_midwater";
        if (m.exit_code != 0) {
          std::printf("%s at dx %g (%s): %s\n", name.c_str(), dx, solver.c_str(), m.message.c_str());
          continue;
        }
        row(name, solver, dx, m.radius / dx, m.cm, floor ? m.cm_floor_lo : 0.5, floor ? m.cm_floor_hi : m.cm_confined,
            m.wall_seconds);
        // The ball's own mean acceleration v(T) / T against (mean F_held - m g) / (m + C_m rho V), C_m
        // over the same range with the tests' 25 % (the a0; session 11).
        row(floor ? "release_a0_floor_mps2" : "release_a0_midwater_mps2", solver, dx, m.radius / dx, m.a0,
            m.a0_expected_lo, m.a0_expected_hi, m.wall_seconds);
      }
    }
    for (double dx : {0.01, 0.008, 0.2 / 30}) {
      if (!on("stokes")) break;
      // Stokes drag over 6 pi mu R U, against the box's wall factor K with the no-slip surface
      // within R -+ dx/2 (TowCheck::expected_lo/hi); sideways / drag against 0. Spacings that
      // divide the 20 cm box (else the liquid starts with a gap and rings: no steady drag).
      // DFSPH corrects compressions only (p >= 0): in the scene's weightless box the liquid at rest
      // has p = 0, so behind the ball there is no suction and the expansion goes uncorrected (the
      // drag halves: 1.06 against 2.13 x 6 pi mu R U at R/dx 3 with ghost velocities, session 10).
      // Gravity gives it the ambient pressure it needs (rho g z ~ 1 kPa at the ball against the
      // flow's 3/2 mu U / R = 25 Pa; the box is closed, so the liquid stays at rest); the drag
      // along x is the same in exact physics, the buoyancy goes to F_z (so sideways is |F_y|).
      // One tow with `extra` settings: its drag row, or a line saying why it did not run.
      auto towDrag = [&](const std::vector<std::string>& extra, const char* name) {
        std::vector<std::string> s2 = sets;
        s2.insert(s2.end(), extra.begin(), extra.end());
        const TowCheck c = towedBall(tow, dx, s2, opt.device);
        if (c.exit_code != 0)
          std::printf("%s at dx %g (%s): %s\n", name, dx, solver.c_str(), c.message.c_str());
        else
          row(name, solver, dx, c.radius / dx, c.drag / c.stokes, c.expected_lo, c.expected_hi, c.wall_seconds);
        return c;
      };
      const TowCheck t = towDrag(base == "dfsph" ? std::vector<std::string>{"simulation.gravity=[0, 0, -9.81]"}
                                                 : std::vector<std::string>{},
                                 "stokes_drag_over_6piMuRU");
      if (t.exit_code != 0) continue;
      row("sideways_over_drag", solver, dx, t.radius / dx, (base == "dfsph" ? t.side_y : t.side) / t.drag, 0.0, 0.0,
          t.wall_seconds);
      // Where the no-slip surface lies: (R - R_eff) / dx for the drag measured, with the box's two
      // bracketing containers (equal volume: the smaller offset; inscribed: the larger), against
      // the band's -0.5 .. 0.5 (the boundary particles sit at R - dx/2, the fluid's first layer
      // at R + dx/2). A constant offset in dx: first-order convergence in dx / R.
      const double b_in = 0.5 * t.box, b_vol = t.box * std::cbrt(3.0 / (4.0 * M_PI));
      row("stokes_noslip_inside_R_dx_eqvol", solver, dx, t.radius / dx,
          (t.radius - stokesEffectiveRadius(t.drag / t.stokes, t.radius, b_vol)) / dx, -0.5, 0.5, t.wall_seconds);
      row("stokes_noslip_inside_R_dx_inscr", solver, dx, t.radius / dx,
          (t.radius - stokesEffectiveRadius(t.drag / t.stokes, t.radius, b_in)) / dx, -0.5, 0.5, t.wall_seconds);
      // DFSPH: the same tow with the implicit viscosity (fluid.dfsph.viscosity_solve: implicit, session 36) at
      // steps of 1, 2.5 and 5 ms, against the explicit solve's viscous bound 0.125 h^2 / nu (0.25 ms at dx 1 cm):
      // what the longer step costs in accuracy, against what it saves in wall time (the row above).
      if (base == "dfsph") {
        for (const char* ms : {"1", "2.5", "5"}) {
          const std::string step = std::to_string(std::atof(ms) * 1e-3);
          towDrag({"simulation.gravity=[0, 0, -9.81]", "fluid.dfsph.viscosity_solve=implicit",
                   "fluid.dfsph.max_time_step=" + step},
                  ("stokes_implicit_" + std::string(ms) + "ms_drag_over_6piMuRU").c_str());
        }
      }
      // WCSPH: the same tow with the box's top closed and a background pressure of 1 kPa (session 35: in the
      // weightless box the suction behind the ball is tension, under which SPH's symmetric pressure force is
      // unstable; fluid.background_pressure keeps the pressure positive).
      if (base != "wcsph") continue;
      towDrag({"domain.closed.z_max=true", "fluid.background_pressure=1000"}, "stokes_bg1kPa_drag_over_6piMuRU");
    }
    for (const double c0 : {30.0, 60.0}) {
      if (!on("re20")) break;
      // Moderate Re: the towed ball at U = 1/3 m/s in a liquid of nu = 1e-3 m^2/s (Re = 2 R U / nu
      // = 20), from 1 cm off the wall across the box, the drag averaged over the second half
      // (0.12 .. 0.24 s, the centre passing 8 .. 12 cm). Schiller & Naumann (1933):
      // C_D = 24/Re (1 + 0.15 Re^0.687), i.e. drag / 6 pi mu R U = 1 + 0.15 Re^0.687 = 2.17, times a
      // wall factor between 1 (walls not felt) and the Stokes band's top (at moderate Re the walls
      // matter less than in Stokes flow), with the no-slip surface within R -+ dx/2. Two sounds
      // speeds: the box's acoustic ringing swings the drag (drag_se: standard error of 6 block means).
      const double u = 1.0 / 3.0, nu = 1e-3;
      std::vector<std::string> s2 = sets;
      s2.insert(s2.end(), {"fluid.phases[0].viscosity=" + std::to_string(nu),
                           "rigid_bodies[0].motion.velocity=[0.3333333333, 0, 0]",
                           "rigid_bodies[0].position=[0.04, 0.1, 0.1]", "simulation.duration=0.24",
                           "fluid.speed_of_sound=" + std::to_string(c0)});
      const TowCheck t = towedBall(tow, 0.01, s2, opt.device);
      if (t.exit_code != 0) {
        std::printf("Re 20 drag at c0 %g (%s): %s\n", c0, solver.c_str(), t.message.c_str());
        continue;
      }
      const double sn = 1.0 + 0.15 * std::pow(2.0 * t.radius * u / nu, 0.687);
      const std::string tag = "_c0_" + std::to_string(static_cast<int>(c0));
      row("re20_drag_over_6piMuRU" + tag, solver, 0.01, t.radius / 0.01, t.drag / t.stokes,
          sn * (t.radius - 0.005) / t.radius, sn * t.expected_hi, t.wall_seconds);
      row("re20_drag_se_over_6piMuRU" + tag, solver, 0.01, t.radius / 0.01, t.drag_noise / t.stokes, 0.0, 0.0,
          t.wall_seconds);
    }
    // sink_ball.yaml at R/dx 3, 4, 4.5 (`sink`) and 7.95 (`sink-fine`); the same ball released into
    // a tank at rest, sink_ball_rest.yaml (gravity ramped in, held 0.2 s after), at R/dx 3, 4
    // (`sink-rest`, rows sink_rest_*: session 12, docs/forces.md).
    struct SinkRun {
      const std::string* scene;
      double dx;
      const char* group;
      const char* prefix;
    };
    const SinkRun sink_runs[] = {{&sink, 0.01, "sink", "sink_"},           {&sink, 0.0075, "sink", "sink_"},
                                 {&sink, 0.2 / 30, "sink", "sink_"},       {&sink, 0.2 / 53, "sink-fine", "sink_"},
                                 {&sink_rest, 0.01, "sink-rest", "sink_rest_"}, {&sink_rest, 0.0075, "sink-rest", "sink_rest_"}};
    for (const SinkRun& run : sink_runs) {
      // R/dx 7.95 (`sink-fine`, a spacing that divides the 20 cm tank: 205k particles, ~10 min per
      // run here) only when named; R/dx 6: session 9's replica, docs/forces.md
      const double dx = run.dx;
      const std::string p = run.prefix;
      const bool named = std::find(opt.force_checks.begin(), opt.force_checks.end(), run.group) != opt.force_checks.end();
      if (std::string(run.group) == "sink-fine" ? !named : !on(run.group)) continue;
      // A dense ball sinking from rest: its speed 0.2 s after the release against the closed form
      // with added mass and quadratic drag, C_m 0.375 .. 0.725, C_d 0 .. sinkingDragBound (a
      // sphere's 0.5 with the resolution's and the tank's factors; tests/test_forces.cpp); the
      // largest distance outside that envelope (ringing margin included) over the 0.2 s; the
      // mean C_d over the 0.2 s from momentum against 0 .. that bound.
      const double cd_hi = sinkingDragBound(0.03, dx, 0.2);
      const SinkCheck k = sinkingBallHeldDrag(*run.scene, dx, 0.02, 0.2, 0.375, 0.725, 0.0, cd_hi, sets, opt.device);
      if (k.exit_code != 0) {
        std::printf("sinking ball (%s) at dx %g (%s): %s\n", run.group, dx, solver.c_str(), k.message.c_str());
        continue;
      }
      row(p + "speed_0.2s_mps", solver, dx, k.radius / dx, k.v_end, k.v_lo, k.v_hi, k.wall_seconds);
      row(p + "outside_envelope_mps", solver, dx, k.radius / dx, k.worst, 0.0, 0.0, k.wall_seconds);
      row(p + "mean_Cd", solver, dx, k.radius / dx, k.cd_effective, 0.0, cd_hi, k.wall_seconds);
      // The ringing margin as a margin on that C_d (the envelope's), and the C_d with the ringing
      // and the sampled buoyancy taken out by the same ball held throughout.
      row(p + "mean_Cd_ringing_margin", solver, dx, k.radius / dx, k.cd_ringing, 0.0, 0.0, k.wall_seconds);
      row(p + "mean_Cd_held_subtracted", solver, dx, k.radius / dx, k.cd_held_subtracted, 0.0, cd_hi, k.wall_seconds);
      // That impulse split into added mass, quadratic drag and a drag linear in v (SinkCheck::fit_*):
      // the excess over the band is the linear part (docs/forces.md, session 9).
      row(p + "fit_Cm", solver, dx, k.radius / dx, k.fit_cm, 0.375, 0.725, k.wall_seconds);
      row(p + "fit_Cd", solver, dx, k.radius / dx, k.fit_cd, 0.0, cd_hi, k.wall_seconds);
      row(p + "fit_linear_drag_Nspm", solver, dx, k.radius / dx, k.fit_b, 0.0, 0.0, k.wall_seconds);
    }
    for (double dx : {0.01, 0.0075}) {
      if (!on("flush")) break;
      // A buoyant block placed flush on the floor: lifted by compile to a gap of dx, it rises and
      // floats; its draft over Archimedes' h rho_b / rho against the Archimedes test's 5 %.
      const FloatCheck b = risingBlock(sourcePath("scenes/tests/rising_block.yaml"), dx, sets, opt.device);
      if (b.exit_code != 0) std::printf("flush block at dx %g (%s): %s\n", dx, solver.c_str(), b.message.c_str());
      else row("flush_block_draft_over_archimedes", solver, dx, b.height / dx, b.draft / b.expected, 0.95, 1.05, b.wall_seconds);
    }
    for (double dx : {0.01, 0.2 / 27}) {
      if (!on("heave")) break;
      // The released 500 kg/m^3 ball run to 1.5 s: it floats half submerged (its centre at the
      // water level, within dx/2) with a damped heave whose undamped period lies in the floating
      // hemisphere's band (Hulme 1982), +-17 % for the waterplane radius known to dx/2
      // (tests/test_forces.cpp). R/dx 3 is the test's; 4.05 (a spacing that divides the tank) here.
      // DFSPH: the same ball as the release rows, with the same (default) fictitious mass (session 11).
      const std::vector<std::string>& heave_sets = sets;
      const HeaveCheck h = floatingBallHeave(release, dx, 1.5, heave_sets, opt.device);
      if (h.exit_code != 0) {
        std::printf("heave at dx %g (%s): %s\n", dx, solver.c_str(), h.message.c_str());
        continue;
      }
      row("heave_centre_minus_level_over_dx", solver, dx, h.radius / dx, h.offset / dx, -0.5, 0.5, h.wall_seconds);
      row("heave_second_over_first_crest", solver, dx, h.radius / dx, h.crest1 > 0 ? h.crest2 / h.crest1 : 0.0, 0.0,
          1.0, h.wall_seconds);
      row("heave_damping_ratio", solver, dx, h.radius / dx, h.zeta, 0.0, 1.0, h.wall_seconds);
      row("heave_undamped_period_s", solver, dx, h.radius / dx, h.period_undamped, h.period_lo / 1.17,
          h.period_hi * 1.17, h.wall_seconds);
    }
    for (double dx : {0.01, 0.008}) {
      if (!on("fall")) break;
      // Stokes terminal velocity: (m - rho V) g / (6 pi mu R U) against the towed ball's band.
      const FallCheck f = fallingBall(fall, dx, sets, opt.device);
      if (f.exit_code != 0) {
        std::printf("Stokes fall at dx %g (%s): %s\n", dx, solver.c_str(), f.message.c_str());
        continue;
      }
      row("stokes_fall_over_6piMuRU", solver, dx, f.radius / dx, f.ratio, f.expected_lo, f.expected_hi,
          f.wall_seconds);
      row("stokes_fall_held_buoyancy", solver, dx, f.radius / dx, f.ratio_held, f.expected_lo, f.expected_hi,
          f.wall_seconds);
    }
  }
  // Moderate Re in a long tank, DFSPH (scenes/tests/tow_re20.yaml sets the solver): the ball towed
  // 10 diameters at Re = 20 after a smooth start, the drag averaged over the second half (1-2 s)
  // against Schiller-Naumann with the duct's confinement (moderateReBand). Not a test: at R/dx = 4
  // a run takes minutes (docs/forces.md).
  const std::string tow20 = sourcePath("scenes/tests/tow_re20.yaml");
  for (double dx : {0.01, 0.2 / 27}) {
    if (!opt.force_long_tank || !on("long-tank")) break;  // --no-long-tank
    const TowCheck t = towedBall(tow20, dx, {}, opt.device);
    if (t.exit_code != 0) {
      std::printf("Re 20 drag, long tank, at dx %g: %s\n", dx, t.message.c_str());
      continue;
    }
    double lo = 0, hi = 0;
    moderateReBand(t.radius, dx, t.box, t.speed, 2.0 * t.radius * t.speed / t.reynolds, lo, hi);
    row("re20_long_drag_over_6piMuRU", "dfsph", dx, t.radius / dx, t.drag / t.stokes, lo, hi, t.wall_seconds);
    row("re20_long_drag_se_over_6piMuRU", "dfsph", dx, t.radius / dx, t.drag_noise / t.stokes, 0.0, 0.0, t.wall_seconds);
    // (horizontal only: under gravity F_z carries the kinematic ball's buoyancy)
    row("re20_long_sideways_y_over_drag", "dfsph", dx, t.radius / dx, t.side_y / t.drag, 0.0, 0.0, t.wall_seconds);
  }
  std::cout << "wrote " << csv.string() << " (wall times on this machine; a shared machine adds noise)\n";
  return kExitOk;
}


// 6. Impact pressure on the far wall (issue 14): the dam break at one resolution with each solver,
// a pressure probe on the far wall and a water-height gauge just in front of it, sampled at
// 1 kHz (DFSPH: every step, its steps being longer). From the front's arrival on: the peak
// pressure, how many samples read 0 (WCSPH clamps negative pressure of a thin sheet to 0) or dry,
// and the pressure against the hydrostatic value rho g (h - z) of the local water height h, over
// the whole impact and over its last 0.1 s. The time runs to T = t sqrt(2 g / a) = 7.5, after the
// run-up on the wall has fallen back.
int impactPressure(const BenchOptions& opt, const std::string& scene, const SceneSpec& base) {
  const BlockSpec& col = base.fluid.blocks.at(0);
  const double a = col.max.x() - col.min.x();
  const double g = base.simulation.gravity.norm();
  const double rho0 = base.fluid.phases.at(0).rest_density;
  const double tscale = std::sqrt(2.0 * g / a);
  const double duration = 7.5 / tscale;
  const double dx = spacingFor(base, static_cast<double>(opt.impact_size));
  // The sensor: on the far wall (half a spacing in front of it, where the first fluid layer sits),
  // mid-width, 4 cm up; the gauge 1.5 spacings in front of the wall.
  const double x_wall = base.domain.max.x(), y_mid = 0.5 * (base.domain.min.y() + base.domain.max.y());
  const double z_probe = base.domain.min.z() + 0.04;
  const fs::path csv = fs::path(opt.out) / "impact_pressure.csv";
  std::ofstream out(csv);
  out << "# sphaptics " << SPHAPTICS_VERSION << " impact pressure: dam break, probe on the far wall at x = "
      << x_wall << " - dx/2, z = " << z_probe << " m, 1 kHz; window: from the front's arrival to T = 7.5; "
      << "hydrostatic = rho0 g (h - z) from a gauge 1.5 dx in front of the wall\n";
  out << "solver,particles,dx_m,steps,arrival_s,samples,zero_samples,dry_samples,peak_Pa,peak_time_s,mean_Pa,"
         "mean_hydrostatic_Pa,late_mean_Pa,late_hydrostatic_Pa,wall_s\n";
  std::printf("\nImpact pressure on the far wall (z = %.3f m), from the front's arrival to t = %.3f s\n", z_probe, duration);
  std::printf("%-6s %-9s %-6s %-9s %-8s %-6s %-5s %-9s %-8s %-9s %-9s %-9s %-9s %-8s\n", "solver", "particles", "steps",
              "arrive s", "samples", "zero", "dry", "peak Pa", "at s", "mean Pa", "rho g h", "late Pa", "late rgh",
              "wall s");
  for (const char* solver : {"wcsph", "dfsph"}) {
    RunOptions ro;
    ro.scene = scene;
    ro.device = opt.device;
    ro.quiet = true;
    ro.write_output = false;
    ro.sets = {"fluid.particle_spacing=" + fmtd(dx, 9), std::string("fluid.solver=") + solver,
               "simulation.numerical_errors=warn", "output.isosurface.enabled=false", "probes.rate=1000",
               "probes.points=[{name: far_wall, position: [" + fmtd(x_wall - 0.5 * dx, 6) + ", " + fmtd(y_mid, 6) +
                   ", " + fmtd(z_probe, 6) + "]}]",
               "probes.gauges=[{name: far_depth, position: [" + fmtd(x_wall - 1.5 * dx, 6) + ", " + fmtd(y_mid, 6) +
                   ", " + fmtd(base.domain.min.z(), 6) + "]}]"};
    ro.duration = duration;
    std::vector<ProbeSample> samples;
    auto collect = [&](Simulation& sim, const FrameReport&) {
      if (samples.empty()) sim.recordProbeSamples(true);  // from the first frame's end on (the front is far)
      for (ProbeSample& s : sim.takeProbeSamples()) samples.push_back(std::move(s));
    };
    const RunResult r = runScene(ro, collect);
    if (r.exit_code != 0) throw std::runtime_error("impact run failed: " + r.message);
    // The window opens at the first wet sample (the front's arrival).
    double arrival = NAN, peak = 0, peak_t = NAN, sum_p = 0, sum_h = 0, late_p = 0, late_h = 0;
    int n = 0, zero = 0, dry = 0, n_mean = 0, n_late = 0;
    for (const ProbeSample& s : samples) {
      const double p = s.points.at(0).pressure, h = s.heights.at(0);
      if (std::isnan(arrival)) {
        if (std::isnan(p)) continue;
        arrival = s.time;
      }
      ++n;
      if (std::isnan(p)) {
        ++dry;
        continue;
      }
      if (p <= 0.0) ++zero;
      if (p > peak) peak = p, peak_t = s.time;
      const double hydro = rho0 * g * std::max(0.0, h - (z_probe - base.domain.min.z()));
      sum_p += p, sum_h += hydro, ++n_mean;
      if (s.time >= duration - 0.1) late_p += p, late_h += hydro, ++n_late;
    }
    const double mean_p = n_mean ? sum_p / n_mean : NAN, mean_h = n_mean ? sum_h / n_mean : NAN;
    const double lp = n_late ? late_p / n_late : NAN, lh = n_late ? late_h / n_late : NAN;
    out << solver << "," << r.particles << "," << dx << "," << r.profile.steps << "," << arrival << "," << n << ","
        << zero << "," << dry << "," << peak << "," << peak_t << "," << mean_p << "," << mean_h << "," << lp << ","
        << lh << "," << r.wall_seconds << "\n";
    std::printf("%-6s %-9zu %-6llu %-9.3f %-8d %-6d %-5d %-9.0f %-8.3f %-9.0f %-9.0f %-9.0f %-9.0f %-8.1f\n", solver,
                r.particles, static_cast<unsigned long long>(r.profile.steps), arrival, n, zero, dry, peak, peak_t,
                mean_p, mean_h, lp, lh, r.wall_seconds);
    std::fflush(stdout);
  }
  std::cout << "wrote " << csv.string() << " (wall times on this machine; a shared machine adds noise)\n";
  return kExitOk;
}
}  // namespace

int benchCommand(const BenchOptions& opt) {
  try {
    fs::create_directories(opt.out);
    if (opt.cloth_only) return clothSweep(opt);
    if (opt.forces_only) return forceChecks(opt);
    const std::string scene = sourcePath("scenes/dam_break.yaml");
    const SceneSpec base = io::loadScene(scene);
    // The accuracy runs' overrides are checked before anything runs: a bad key or value is bad input (exit 2).
    if (!opt.accuracy_sets.empty()) io::loadScene(scene, opt.accuracy_sets);
    std::cout << "benchmark scene: " << scene << "\n";
    if (opt.impact_only) return impactPressure(opt, scene, base);

    // ---- 1. Speed -------------------------------------------------------------------------
    if (!opt.accuracy_only && !opt.iso_only) {
      const fs::path csv = fs::path(opt.out) / "speed.csv";
      std::ofstream out(csv);
      out << "# sphaptics " << SPHAPTICS_VERSION << " speed benchmark: dam break, medians of " << opt.repeats
          << " runs of " << opt.frames << " frames\n";
      std::string header = "target_particles,particles,substeps,steps_per_frame,frames_per_s,particle_steps_per_s";
      for (int s = 0; s < kNumStages; ++s) header += std::string(",ms_per_step_") + stageName(static_cast<Stage>(s));
      header += ",device_buffers_mib,peak_rss_mib,device";
      out << header << "\n";
      std::printf("\n%-9s %-9s %-8s %-10s %-9s %-14s %-40s %-8s\n", "particles", "substeps", "steps/fr", "frames/s",
                  "ms/step", "p-steps/s", "ms/step: grid density pressure visc integ", "buf MiB");
      for (long target : opt.sizes) {
        for (int sub : opt.substeps) {
          std::vector<double> fps, pss;
          RunResult last;
          for (int r = 0; r < opt.repeats; ++r) {
            RunOptions ro;
            ro.scene = scene;
            ro.device = opt.device;
            ro.quiet = true;
            ro.write_output = false;
            ro.sets = {"fluid.particle_spacing=" + fmtd(spacingFor(base, static_cast<double>(target)), 9),
                       "simulation.substeps=" + std::to_string(sub), "output.isosurface.enabled=false"};
            ro.duration = opt.frames / base.simulation.frame_rate;
            last = runScene(ro);
            if (last.exit_code != 0) throw std::runtime_error("benchmark run failed: " + last.message);
            fps.push_back(last.frames / last.wall_seconds);
            pss.push_back(static_cast<double>(last.profile.particle_steps) / last.wall_seconds);
          }
          const double steps_per_frame = static_cast<double>(last.profile.steps) / last.frames;
          const double ms_step = 1e3 * last.wall_seconds / static_cast<double>(last.profile.steps);
          auto stage_ms = [&](Stage s) {
            return 1e3 * last.profile.seconds[static_cast<std::size_t>(s)] / static_cast<double>(last.profile.steps);
          };
          out << target << "," << last.particles << "," << sub << "," << steps_per_frame << "," << median(fps) << ","
              << median(pss);
          for (int s = 0; s < kNumStages; ++s) out << "," << stage_ms(static_cast<Stage>(s));
          out << "," << last.device_bytes / 1048576.0 << "," << peakRssMiB() << ",\""
              << (opt.device.empty() ? "default" : opt.device) << "\"\n";
          std::printf("%-9zu %-9d %-8.0f %-10.3f %-9.2f %-14.3g %5.2f %7.2f %8.2f %5.2f %5.2f %12.1f\n",
                      last.particles, sub, steps_per_frame, median(fps), ms_step, median(pss),
                      stage_ms(Stage::Grid), stage_ms(Stage::Density), stage_ms(Stage::Pressure),
                      stage_ms(Stage::Viscosity), stage_ms(Stage::Integrate), last.device_bytes / 1048576.0);
          std::fflush(stdout);
        }
      }
      std::cout << "wrote " << csv.string() << " (peak RSS of the whole process: " << fmtd(peakRssMiB(), 0)
                << " MiB)\n";
    }

    // ---- 2. Accuracy against time ---------------------------------------------------------
    if (!opt.speed_only && !opt.iso_only) {
      const Table mm = readCsvTable(sourcePath("tests/data/martin_moyce_1952_n2_2_front_table2.csv"));
      const std::vector<double> Te = mm.column("T"), Ze = mm.column("Z");
      // Column base a and the time scale T = t sqrt(2 g / a).
      const BlockSpec& col = base.fluid.blocks.at(0);
      const double a = col.max.x() - col.min.x();
      const double wall_x = base.domain.min.x();
      const double g = base.simulation.gravity.norm();
      const double tscale = std::sqrt(2.0 * g / a);
      const double duration = opt.accuracy_until / tscale;  // 3.6 (the default) covers the data up to Z ~ 4
      const fs::path csv = fs::path(opt.out) / "accuracy.csv";
      std::ofstream out(csv);
      out << "# sphaptics " << SPHAPTICS_VERSION
          << " accuracy benchmark: dam-break front vs Martin & Moyce 1952 (Table 2), points with 1.5 <= Z <= 4, "
             "simulated T shifted by +0.175\n";
      // (--accuracy-set: the overrides every run took, so that the file says what it measured)
      std::string overrides;
      for (const std::string& kv : opt.accuracy_sets) overrides += " " + kv;
      if (!overrides.empty()) out << "# scene overrides of every run:" << overrides << "\n";
      out << "solver,particles,dx_m,cfl,steps,eos,mean_rel_error,max_rel_error,points,wall_s,particle_steps_per_s,"
             "wall_crossings,iterations_per_step\n";
      // Each run's front per frame (the row front that is scored, and the farthest particle) and
      // each scored point's error: where a run's largest error comes from.
      const fs::path series_csv = fs::path(opt.out) / "accuracy_front.csv";
      std::ofstream series(series_csv);
      series << "# sphaptics " << SPHAPTICS_VERSION
             << " dam-break front per frame (T = t sqrt(2 g / a), Z = x / a; Z_row: the front that is scored, a full "
                "row of particles across the tank; Z_tip: the farthest particle) and per Martin & Moyce point "
                "(T_exp, Z_exp; Z_sim at T_exp - 0.175; rel = |Z_sim - Z_exp| / Z_exp)\n";
      if (!overrides.empty()) series << "# scene overrides of every run:" << overrides << "\n";
      series << "solver,particles,cfl,eos,kind,T,Z_row,Z_tip,Z_exp,rel_error\n";
      std::printf("\n%-18s %-9s %-8s %-5s %-7s %-7s %-10s %-10s %-8s %-9s %-6s\n", "solver", "particles", "dx [m]", "cfl",
                  "steps", "eos", "mean err", "max err", "wall s", "crossings", "it/step");
      // WCSPH: both equations of state at Courant 0.4 and 0.2; DFSPH (no equation of state; its
      // Courant number is fluid.dfsph.cfl): the iterations per step of its density solve.
      // (--accuracy-solvers: "dfsph-W" runs dfsph with fluid.dfsph.walls W; DFSPH takes one row per
      // Courant number, the first equation of state's.)
      for (const std::string& label : opt.accuracy_solvers)
      for (long target : opt.accuracy_sizes) {
        for (double cfl : opt.accuracy_cfls) {
          for (const std::string& eos : opt.accuracy_eos) {
            const bool dfsph = label.rfind("dfsph", 0) == 0;
            if (dfsph && eos != opt.accuracy_eos.front()) continue;
            const char* solver = label.c_str();
            const std::string walls = label.size() > 6 && dfsph ? label.substr(6) : std::string();
            RunOptions ro;
            ro.scene = scene;
            ro.device = opt.device;
            ro.quiet = true;
            ro.write_output = false;
            const double dx = spacingFor(base, target);
            // a full row of particles across the tank marks the front (analysis.h)
            const std::size_t row = static_cast<std::size_t>(std::max(1.0, std::floor((base.fluid.blocks.at(0).max.y() - base.fluid.blocks.at(0).min.y()) / dx + 1e-4)));
            ro.sets = {"fluid.particle_spacing=" + fmtd(dx, 9), std::string("fluid.solver=") + (dfsph ? "dfsph" : "wcsph"),
                       (dfsph ? "fluid.dfsph.cfl=" : "simulation.cfl=") + fmtd(cfl, 2),
                       std::string("fluid.equation_of_state=") + eos,
                       // count problems instead of stopping: the table reports them
                       "simulation.numerical_errors=warn", "output.isosurface.enabled=false"};
            if (!walls.empty()) ro.sets.push_back("fluid.dfsph.walls=" + walls);
            ro.sets.insert(ro.sets.end(), opt.accuracy_sets.begin(), opt.accuracy_sets.end());
            ro.duration = duration;
            std::vector<double> Ts{0.0}, Zs{1.0}, Ztip{1.0};
            double front_seconds = 0;
            auto probe = [&](Simulation& sim, const FrameReport&) {
              const auto t0 = std::chrono::steady_clock::now();
              Ts.push_back(sim.time() * tscale);
              const ParticleFrame frame = sim.readFrame();
              Zs.push_back((surgeFront(frame, dx, row) - wall_x) / a);
              Ztip.push_back((surgeFront(frame, dx, 1) - wall_x) / a);
              front_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            };
            const RunResult r = runScene(ro, probe);
            if (r.exit_code != 0) throw std::runtime_error("benchmark run failed: " + r.message);
            const double wall = r.wall_seconds - front_seconds;  // the probe is not the simulator's cost
            const FrontError e = frontError(Ts, Zs, Te, Ze, 0.175, 1.5, 4.0);
            const double pss = static_cast<double>(r.profile.particle_steps) / wall;
            uint64_t crossings = 0;
            for (const FrameReport& rep : r.reports) crossings += rep.wall_crossings;
            const double its = r.profile.steps ? double(r.profile.density_iterations) / double(r.profile.steps) : 0.0;
            const char* eos_col = dfsph ? "-" : eos.c_str();
            for (std::size_t k = 0; k < Ts.size(); ++k)
              series << solver << "," << r.particles << "," << cfl << "," << eos_col << ",frame," << Ts[k] << ","
                     << Zs[k] << "," << Ztip[k] << ",,\n";
            for (const FrontPoint& pt : e.detail)
              series << solver << "," << r.particles << "," << cfl << "," << eos_col << ",point," << pt.T_exp << ","
                     << pt.Z_sim << ",," << pt.Z_exp << "," << pt.rel << "\n";
            series.flush();
            out << solver << "," << r.particles << "," << dx << "," << cfl << "," << r.profile.steps << "," << eos_col
                << "," << e.mean_rel << "," << e.max_rel << "," << e.points << "," << wall << "," << pss << ","
                << crossings << "," << its << "\n";
            std::printf("%-18s %-9zu %-8.4f %-5.2f %-7llu %-7s %-10.3f %-10.3f %-8.1f %-9llu %-6.1f\n", solver, r.particles,
                        dx, cfl, static_cast<unsigned long long>(r.profile.steps), eos_col, e.mean_rel, e.max_rel, wall,
                        static_cast<unsigned long long>(crossings), its);
            std::fflush(stdout);
          }
        }
      }
      out.close();  // the plot reads the file
      std::cout << "wrote " << csv.string() << " and " << series_csv.string() << "\n";
      const std::string plot = sourcePath("scripts/plot_bench.py");
      const std::string cmd = "/usr/bin/python3 " + plot + " " + csv.string() + " " +
                              (fs::path(opt.out) / "accuracy.png").string();
      if (std::system(cmd.c_str()) != 0)
        std::cerr << "note: plotting failed (needs python3-matplotlib); run: " << cmd << "\n";
      if (opt.impact) impactPressure(opt, scene, base);  // 6. the wall pressure of both solvers at impact
    }
    // ---- 3. Isosurface cost ----------------------------------------------------------------
    if (opt.iso && !opt.accuracy_only) {
      const fs::path csv = fs::path(opt.out) / "isosurface.csv";
      std::ofstream out(csv);
      out << "# sphaptics " << SPHAPTICS_VERSION << " isosurface benchmark: dam break, scene substeps, medians of "
          << opt.repeats << " runs of " << opt.frames << " frames; surface grid spacing = "
          << kAutoIsoSpacingRatio << " dx (the default)\n";
      out << "target_particles,particles,frames_per_s_off,frames_per_s_on,frames_per_s_export,iso_ms_per_frame,"
             "handoff_ms_per_frame,writer_ms_per_frame,triangles,iso_share_on,iso_export_share,iso_export_cost_share\n";
      std::printf("\n%-9s %-10s %-10s %-10s %-10s %-10s %-10s %-10s %-9s %-9s %-9s\n", "particles", "fr/s off",
                  "fr/s on", "fr/s +obj", "iso ms/fr", "hand ms/fr", "write ms", "triangles", "iso %", "iso+obj %",
                  "cost %");
      for (long target : opt.iso_sizes) {
        // Modes: 0 off, 1 on (no files), 2 on + OBJ export. Particles are not written in any mode.
        std::array<std::vector<double>, 3> loop;
        std::vector<double> iso_ms, hand_ms, write_ms, cost_share;
        std::size_t particles = 0, triangles = 0;
        for (int r = 0; r < opt.repeats; ++r) {
          for (int mode = 0; mode < 3; ++mode) {
            RunOptions ro;
            ro.scene = scene;
            ro.device = opt.device;
            ro.quiet = true;
            ro.write_output = mode == 2;
            ro.out = (fs::path(opt.out) / "isosurface_run").string();
            ro.sets = {"fluid.particle_spacing=" + fmtd(spacingFor(base, static_cast<double>(target)), 9),
                       "output.particles=false", "output.isosurface.spacing=0",
                       std::string("output.isosurface.enabled=") + (mode ? "true" : "false")};
            ro.duration = opt.frames / base.simulation.frame_rate;
            const RunResult res = runScene(ro);
            if (res.exit_code != 0) throw std::runtime_error("benchmark run failed: " + res.message);
            loop[static_cast<std::size_t>(mode)].push_back(res.loop_seconds / res.frames);
            particles = res.particles;
            if (mode == 2) {
              iso_ms.push_back(1e3 * res.iso_seconds / res.frames);
              hand_ms.push_back(1e3 * res.output_seconds / res.frames);
              write_ms.push_back(1e3 * res.writer_seconds / (res.frames + 1));
              // Within one run (robust on a shared machine): isosurface + hand-off on the main thread
              // plus the writer thread's busy time, as if it all ran in series, over the frame loop.
              const double writer_loop = res.writer_seconds * res.frames / (res.frames + 1);
              cost_share.push_back((res.iso_seconds + res.output_seconds + writer_loop) / res.loop_seconds);
              triangles = res.surface_triangles;
            }
          }
        }
        const double off = median(loop[0]), on = median(loop[1]), exp = median(loop[2]);
        // Share of the frame: the extra loop time over the loop time with the feature on.
        const double share_on = std::max(0.0, on - off) / on, share_exp = std::max(0.0, exp - off) / exp;
        out << target << "," << particles << "," << 1 / off << "," << 1 / on << "," << 1 / exp << "," << median(iso_ms)
            << "," << median(hand_ms) << "," << median(write_ms) << "," << triangles << "," << share_on << ","
            << share_exp << "," << median(cost_share) << "\n";
        std::printf("%-9zu %-10.3f %-10.3f %-10.3f %-10.1f %-10.1f %-10.1f %-10zu %-9.1f %-9.1f %-9.1f\n", particles,
                    1 / off, 1 / on, 1 / exp, median(iso_ms), median(hand_ms), median(write_ms), triangles,
                    100 * share_on, 100 * share_exp, 100 * median(cost_share));
        std::fflush(stdout);
      }
      std::cout << "wrote " << csv.string()
                << " (iso % and iso+obj %: (t_on - t_off) / t_on from the medians of separate runs, noisy on a shared "
                   "machine; cost %: (isosurface + hand-off + writer thread) / frame loop within each export run)\n";
    }
    if (opt.forces && !opt.speed_only && !opt.accuracy_only && !opt.iso_only) forceChecks(opt);
    if (opt.cloth && !opt.accuracy_only && !opt.iso_only) return clothSweep(opt);
    return kExitOk;
  } catch (const InputError& e) {
    std::cerr << e.what() << "\n";
    return kExitBadInput;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace sph::app
