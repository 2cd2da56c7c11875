// Physics against the world: closed forms and experiments from shared/reference (copied to
// tests/data with their headers). Each test runs a small scene from scenes/tests/ on the default
// OpenCL device (pocl on CI). Tolerances come from the physics, stated next to each check.
#include "cli/analysis.h"
#include "cli/runner.h"
#include "tests/scene_runs.h"
#include "core/errors.h"
#include "core/model.h"
#include "core/probes.h"
#include "io/scene_loader.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <regex>

using namespace sph;

namespace {

using testing::dataPath;
using testing::quietRun;
using testing::scenePath;

double speed(const ParticleFrame& f, std::size_t i) {
  return std::sqrt(double(f.vx[i]) * f.vx[i] + double(f.vy[i]) * f.vy[i] + double(f.vz[i]) * f.vz[i]);
}

}  // namespace

TEST_CASE("A lattice at rest has the rest density in the interior", "[physics]") {
  // Closed box completely filled with a lattice, no gravity: after one tiny step the density of
  // particles at least one support radius from every wall must be rho0 within 1 % (the cubic
  // spline's lattice sum at H = 2 dx is 1.000; Wendland C2 needs H = 3 dx for the same).
  for (const char* kernel : {"cubic_spline", "wendland_c2"}) {
    const std::string ratio = std::string(kernel) == "wendland_c2" ? "3.0" : "2.0";
    SceneSpec spec = io::loadScene(scenePath("tiny_tank.yaml"),
                                   {"simulation.gravity=[0,0,0]", std::string("simulation.kernel=") + kernel,
                                    "simulation.support_ratio=" + ratio, "domain.closed.z_max=true",
                                    "fluid.blocks=[{min: [0,0,0], max: [0.2,0.1,0.2]}]"});
    Compiled c = compile(spec);
    ClContext cl;
    Simulation sim(c.model, c.initial, cl);
    sim.step(1e-7);
    const ParticleFrame f = sim.readFrame();
    const double H = c.model.support;
    int interior = 0;
    double worst = 0;
    for (std::size_t i = 0; i < f.size(); ++i) {
      const Eigen::Vector3d x(f.x[i], f.y[i], f.z[i]);
      const double wall = std::min((x - spec.domain.min).minCoeff(), (spec.domain.max - x).minCoeff());
      if (wall < H) continue;
      ++interior;
      worst = std::max(worst, std::abs(f.density[i] / 1000.0 - 1.0));
    }
    INFO(kernel << ": " << interior << " interior particles, worst relative density error " << worst);
    CHECK(interior > 100);
    CHECK(worst < 0.01);
  }
}

TEST_CASE("Hydrostatic tank: pressure follows rho0 g (H - z) after settling", "[physics]") {
  // Reference: shared/reference/hydrostatic_tank_analytic.csv, p = rho0 g (H - z).
  const app::Table ref = app::readCsvTable(dataPath("hydrostatic_tank_analytic.csv"));
  const std::vector<double> ref_y_over_H = ref.column("y_over_H"), ref_p_nd = ref.column("p_nd");

  // Settle (gravity ramped in over 0.4 s), then probe like a pressure gauge: average over the
  // central part of the tank in horizontal layers one spacing thick, and over the last 0.3 s
  // (weakly compressible SPH carries acoustic waves, period ~ 4 H / c0 = 40 ms here).
  // Depth: at rest the pressure at a gauge is the weight of the water above it per unit area,
  // so the depth in the closed form is the thickness that water has at rest density: the
  // number of particles above the gauge (whole tank) times dx^3 over the tank's floor area.
  // (The free surface's height is not used: weakly compressible SPH compresses the column by
  // ~1 %, and its top particle layers pack closer than dx, so surface height + dx/2 came out
  // 3 mm short of the 0.2 m of water in the tank and put ~30 Pa of bias on every layer.)
  app::RunOptions o = quietRun("hydrostatic.yaml");
  ParticleFrame last;
  struct Layer {
    double p = 0, z = 0, above = 0;  // sums of pressure, height and particles above, over the samples
    int n = 0;
  };
  std::map<int, Layer> layers;
  // The scene's probes (points at fixed heights, two gauges): their readings and, for each point,
  // the water above it (particle count), summed over the same frames.
  const std::vector<double> probe_z{0.02, 0.05, 0.08, 0.11, 0.14, 0.17};  // p02 .. p17 in hydrostatic.yaml
  std::vector<double> probe_p(probe_z.size() + 1, 0.0), probe_above(probe_z.size() + 1, 0.0);
  std::vector<double> gauge_h(2, 0.0);
  int probe_frames = 0;
  bool air_dry = true;
  app::RunResult r = app::runScene(o, [&](Simulation& sim, const FrameReport&) {
    if (sim.time() < 1.0 - 1e-9) return;
    last = sim.readFrame();
    std::vector<float> zs(last.z);
    std::sort(zs.begin(), zs.end());
    const ProbeSample* ps = sim.latestProbeSample();
    REQUIRE(ps != nullptr);
    REQUIRE(ps->points.size() == probe_z.size() + 2);
    for (std::size_t k = 0; k < probe_z.size() + 1; ++k) {  // the six centre probes, then 'wall' (z = 0.05)
      const std::size_t at = k < probe_z.size() ? k : probe_z.size() + 1;
      const double z = k < probe_z.size() ? probe_z[k] : 0.05;
      probe_p[k] += ps->points[at].pressure;
      probe_above[k] += static_cast<double>(zs.end() - std::upper_bound(zs.begin(), zs.end(), static_cast<float>(z)));
    }
    air_dry = air_dry && std::isnan(ps->points[probe_z.size()].pressure);
    for (std::size_t g = 0; g < 2; ++g) gauge_h[g] += ps->heights[g];
    ++probe_frames;
    for (std::size_t i = 0; i < last.size(); ++i) {
      if (std::abs(last.x[i] - 0.1) > 0.05 || std::abs(last.y[i] - 0.03) > 0.01) continue;
      auto& L = layers[static_cast<int>(std::floor(last.z[i] / 0.01))];
      L.p += last.pressure[i];
      L.z += last.z[i];
      L.above += static_cast<double>(zs.end() - std::upper_bound(zs.begin(), zs.end(), last.z[i]));
      ++L.n;
    }
  });
  REQUIRE(r.exit_code == 0);
  REQUIRE(last.size() == 2400);
  const double rho0 = 1000, g = 9.81, dx = 0.01, h = 0.01;
  const double area = 0.2 * 0.06;                    // the tank's floor (unit: m^2)
  const double H = last.size() * dx * dx * dx / area;  // water depth at rest density (unit: m)
  int compared = 0;
  double worst = 0;
  for (auto& [k, L] : layers) {
    const double z = L.z / L.n;                              // the gauge's height (unit: m)
    const double depth = L.above / L.n * dx * dx * dx / area; // water above it, at rest density (unit: m)
    if (depth < 2 * h) continue;  // the kernel support is truncated near the free surface
    const double p = L.p / L.n;
    // The closed form p = rho0 g H (1 - y/H), read from the reference table at y/H = 1 - depth/H.
    const double zn = 1.0 - depth / H;
    std::size_t j = 1;
    while (j + 1 < ref_y_over_H.size() && ref_y_over_H[j] < zn) ++j;
    const double w = (zn - ref_y_over_H[j - 1]) / (ref_y_over_H[j] - ref_y_over_H[j - 1]);
    const double p_ref = rho0 * g * H * (ref_p_nd[j - 1] + w * (ref_p_nd[j] - ref_p_nd[j - 1]));
    INFO("z = " << z << " m, depth " << depth << " m: p = " << p << " Pa, closed form " << p_ref << " Pa");
    worst = std::max(worst, std::abs(p / p_ref - 1));
    CHECK(std::abs(p - p_ref) <= 0.05 * p_ref);  // the 5 %
    ++compared;
  }
  CHECK(compared >= 15);
  WARN("hydrostatic tank: " << compared << " layers from the floor up, worst pressure error " << 100 * worst << " %");

  // Probes (issue 12): Shepard-interpolated pressure at fixed points, against the weight of the
  // water above each (as for the layers), within the 2 %, at every probe at least two
  // smoothing lengths below the surface; the one on the side wall too. One above the water is dry.
  REQUIRE(probe_frames > 0);
  double worst_probe = 0;
  for (std::size_t k = 0; k < probe_p.size(); ++k) {
    const double p = probe_p[k] / probe_frames;
    const double depth = probe_above[k] / probe_frames * dx * dx * dx / area;
    if (depth < 2 * h) continue;
    const double p_ref = rho0 * g * depth;
    INFO("probe " << k << ": depth " << depth << " m, p = " << p << " Pa, closed form " << p_ref << " Pa");
    CHECK(std::abs(p - p_ref) <= 0.02 * p_ref);
    worst_probe = std::max(worst_probe, std::abs(p / p_ref - 1));
    WARN("probe " << k << " depth " << depth << " m: " << 100 * (p / p_ref - 1) << " %");
  }
  CHECK(air_dry);
  // Gauges (centre and corner): the column's height within one spacing of the water's depth.
  for (std::size_t g = 0; g < 2; ++g) {
    INFO("gauge " << g << ": height " << gauge_h[g] / probe_frames << " m, water depth " << H << " m");
    CHECK(std::abs(gauge_h[g] / probe_frames - H) < dx);
  }
  WARN("hydrostatic probes: worst pressure error " << 100 * worst_probe << " %; gauges " << gauge_h[0] / probe_frames
                                                   << " m and " << gauge_h[1] / probe_frames << " m for " << H << " m of water");
  // Residual motion: small against the problem's velocity scale, the gravity-wave speed sqrt(g H)
  // (what remains is weakly compressible SPH's acoustic noise; a sloshing or unstable tank moves
  // at a sizeable fraction of it).
  double vmax = 0, v2 = 0;
  for (std::size_t i = 0; i < last.size(); ++i) vmax = std::max(vmax, speed(last, i)), v2 += speed(last, i) * speed(last, i);
  const double vrms = std::sqrt(v2 / last.size());
  INFO("residual speed: max " << vmax << " m/s, rms " << vrms << " m/s, sqrt(g H) = " << std::sqrt(g * H) << " m/s");
  CHECK(vmax < 0.05 * std::sqrt(g * H));
  CHECK(vrms < 0.01 * std::sqrt(g * H));
}

TEST_CASE("Dam break: surge front against Martin & Moyce (1952)", "[physics]") {
  const app::Table mm = app::readCsvTable(dataPath("martin_moyce_1952_n2_2_front_table2.csv"));
  const double a = 0.1, g = 9.81, tscale = std::sqrt(2 * g / a);
  std::vector<double> Ts{0.0}, Zs{1.0};
  std::size_t n0 = 0;
  bool count_conserved = true, inside = true;
  double worst_bound = -1e9;
  app::RunOptions o = quietRun("dam_break_slab.yaml");
  std::vector<double> taus, gauge_inner;  // the scene's height gauge 2.5 dx from the back wall
  app::RunResult r = app::runScene(o, [&](Simulation& sim, const FrameReport& rep) {
    if (const ProbeSample* ps = sim.latestProbeSample()) {
      taus.push_back(ps->time * std::sqrt(g / a));
      gauge_inner.push_back(ps->heights.at(1) / (2 * a));
    }
    const ParticleFrame f = sim.readFrame();
    if (n0 == 0) n0 = f.size();
    count_conserved = count_conserved && f.size() == n0;
    inside = inside && rep.wall_crossings == 0 && rep.outside == 0;
    // The front: the leading full row across the slab (8 particles of dx = 5 mm in 0.04 m), not a
    // droplet jetted ahead of the tip (which ran up to 10 % ahead of the water body, measured).
    const double T = sim.time() * tscale, Z = app::surgeFront(f, 0.005, 8) / a;
    Ts.push_back(T);
    Zs.push_back(Z);
    worst_bound = std::max(worst_bound, Z - (1 + 2 * T));  // shallow-water bound (Ritter)
  });
  REQUIRE(r.exit_code == 0);
  CHECK(count_conserved);
  CHECK(inside);
  // Never ahead of the inviscid shallow-water front Z = 1 + 2T.
  CHECK(worst_bound <= 0.0);
  // Within 10 % of the experiment for 1.5 <= Z <= 4, simulated T shifted by +0.175 (gate opening).
  const app::FrontError e = app::frontError(Ts, Zs, mm.column("T"), mm.column("Z"), 0.175, 1.5, 4.0);
  INFO("compared " << e.points << " points, mean relative error " << e.mean_rel << ", max " << e.max_rel);
  CHECK(e.points >= 8);
  CHECK(e.max_rel < 0.10);

  // Height gauge (issue 12) 2.5 dx from the back wall, against Martin & Moyce's Table 6 (H = h / 2a
  // against tau = t sqrt(g / a)), while the column collapses (tau <= 1.5). (The scene's gauge on
  // the wall itself dips by up to 4 dx for a frame at times, where the first particle layer comes
  // off the wall under the clamped pressure: it reads the fluid, but is no gauge for this test.)
  // Tolerance: the gate's opening time (the reference's +0.175 in T, 0.124 in tau) times the
  // table's slope (|dH/dtau| ~ 0.3), plus half a spacing of height resolution (dx / 2 over 2a):
  // 0.037 + 0.0125 = 0.05. Later the simulated column stays higher than the experiment (up to
  // 0.09 at tau = 2.2-2.45, measured), which README reports.
  const app::Table mh = app::readCsvTable(dataPath("martin_moyce_1952_n2_2_height_table6.csv"));
  const std::vector<double> mt = mh.column("tau"), mH = mh.column("H");
  REQUIRE(taus.size() > 10);
  int height_points = 0;
  for (std::size_t k = 0; k < mt.size(); ++k) {
    if (mt[k] > 1.5) continue;
    std::size_t j = 1;
    while (j + 1 < taus.size() && taus[j] < mt[k]) ++j;
    const double w = (mt[k] - taus[j - 1]) / (taus[j] - taus[j - 1]);
    const double Hs = gauge_inner[j - 1] + w * (gauge_inner[j] - gauge_inner[j - 1]);
    INFO("tau = " << mt[k] << ": gauge H = " << Hs << ", Martin & Moyce " << mH[k]);
    CHECK(std::abs(Hs - mH[k]) <= 0.05);
    ++height_points;
  }
  CHECK(height_points >= 5);
}

TEST_CASE("Two phases: heavy stays under light, no mixing beyond two layers", "[physics]") {
  // Light (500 kg/m^3) resting on heavy (1000 kg/m^3), and the same at a density ratio of 10
  // (100 over 1000): after settling, every heavy particle lies below every light one, allowing
  // two particle layers of interface roughness (the criterion).
  for (const char* light : {"500", "100"}) {
    ParticleFrame last;
    app::RunOptions o = quietRun("two_layers.yaml", {std::string("fluid.phases[1].rest_density=") + light});
    app::RunResult r = app::runScene(o, [&](Simulation& sim, const FrameReport&) { last = sim.readFrame(); });
    REQUIRE(r.exit_code == 0);
    const double dx = 0.01, interface_z = 0.08;
    double heavy_top = -1, light_bottom = 1;
    for (std::size_t i = 0; i < last.size(); ++i) {
      if (last.phase[i] == 0) heavy_top = std::max(heavy_top, double(last.z[i]));
      else light_bottom = std::min(light_bottom, double(last.z[i]));
    }
    INFO("light density " << light << ": highest heavy particle z = " << heavy_top
                          << " m, lowest light particle z = " << light_bottom << " m");
    CHECK(heavy_top < interface_z + 2 * dx);
    CHECK(light_bottom > interface_z - 2 * dx);
  }
}

TEST_CASE("A light blob released at the bottom rises", "[physics]") {
  // Buoyancy: a 500 kg/m^3 blob under 1000 kg/m^3 fluid must rise; its centre of mass starts at
  // z = 0.05 m and, driven by (rho_h - rho_l) g, rises several spacings within 1 s.
  std::vector<double> centre;
  app::RunOptions o = quietRun("rising_blob.yaml");
  app::RunResult r = app::runScene(o, [&](Simulation& sim, const FrameReport&) {
    const ParticleFrame f = sim.readFrame();
    double z = 0;
    int n = 0;
    for (std::size_t i = 0; i < f.size(); ++i)
      if (f.phase[i] == 1) z += f.z[i], ++n;
    centre.push_back(z / n);
  });
  REQUIRE(r.exit_code == 0);
  INFO("blob centre: start 0.05 m, after 0.5 s " << centre[centre.size() / 2] << " m, end " << centre.back() << " m");
  CHECK(centre.back() > 0.05 + 3 * 0.01);
  CHECK(centre.back() > centre[centre.size() / 2]);
}

TEST_CASE("Determinism: the same scene twice gives bitwise equal states", "[physics]") {
  app::RunOptions o = quietRun("dam_break_slab.yaml");
  o.duration = 0.05;
  const app::RunResult a = app::runScene(o);
  const app::RunResult b = app::runScene(o);
  REQUIRE(a.exit_code == 0);
  REQUIRE(b.exit_code == 0);
  CHECK(a.state_hash == b.state_hash);
  // and the hash sees the state: a different duration gives a different one
  o.duration = 0.06;
  const app::RunResult c = app::runScene(o);
  CHECK(c.state_hash != a.state_hash);
}

TEST_CASE("Stage mask: a stage the scene does not call for enqueues no kernel", "[physics]") {
  app::RunOptions o = quietRun("tiny_tank.yaml");
  o.duration = 0.05;
  const app::RunResult on = app::runScene(o);
  REQUIRE(on.exit_code == 0);
  // pressure and viscosity both on: one fused pass per step, no separate passes
  CHECK(on.dispatch_counts.count("pressure_viscosity_force") == 1);
  CHECK(on.dispatch_counts.at("pressure_viscosity_force") == on.profile.steps);
  CHECK(on.dispatch_counts.count("pressure_force") == 0);
  CHECK(on.dispatch_counts.count("viscosity_force") == 0);
  CHECK(on.dispatch_counts.count("colour_diffuse") == 0);  // colour_diffusion is 0 in the scene
  o.disable = {"viscosity"};
  const app::RunResult off = app::runScene(o);
  REQUIRE(off.exit_code == 0);
  CHECK(off.dispatch_counts.count("viscosity_force") == 0);
  CHECK(off.dispatch_counts.count("pressure_viscosity_force") == 0);
  CHECK(off.dispatch_counts.at("pressure_force") == off.profile.steps);
  CHECK(off.profile.seconds[static_cast<std::size_t>(Stage::Viscosity)] == 0.0);
  CHECK(off.state_hash != on.state_hash);  // and it mattered
  // colour diffusion runs only when the scene asks for it
  o.disable.clear();
  o.sets = {"fluid.colour_diffusion=1e-4"};
  const app::RunResult col = app::runScene(o);
  REQUIRE(col.exit_code == 0);
  CHECK(col.dispatch_counts.at("colour_diffuse") == col.profile.steps);
}

TEST_CASE("Inflow: a nozzle emits at its rate and stops at the particle budget", "[physics]") {
  // A circular nozzle of radius 2 dx emits one layer (13 lattice points) per dx travelled:
  // rate = 13 speed / dx particles per second.
  const std::vector<std::string> sets = {
      "fluid.blocks=[]",
      "fluid.inflows=[{position: [0.1, 0.05, 0.15], direction: [0, 0, -1], radius: 0.02, speed: 0.5, start: 0.0, "
      "stop: 0.1}]"};
  app::RunOptions o = quietRun("tiny_tank.yaml", sets);
  o.duration = 0.15;
  const app::RunResult r = app::runScene(o);
  REQUIRE(r.exit_code == 0);
  const double expected = 13 * (0.5 * 0.1 / 0.01);  // layers emitted while active
  INFO("emitted " << r.particles << ", expected about " << expected);
  CHECK(std::abs(double(r.particles) - expected) <= 2 * 13);  // within two layers (step granularity)
  // Emitting for 0.3 s (195 particles) with a budget of 100 stops there, with a message, not a crash.
  o.sets = {"fluid.blocks=[]",
            "fluid.inflows=[{position: [0.1, 0.05, 0.15], direction: [0, 0, -1], radius: 0.02, speed: 0.5, "
            "start: 0.0, stop: 0.3}]",
            "fluid.max_particles=100"};
  o.duration = 0.35;
  bool told = false;
  const app::RunResult capped = app::runScene(o, [&](Simulation&, const FrameReport& rep) {
    for (const auto& m : rep.messages) told = told || m.find("particle budget") != std::string::npos;
  });
  REQUIRE(capped.exit_code == 0);
  CHECK(capped.particles <= 100);
  CHECK(capped.particles > 100 - 13);
  CHECK(told);
}

TEST_CASE("Numerical failure under policy abort exits 4 naming frame, time and stage", "[physics]") {
  // One step per frame at 5 frames/s with CFL control off (policy 'warn' for the time step):
  // dt = 0.2 s is ~2000x the CFL limit, so particles fly more than h per step.
  app::RunOptions o = quietRun("tiny_tank.yaml", {"simulation.time_step_control=warn", "simulation.substeps=1",
                                                  "simulation.frame_rate=5", "simulation.numerical_errors=abort"});
  o.duration = 1.0;
  const app::RunResult r = app::runScene(o);
  CHECK(r.exit_code == kExitNumerical);
  // Which frame it is depends on the wall model (frame 1 with Akinci's single-term walls, frame 0
  // with the pressure-extrapolating ones); the message must name a frame and its end time.
  std::smatch m;
  REQUIRE(std::regex_search(r.message, m, std::regex("at frame ([0-9]+), t = ([0-9.]+) s")));
  CHECK(std::stod(m[2].str()) == Approx(0.2 * (std::stoi(m[1].str()) + 1)));
  CHECK(r.message.find("moved more than h") != std::string::npos);
  CHECK(r.message.find("stage: integrate") != std::string::npos);
  // Under policy 'warn' the same run goes on and reports the problems per frame.
  o.sets.back() = "simulation.numerical_errors=warn";
  const app::RunResult w = app::runScene(o);
  CHECK(w.exit_code == 0);
  REQUIRE(!w.reports.empty());
  CHECK(!w.reports.front().clean());
}
