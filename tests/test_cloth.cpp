// Cloth (issue 11, core/cloth.h): the spring table, both solvers against closed forms (a hanging
// chain at rest, a mass on a spring, a chain between two anchors against the catenary), tearing,
// the stage mask, determinism and bad input. No fluid: each scene runs in a second or two.
#include "core/cl_context.h"
#include "core/cloth.h"
#include "core/errors.h"
#include "core/model.h"
#include "core/simulation.h"
#include "io/cloth_writer.h"
#include "io/obj_io.h"
#include "io/scene_loader.h"
#include "tests/cloth_scenes.h"
#include "tests/run_binary.h"
#include "tests/scene_issues.h"
#include "tests/temp_dir.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <sstream>
#include <vector>

using namespace sph;

namespace {

const double kG = 9.81;

using sph::testing::clothScene;
using sph::testing::anchoredSquare;
using sph::testing::dynamicBall;

/// A vertical chain of `masses` free nodes of mass m hung by springs (rest length L0, stiffness k)
/// from an anchored top node: a cloth one node wide along y, turned so that y points up.
ClothSpec chain(int masses, double m, double L0, double k, double c, ClothSolver solver) {
  ClothSpec ch;
  ch.name = "chain";
  ch.resolution_x = 1;
  ch.resolution_y = masses + 1;
  ch.width = 0.01;
  ch.length = masses * L0;
  ch.areal_density = m * (masses + 1) / (ch.width * ch.length);  // every node weighs m
  ch.position = Eigen::Vector3d(0.5, 0.5, 0.6);
  ch.orientation_axis = Eigen::Vector3d::UnitX();
  ch.orientation_angle = 90;  // cloth y -> world z
  ch.stretch_stiffness = k;
  ch.shear_stiffness = 0;
  ch.bend_stiffness = 0;
  ch.damping = c;
  ch.solver = solver;
  ch.iterations = 20;
  ClothAnchorSpec top;
  top.type = AnchorType::Node;
  top.i = 0;
  top.j = masses;
  ch.anchors.push_back(top);
  return ch;
}

std::vector<Eigen::Vector4f> positions(Simulation& sim) {
  std::vector<Eigen::Vector4f> x, v;
  sim.cloth()->read(x, v);
  return x;
}

}  // namespace

TEST_CASE("Cloth: the spring table holds each spring in both ends' rows, and colours share no node", "[cloth]") {
  // A 4 x 3 cloth with every spring kind: stretch 3*3 + 4*2 = 17, shear 2*3*2 = 12, bend 2*3 + 4*1 = 10.
  ClothSpec c;
  c.name = "c";
  c.resolution_x = 4;
  c.resolution_y = 3;
  std::vector<InputIssue> issues;
  const cloth::ClothModel m = cloth::compileCloths({c}, issues);
  REQUIRE(issues.empty());
  REQUIRE(m.springs() == 17u + 12u + 10u);
  REQUIRE(m.row_start.back() == 2 * m.springs());
  for (uint32_t i = 0; i < m.nodes(); ++i)
    for (uint32_t e = m.row_start[i]; e < m.row_start[i + 1]; ++e) {
      const uint32_t s = m.spring[e], j = m.other[e];
      CHECK(((m.ends[2 * s] == i && m.ends[2 * s + 1] == j) || (m.ends[2 * s] == j && m.ends[2 * s + 1] == i)));
    }
  // Per colour, each node has at most one spring (slot table), and every entry has a slot.
  std::vector<int> seen(m.spring.size(), 0);
  for (uint32_t col = 0; col < m.num_colours; ++col)
    for (uint32_t i = 0; i < m.nodes(); ++i)
      if (m.slot[col * m.nodes() + i] != cloth::kNoSlot) ++seen[m.slot[col * m.nodes() + i]];
  CHECK(std::all_of(seen.begin(), seen.end(), [](int n) { return n == 1; }));
  // Rest lengths: grid spacing 0.1/3 along x, 0.1/2 along y.
  CHECK(m.prm[0].x() == Approx(0.1 / 3).epsilon(1e-6));
}

TEST_CASE("Cloth: a hanging chain at rest stretches spring i by (N - i + 1) m g / k (both solvers)", "[cloth][physics]") {
  // N = 5 masses of m = 10 g on springs k = 10 N/m, L0 = 0.1 m. At rest spring i from the top
  // carries the N - i + 1 masses below it: stretch (N - i + 1) m g / k (9.8 mm for the lowest).
  // The dashpots (c = 1.1 N s/m: damping ratio 0.5 on the slowest mode, 9 rad/s) settle the
  // chain to e^-4.5t: after 3 s the residual motion is 1e-6 of the 0.15 m initial fall, far below
  // the 1e-3 relative tolerance of the issue on the smallest stretch (1e-5 m).
  const int N = 5;
  const double m = 0.01, k = 10.0, L0 = 0.1, c = 1.1;
  ClContext cl;
  for (ClothSolver solver : {ClothSolver::Explicit, ClothSolver::Xpbd}) {
    INFO("solver " << (solver == ClothSolver::Xpbd ? "xpbd" : "explicit"));
    const Compiled comp = compile(clothScene(chain(N, m, L0, k, c, solver), 60, 4, 3.0));
    Simulation sim(comp.model, comp.initial, cl);
    for (int f = 0; f < comp.model.num_frames; ++f) sim.advanceFrame();
    const auto x = positions(sim);
    // Node j (0 = bottom, N = anchored top); spring i from the top joins nodes N - i + 1 and N - i.
    for (int i = 1; i <= N; ++i) {
      const double stretch = (x[N - i + 1].z() - x[N - i].z()) - L0;
      const double expected = (N - i + 1) * m * kG / k;
      INFO("spring " << i << ": stretch " << stretch << " m, expected " << expected << " m");
      CHECK(std::abs(stretch - expected) <= 1e-3 * expected);
    }
  }
}

TEST_CASE("Cloth: the anchors of a hanging cloth at rest carry its full weight under air drag (both solvers)",
          "[cloth][physics]") {
  // A 5 x 5 cloth, 8 cm square, 10 g (1.25 kg/m^2), hung from its top edge in a vertical plane,
  // air_damping c = 20/s, dt = 1/960 s: dt c = 0.021. Air drag acts on velocity only, so at rest
  // the springs on the anchored edge carry the weight of the 20 free nodes, m g, exactly (statics:
  // the free nodes' force balance summed, the inner springs cancel). A predictor that divides
  // gravity by 1 + dt c as well leaves them m g / (1 + dt c), 2.1 % short. The drag damps every
  // mode at c/2 = 10/s: after 1 s the release transient (amplitude m g) is e^-10 = 5e-5 of it.
  // Tolerance 1e-3 relative, a twentieth of dt c: float rounding of the per-step corrections
  // (dt^2 g = 1.1e-5 m against a position ulp of 1.5e-8 m) stays below it.
  ClContext cl;
  for (ClothSolver solver : {ClothSolver::Xpbd, ClothSolver::Explicit}) {
    INFO("solver " << (solver == ClothSolver::Xpbd ? "xpbd" : "explicit"));
    ClothSpec s;
    s.name = "curtain";
    s.resolution_x = s.resolution_y = 5;
    s.width = s.length = 0.08;
    s.areal_density = 0.01 / (0.08 * 0.08);
    s.position = Eigen::Vector3d(0.5, 0.5, 0.06);
    s.stretch_stiffness = 100;
    s.shear_stiffness = 10;
    s.bend_stiffness = 1;
    s.orientation_axis = Eigen::Vector3d::UnitX();
    s.orientation_angle = 90;  // cloth y -> world z: the y_max edge on top
    s.air_damping = 20.0;
    s.solver = solver;
    ClothAnchorSpec top;
    top.type = AnchorType::Edge;
    top.edge = ClothEdge::YMax;
    s.anchors.push_back(top);
    const Compiled comp = compile(clothScene(s, 60, 16, 1.0));
    const cloth::ClothModel& m = comp.model.cloth;
    double free_mass = 0;
    for (std::size_t k = 0; k < m.nodes(); ++k)
      if (m.x0[k].w() > 0.0f) free_mass += m.mass[k];
    Simulation sim(comp.model, comp.initial, cl);
    for (int f = 0; f < comp.model.num_frames; ++f) sim.advanceFrame();
    const cloth::ClothReport r = sim.cloth()->report(0, Eigen::Vector3d(0, 0, -kG));
    const double weight = free_mass * kG;
    INFO("anchor force " << r.anchor_force.transpose() << " N, weight of the free nodes " << weight
                         << " N, relative error " << (-r.anchor_force.z() - weight) / weight << ", dt c = " << 20.0 / 960);
    CHECK(std::abs(-r.anchor_force.z() - weight) <= 1e-3 * weight);
    CHECK(std::abs(r.anchor_force.x()) <= 1e-3 * weight);
    CHECK(std::abs(r.anchor_force.y()) <= 1e-3 * weight);
  }
}

TEST_CASE("Cloth: sphaptics run writes cloth.csv with the anchor reaction and a coloured OBJ per frame", "[cloth][io]") {
  // The curtain above as a scene file, run by the command line for 1 s: cloth.csv has a row per
  // frame (61 with frame 0) whose anchor_fz at the end is minus the free nodes' weight (20 of 25
  // nodes of 0.4 g: 0.07848 N) within 1e-3, and cloth_curtain_0060.obj the 4 x 4 cells' 32
  // triangles with a colour per vertex.
  using sph::testing::TempDir;
  TempDir dir;
  const auto scene = dir.write("curtain.yaml",
                               "simulation: {duration: 1.0, frame_rate: 60, substeps: 16}\n"
                               "domain: {min: [0, 0, 0], max: [1, 1, 1]}\n"
                               "fluid: {particle_spacing: 0.05}\n"
                               "cloth:\n"
                               "  - name: curtain\n"
                               "    width: 0.08\n"
                               "    length: 0.08\n"
                               "    resolution_x: 5\n"
                               "    resolution_y: 5\n"
                               "    position: [0.5, 0.5, 0.06]\n"
                               "    orientation_axis: [1, 0, 0]\n"
                               "    orientation_angle: 90\n"
                               "    areal_density: 1.5625\n"
                               "    stretch_stiffness: 100\n"
                               "    shear_stiffness: 10\n"
                               "    bend_stiffness: 1\n"
                               "    air_damping: 20\n"
                               "    anchors: [{type: edge, edge: y_max}]\n"
                               "output: {particles: false}\n");
  const sph::testing::Result r = sph::testing::sphaptics(dir.path, {"run", scene.string(), "-q", "-o", (dir.path / "run").string()});
  INFO(r.err);
  REQUIRE(r.code == 0);
  std::istringstream csv(sph::testing::readFile(dir.path / "run" / "cloth.csv"));
  std::string line, last;
  int rows = 0;
  bool header = false;
  while (std::getline(csv, line)) {
    if (line.empty() || line[0] == '#') continue;
    if (line.rfind("time,cloth,", 0) == 0) {
      header = line.find("anchor_fx,anchor_fy,anchor_fz") != std::string::npos;
      continue;
    }
    ++rows;
    last = line;
  }
  CHECK(header);
  CHECK(rows == 61);
  const double fz = std::stod(last.substr(last.rfind(',') + 1));
  const double weight = 20 * 0.0004 * kG;
  INFO("last row: " << last << "; weight of the free nodes " << weight << " N");
  CHECK(std::abs(-fz - weight) <= 1e-3 * weight);
  const TriMesh obj = io::readObj((dir.path / "run" / "cloth_curtain_0060.obj").string());
  CHECK(obj.numTriangles() == 32u);
  CHECK(obj.colours.size() == obj.positions.size());
}

TEST_CASE("Cloth: the explicit solver subdivides a step past 2 sqrt(m/k) and stays stable", "[cloth][physics]") {
  // One mass m = 10 g on a spring k = 10^4 N/m (explicit, no damping): stability limit
  // 2 sqrt(m/k) = 2 ms, taken with a 10 % margin (ClothModel::explicit_dt_limit = 1.8 ms). Frames of
  // 1/60 s in one step each: every step runs ceil(16.7 / 1.8) = 10 substeps. Released at its rest
  // length, it oscillates about m g / k below with amplitude A = m g / k (9.8 um). Symplectic Euler
  // at substep h keeps x^2 + v^2 / omega^2 - h x v constant, so from rest at A its largest
  // excursion is A / sqrt(1 - (omega h / 2)^2) = 1.81 A at omega h = 1.67: checked over 1 s (160
  // periods) within 5 % of that (float rounding of z near 0.1 m: 1e-3 A). Unsubdivided (omega dt =
  // 16.7) it grows by ~ (omega dt)^2 per step and overflows within the second.
  const double m = 0.01, k = 1e4;
  ClothSpec s = chain(1, m, 0.1, k, 0.0, ClothSolver::Explicit);
  s.position.z() = 0.1;
  ClContext cl;
  const Compiled comp = compile(clothScene(s, 60, 1, 1.0));
  const double limit = 1.8 * std::sqrt(m / k);
  CHECK(comp.model.cloth.explicit_dt_limit == Approx(limit).epsilon(1e-6));
  Simulation sim(comp.model, comp.initial, cl);
  const double z_eq = comp.model.cloth.x0[0].z() - m * kG / k;
  double worst = 0;
  for (int f = 0; f < comp.model.num_frames; ++f) {
    sim.advanceFrame();
    CHECK(sim.cloth()->lastSubsteps() == static_cast<int>(std::ceil((1.0 / 60) / limit)));
    worst = std::max(worst, std::abs(double(positions(sim)[0].z()) - z_eq));
  }
  const double h = (1.0 / 60) / std::ceil((1.0 / 60) / limit), wh = std::sqrt(k / m) * h;
  const double bound = m * kG / k / std::sqrt(1 - wh * wh / 4);
  INFO("largest distance from the rest point " << worst << " m; symplectic Euler's bound " << bound << " m");
  CHECK(std::isfinite(worst));
  CHECK(worst <= 1.05 * bound);
}

TEST_CASE("Cloth: a very stiff explicit spring far from the origin gains no energy from float rounding", "[cloth][physics]") {
  // m = 10 g on k = 10^6 N/m (omega = 10^4 rad/s), rest length 1 cm, its node at z = 0.7 m where a
  // float position rounds to 6e-8 m, more than half the static stretch m g / k = 9.8e-8 m (the
  // length's own float resolution, 1e-9 m at 1 cm, is 1 % of it). Released where it was placed, it
  // oscillates with the amplitude A0 = |L - L0 - m g / k| of the placement (L from the float
  // positions, in double), so its speed stays below omega A0 / sqrt(1 - (omega h / 2)^2)
  // (symplectic Euler at substep h; 10 % margin for that 1 %) over 0.2 s (318 periods, 1,200
  // substeps, sampled 120 times): measured 0.995 of it. Positions stored as plain floats (a
  // mutation) re-round every substep; that noise, k x 6e-8 m = 0.06 N on a 0.1 N weight, pumped the
  // speed to 6.1 times the bound.
  const double m = 0.01, k = 1e6, L0 = 0.01;
  ClothSpec s = chain(1, m, L0, k, 0.0, ClothSolver::Explicit);
  s.position.z() = 0.7;
  ClContext cl;
  const Compiled comp = compile(clothScene(s, 600, 1, 0.2));
  const cloth::ClothModel& cm = comp.model.cloth;
  const double L = double(cm.x0[1].z()) - double(cm.x0[0].z());
  const double A0 = std::abs(L - double(cm.prm[0].x()) - m * kG / k);
  const double h = (1.0 / 600) / std::ceil((1.0 / 600) / cm.explicit_dt_limit), wh = std::sqrt(k / m) * h;
  const double bound = std::sqrt(k / m) * A0 / std::sqrt(1 - wh * wh / 4);
  Simulation sim(comp.model, comp.initial, cl);
  double fastest = 0;
  for (int f = 0; f < comp.model.num_frames; ++f) {
    sim.advanceFrame();
    std::vector<Eigen::Vector4f> x, v;
    sim.cloth()->read(x, v);
    fastest = std::max(fastest, double(v[0].head<3>().norm()));
  }
  INFO("placement amplitude " << A0 << " m; fastest " << fastest << " m/s; bound " << bound << " m/s");
  CHECK(fastest <= 1.1 * bound);
}

TEST_CASE("Cloth: a mass on a spring oscillates with period 2 pi sqrt(m/k)", "[cloth][physics]") {
  // m = 10 g, k = 100 N/m: T = 2 pi sqrt(m/k) = 62.8 ms. Released at the unstretched length under
  // gravity, it oscillates about mg/k below with amplitude mg/k (0.98 mm). Sampled 64 times per
  // period (dt = T/64: symplectic Euler lengthens the period by (omega dt)^2 / 24 = 4e-4), the
  // period from 20 upward zero crossings (linear interpolation) is within 1 % of T.
  const double m = 0.01, k = 100.0, T = 2 * M_PI * std::sqrt(m / k);
  ClothSpec s = chain(1, m, 0.1, k, 0.0, ClothSolver::Explicit);
  s.position.z() = 0.1;  // near the origin: finer float spacing
  ClContext cl;
  const Compiled comp = compile(clothScene(s, 64 / T, 1, 22 * T));
  Simulation sim(comp.model, comp.initial, cl);
  const double z_eq = comp.model.cloth.x0[0].z() - m * kG / k;
  std::vector<double> crossings;
  double prev = comp.model.cloth.x0[0].z() - z_eq, t_prev = 0;
  for (int f = 0; f < comp.model.num_frames; ++f) {
    sim.advanceFrame();
    const double y = positions(sim)[0].z() - z_eq;
    if (prev < 0 && y >= 0) crossings.push_back(t_prev + (sim.time() - t_prev) * (-prev) / (y - prev));
    prev = y;
    t_prev = sim.time();
  }
  REQUIRE(crossings.size() >= 20);
  const double period = (crossings.back() - crossings.front()) / (crossings.size() - 1);
  INFO("period " << period << " s, 2 pi sqrt(m/k) = " << T << " s");
  CHECK(std::abs(period - T) <= 0.01 * T);
}

TEST_CASE("Cloth: the explicit mass-spring keeps its energy bounded over 10^4 periods (symplectic)", "[cloth][physics]") {
  // The same mass on a spring, dt = T/16, 10^4 periods (160 000 steps). Symplectic Euler keeps a
  // modified energy H' = E - (dt/2) k x v exactly for a linear spring (Hairer, Lubich, Wanner 2006,
  // ch. IX), so E stays within omega dt E_osc of its start, E_osc = k A^2 / 2 the oscillation energy;
  // an integrator that drifts (explicit Euler gains a factor 1 + (omega dt)^2 per step) leaves that
  // band within a few periods. Sampled at frames 1.37 T apart (all phases over the run).
  const double m = 0.01, k = 100.0, T = 2 * M_PI * std::sqrt(m / k), w = 2 * M_PI / T;
  ClothSpec s = chain(1, m, 0.1, k, 0.0, ClothSolver::Explicit);
  s.position.z() = 0.1;
  const int substeps = 22;
  const double frame = 1.37 * T, dt = frame / substeps;
  ClContext cl;
  const Compiled comp = compile(clothScene(s, 1.0 / frame, substeps, 1e4 * T));
  Simulation sim(comp.model, comp.initial, cl);
  const Eigen::Vector3d g(0, 0, -kG);
  const double E0 = sim.cloth()->report(0, g).energy();
  const double A = m * kG / k, E_osc = 0.5 * k * A * A;
  double worst = 0, worst_late = 0;
  for (int f = 0; f < comp.model.num_frames; ++f) {
    sim.advanceFrame();
    const double dE = std::abs(sim.cloth()->report(0, g).energy() - E0);
    worst = std::max(worst, dE);
    if (f >= comp.model.num_frames - 100) worst_late = std::max(worst_late, dE);
  }
  INFO("max |E - E0| = " << worst << " J (last 100 frames " << worst_late << " J); bound omega dt E_osc = "
                         << w * dt * E_osc << " J");
  CHECK(worst <= w * dt * E_osc);
  CHECK(sim.profile().steps == static_cast<uint64_t>(comp.model.num_frames) * substeps);
}

TEST_CASE("Cloth: a chain between two anchors sags to the catenary, converging with resolution", "[cloth][physics]") {
  // A chain of length L = 1 m (XPBD, k = 10^6 N/m per link: strain ~ 3e-5, inextensible at this
  // scale; 16 steps per frame, 30 sweeps) whose two ends are drawn together at 0.2 m/s each for
  // 0.5 s, to D = 0.8 m apart, then left to settle (air damping 10/s) until 2.5 s. A uniform
  // inextensible chain hangs as the catenary z = a cosh(x/a), L = 2 a sinh(D / 2a); its sag is
  // a (cosh(D / 2a) - 1) = 0.2654 m. A chain of N links with equal masses at its nodes tends to it
  // as 1/N^2. Checked: the error shrinks with each doubling of N by at least 2.5x (second order
  // gives 4x), and at N = 32 it is below 0.2 % of the sag: the second-order extrapolation of the
  // N = 8 error (0.9 %) to N = 32 is 0.05 %, with a 4x margin for the solver's residual stretch.
  const double L = 1.0, D = 0.8;
  double a = 0.5;  // solve 2 a sinh(D / 2a) = L by bisection on a
  for (double lo = 0.05, hi = 10.0, it = 0; it < 200; ++it) {
    a = 0.5 * (lo + hi);
    (2 * a * std::sinh(D / (2 * a)) > L ? lo : hi) = a;
  }
  const double sag = a * (std::cosh(D / (2 * a)) - 1);
  ClContext cl;
  std::vector<double> errors;
  for (int N : {8, 16, 32}) {
    ClothSpec s;
    s.name = "chain";
    s.resolution_x = N + 1;
    s.resolution_y = 1;
    s.width = L;
    s.length = 0.01;
    s.areal_density = 10.0;  // 0.1 kg in all
    s.position = Eigen::Vector3d(0.5, 0.5, 0.8);
    s.stretch_stiffness = 1e6;
    s.shear_stiffness = s.bend_stiffness = 0;
    s.air_damping = 10.0;
    s.iterations = 30;
    for (int end : {0, 1}) {
      ClothAnchorSpec an;
      an.type = AnchorType::Node;
      an.i = end ? N : 0;
      an.velocity = Eigen::Vector3d(end ? -0.2 : 0.2, 0, 0);
      an.stop = 0.5;
      s.anchors.push_back(an);
    }
    const Compiled comp = compile(clothScene(s, 60, 16, 2.5));
    Simulation sim(comp.model, comp.initial, cl);
    for (int f = 0; f < comp.model.num_frames; ++f) sim.advanceFrame();
    const auto x = positions(sim);
    double lowest = x[0].z();
    for (const auto& p : x) lowest = std::min(lowest, double(p.z()));
    const double span = x[N].x() - x[0].x();
    errors.push_back(std::abs((x[0].z() - lowest) - sag));
    INFO("N = " << N << ": span " << span << " m, sag " << x[0].z() - lowest << " m, catenary " << sag << " m");
    CHECK(span == Approx(D).margin(1e-4));
  }
  INFO("errors " << errors[0] << ", " << errors[1] << ", " << errors[2] << " m");
  CHECK(errors[1] * 2.5 <= errors[0]);
  CHECK(errors[2] * 2.5 <= errors[1]);
  CHECK(errors[2] <= 0.002 * sag);
}

TEST_CASE("Cloth: pulling two anchored edges apart past tear_strain breaks springs", "[cloth]") {
  // A 6 x 3 strip (XPBD, stiff) whose x_min and x_max edges move apart at 0.2 m/s each: after
  // 0.5 s it is 0.2 m longer than its 0.1 m, a strain of 2 against tear_strain 0.5. Springs break
  // (the strip comes apart), and none breaks while the mean strain is well below it (0.2 at
  // 0.05 s; measured largest spring strain then 0.38, the springs next to the anchors lead).
  ClothSpec s;
  s.name = "strip";
  s.resolution_x = 6;
  s.resolution_y = 3;
  s.width = 0.1;
  s.length = 0.04;
  s.position = Eigen::Vector3d(0.5, 0.5, 0.5);
  s.stretch_stiffness = 1e5;
  s.tear_strain = 0.5;
  for (ClothEdge e : {ClothEdge::XMin, ClothEdge::XMax}) {
    ClothAnchorSpec an;
    an.type = AnchorType::Edge;
    an.edge = e;
    an.velocity = Eigen::Vector3d(e == ClothEdge::XMin ? -0.2 : 0.2, 0, 0);
    s.anchors.push_back(an);
  }
  ClContext cl;
  const Compiled comp = compile(clothScene(s, 60, 4, 0.5));
  Simulation sim(comp.model, comp.initial, cl);
  const Eigen::Vector3d g(0, 0, -kG);
  for (int f = 0; f < 3; ++f) sim.advanceFrame();  // 0.05 s: strain 0.2
  CHECK(sim.cloth()->report(0, g).broken == 0);
  for (int f = 3; f < comp.model.num_frames; ++f) sim.advanceFrame();
  const cloth::ClothReport r = sim.cloth()->report(0, g);
  INFO("broken " << r.broken << " of " << comp.model.cloth.springs());
  CHECK(r.broken > 0);
  CHECK(r.max_strain < 0.5 * 1.01);  // what is left is below the tear strain
  // The exported mesh leaves out the triangles along broken springs (5 x 2 cells, 2 triangles each).
  const TriMesh whole = io::clothMesh(comp.model.cloth, 0, s, comp.model.cloth.x0, {});
  const TriMesh torn = io::clothMesh(comp.model.cloth, 0, s, positions(sim), sim.cloth()->readBroken());
  CHECK(whole.numTriangles() == 20u);
  CHECK(torn.numTriangles() < whole.numTriangles());
  CHECK(torn.colours.size() == torn.positions.size());
}

TEST_CASE("Cloth: scenes without cloth enqueue no cloth kernel, and with cloth runs are bitwise equal", "[cloth]") {
  ClContext cl;
  SceneSpec plain = clothScene(ClothSpec{}, 60, 2, 0.1);
  plain.cloth.clear();
  plain.fluid.blocks.resize(1);
  plain.fluid.blocks[0].min = Eigen::Vector3d(0.1, 0.1, 0.0);
  plain.fluid.blocks[0].max = Eigen::Vector3d(0.4, 0.4, 0.2);
  const Compiled c0 = compile(plain);
  CHECK_FALSE(c0.model.stages.on(Stage::Cloth));
  Simulation s0(c0.model, c0.initial, cl);
  for (int f = 0; f < 3; ++f) s0.advanceFrame();
  for (const auto& [name, count] : s0.dispatchCounts()) CHECK(name.rfind("cloth_", 0) != 0);

  // A 10 x 10 XPBD cloth pinned at its corners, then an explicit one: twice each, bitwise equal.
  // XPBD: the fused solve (one launch per step, cloth_xpbd_solve) twice, then the per-colour
  // launches (cloth_xpbd_colour): all three bitwise equal.
  for (ClothSolver solver : {ClothSolver::Xpbd, ClothSolver::Explicit}) {
    ClothSpec c;
    c.name = "sheet";
    c.resolution_x = c.resolution_y = 10;
    c.position = Eigen::Vector3d(0.5, 0.5, 0.5);
    c.solver = solver;
    c.anchors.resize(1);
    const Compiled comp = compile(clothScene(c, 60, 2, 0.2));
    std::vector<std::vector<Eigen::Vector4f>> runs;
    const int n_runs = solver == ClothSolver::Xpbd ? 3 : 2;
    for (int run = 0; run < n_runs; ++run) {
      Simulation sim(comp.model, comp.initial, cl);
      if (run == 2) sim.cloth()->setFusedMaxNodes(0);
      for (int f = 0; f < comp.model.num_frames; ++f) sim.advanceFrame();
      runs.push_back(positions(sim));
      const char* kernel = solver == ClothSolver::Explicit ? "cloth_explicit_step" : run < 2 ? "cloth_xpbd_solve" : "cloth_xpbd_colour";
      CHECK(sim.dispatchCounts().count(kernel));
    }
    CHECK(std::memcmp(runs[0].data(), runs[1].data(), runs[0].size() * 16) == 0);
    if (n_runs == 3) CHECK(std::memcmp(runs[0].data(), runs[2].data(), runs[0].size() * 16) == 0);
    CHECK(runs[0][55].z() < 0.5f);  // its middle sagged
  }
}

TEST_CASE("Cloth: bad input is reported at its location", "[cloth][input]") {
  using namespace sph::testing;
  TempDir dir;
  const std::string head =
      "domain: {min: [0, 0, 0], max: [1, 1, 1]}\n"
      "fluid: {particle_spacing: 0.05}\n"
      "cloth:\n"
      "  - name: sheet\n";
  // Zero and negative resolution, a tear strain <= 0: schema ranges, at the key.
  auto issues = issuesOf(dir, head + "    resolution_x: 0\n");
  CHECK(hasIssue(issues, 5, {"resolution_x"}));
  issues = issuesOf(dir, head + "    resolution_y: -3\n");
  CHECK(hasIssue(issues, 5, {"resolution_y"}));
  issues = issuesOf(dir, head + "    tear_strain: 0\n");
  CHECK(hasIssue(issues, 5, {"tear_strain"}));
  // A resolution that would not fit in memory: at compile time, at the cloth, before allocating.
  const auto huge = dir.write("huge.yaml", head + "    resolution_x: 100000\n    resolution_y: 100000\n");
  try {
    (void)compile(io::loadScene(huge.string()));
    FAIL("a 1e10-node cloth compiled");
  } catch (const InputError& e) {
    INFO(dump(e.issues()));
    CHECK(hasIssue(e.issues(), 4, {"nodes supported"}));
  }
  // An anchor outside the cloth: at compile time, at the anchor.
  const auto scene = dir.write("anchor.yaml", head +
                                                  "    resolution_x: 4\n"
                                                  "    resolution_y: 4\n"
                                                  "    anchors:\n"
                                                  "      - {type: node, i: 4, j: 0}\n"
                                                  "      - {type: box, min: [2, 2, 2], max: [3, 3, 3]}\n");
  try {
    (void)compile(io::loadScene(scene.string()));
    FAIL("an anchor outside the cloth compiled");
  } catch (const InputError& e) {
    INFO(dump(e.issues()));
    CHECK(hasIssue(e.issues(), 8, {"pins no node", "(4, 0)"}));
    CHECK(hasIssue(e.issues(), 9, {"pins no node", "box"}));
  }
  // The command line: exit code 2 with file:line:col.
  const Result r = sphaptics(dir.path, {"validate", scene.string()});
  CHECK(r.code == 2);
  CHECK(r.err.find("anchor.yaml:8:") != std::string::npos);
}

namespace {

/// Tracks which side of a cloth each fluid particle (by id) is on, and counts crossings from above
/// to below. The side is taken against the nearest node in (x, y) when that node is an interior
/// one; beside an edge node it is unknown (water spilling over an edge falls beside the sheet and
/// may then spread under it: no crossing).
struct CrossingCounter {
  int nx, ny;
  std::vector<int> side;  // per id: +1 above, -1 below, 0 unknown
  int crossings = 0;
  int above = 0;          // particles above the sheet at the last update
  void update(Simulation& sim) {
    std::vector<Eigen::Vector4f> x, v;
    sim.cloth()->read(x, v);
    const ParticleFrame f = sim.readFrame();
    above = 0;
    for (std::size_t p = 0; p < f.size(); ++p) {
      std::size_t best = 0;
      double d2 = INFINITY;
      for (std::size_t k = 0; k < x.size(); ++k) {
        const double ex = x[k].x() - f.x[p], ey = x[k].y() - f.y[p], e = ex * ex + ey * ey;
        if (e < d2) d2 = e, best = k;
      }
      const int i = static_cast<int>(best) % nx, j = static_cast<int>(best) / nx;
      const uint32_t id = f.id[p];
      if (side.size() <= id) side.resize(id + 1, 0);
      if (i == 0 || j == 0 || i == nx - 1 || j == ny - 1) {
        side[id] = 0;
        continue;
      }
      const int now = f.z[p] >= x[best].z() ? 1 : -1;
      if (side[id] == 1 && now == -1) ++crossings;
      side[id] = now;
      above += now == 1;
    }
  }
};

}  // namespace

namespace {
// scenes/hammock.yaml with fluid.solver `solver` (the next two tests).
void hammockHoldsWater(const std::string& solver) {
  // scenes/hammock.yaml: 0.4 kg of water falls into a cloth anchored at its four corners (node
  // spacing 0.8 dx), for the scene's 2 s (the issue's "holds a pool of water for 2 s").
  // Every frame, no fluid particle crosses the sheet from above to below; water that spills over
  // the sagging edges is not a crossing. The cloth carries the water: its lowest node sags below
  // the anchors, and over the last second the anchors hold on average the weight of the cloth and
  // of the water still above it within 10 % (the pool sloshes: its vertical momentum changes).
  // No particle crosses a closed wall (the water spilled on the floor stays above it).
  // The anchors' force is the springs' pull at the end of a frame, which rings with the XPBD springs
  // and the impacts (1.3-20 N from frame to frame for 5.5 N of weight): sampled at the scene's 30
  // frames/s, 9 frames over 0.3 s, it aliased that ringing (0.99-1.22 of the weight as the DFSPH
  // Courant number went from 0.38 to 0.42, session 15; with the strong cloth coupling 0.89, session
  // 17). So the test runs at 240 frames/s, one substep (the scene's largest step), and averages the
  // last second: every DFSPH step (dt <= 5 ms), every ~27th WCSPH step (sessions 16-17).
  SceneSpec spec = io::loadScene((std::string(SPHAPTICS_SOURCE_DIR) + "/scenes/hammock.yaml"));
  spec.simulation.duration = 2.0;
  spec.simulation.frame_rate = 240;  // with one substep: the scene's largest step, 1 / (30 x 8) s
  spec.simulation.substeps = 1;
  spec.fluid.solver = solver == "dfsph" ? FluidSolver::Dfsph : FluidSolver::Wcsph;
  const Compiled comp = compile(spec);
  REQUIRE(comp.model.stages.on(Stage::ClothCoupling));
  ClContext cl;
  Simulation sim(comp.model, comp.initial, cl);
  const Eigen::Vector3d g(0, 0, -kG);
  const ClothSpec& c = spec.cloth[0];
  CrossingCounter counter{c.resolution_x, c.resolution_y, {}, 0, 0};
  counter.update(sim);
  const int initial_above = counter.above;
  double carried = 0, held = 0;
  int frames = 0;
  const double particle_mass = 1000.0 * std::pow(comp.model.dx, 3), cloth_mass = c.areal_density * c.width * c.length;
  uint64_t wall_crossings = 0;
  for (int f = 0; f < comp.model.num_frames; ++f) {
    wall_crossings += sim.advanceFrame().wall_crossings;
    counter.update(sim);
    if (sim.time() > spec.simulation.duration - 1.0 + 1e-9) {
      carried += -sim.cloth()->report(0, g).anchor_force.z();
      held += (counter.above * particle_mass + cloth_mass) * kG;
      ++frames;
    }
  }
  carried /= frames;
  held /= frames;
  const auto x = positions(sim);
  double lowest = 1;
  for (const auto& p : x) lowest = std::min(lowest, double(p.z()));
  INFO("crossings: " << counter.crossings << "; particles above the sheet: " << initial_above << " at first, "
                     << counter.above << " at the end; lowest node " << lowest << " m; anchors carry " << carried
                     << " N, cloth and water above it weigh " << held << " N; " << wall_crossings
                     << " wall crossings");
  CHECK(initial_above == static_cast<int>(comp.initial.size()));
  CHECK(counter.crossings == 0);
  CHECK(counter.above > initial_above / 2);
  CHECK(lowest < c.position.z() - 0.02);
  CHECK(std::abs(carried - held) <= 0.1 * held);
  CHECK(wall_crossings == 0);
  WARN("hammock, " << solver << ": " << counter.crossings << " crossings, " << counter.above << " of " << initial_above
                   << " above at the end, anchors " << carried << " N for " << held << " N, " << wall_crossings
                   << " wall crossings, " << sim.profile().steps << " steps");
}
}  // namespace

TEST_CASE("Cloth: a hammock holds a pool of water with no particle through (two-way coupling)", "[cloth][fluid]") {
  hammockHoldsWater("wcsph");
}

TEST_CASE("Cloth with DFSPH: a hammock holds a pool of water with no particle through", "[cloth][fluid][dfsph]") {
  // Issue 14: cloth works with DFSPH as with WCSPH (the nodes are boundary particles for the
  // solver's walls, `walls: extrapolated`; the nodes gather the reaction of the solver's pressure,
  // core/simulation.cpp gatherClothForces). The same criteria. Measured (session 17, 240 frames/s,
  // the last second; fluid.dfsph.cloth_coupling: strong): 0 crossings, 378 of 400 particles above the
  // sheet at 2 s, the anchors carry 5.56 N for 5.67 N of cloth and water above it (-2.0 %), 648 steps;
  // staggered 365 of 400, 5.49 N for 5.55 N (-1.2 %), 741 steps. Session 15 (30 frames/s, the last
  // 0.3 s, staggered): 362 of 400, +0.6 %, 556 steps (WCSPH 384, -0.5 %, 6,393 steps); before the
  // floor contact below 361, +5.4 %, 599 steps. Mutation: no fluid force on the
  // nodes with DFSPH (gatherClothForces skipped): 55 particles above, anchors 50 % off: fails.
  // The ~40 particles that spill over the edges land on the domain floor in a layer one particle
  // thick (p = 0: a cut support); before the walls' non-penetration contact (kernels/dfsph.cl,
  // dfsph_wall_impulse) they were pressed through it (1,684 wall crossings repaired in 2 s, 0 with
  // WCSPH); now 0, checked.
  // The anchors' check averaged 9 frame ends of the springs' ringing pull until session 17 (above):
  // with the contact at a gap of dx/2 (not kept) it read 0.99, 0.99, 1.19, 0.99, 1.22 of the weight
  // at DFSPH Courant numbers 0.38, 0.39, 0.40, 0.41, 0.42; averaged over every step of the last
  // second, 0.98, 0.98, 0.93 (at 0.38, 0.40, 0.42).
  hammockHoldsWater("dfsph");
}

TEST_CASE("Cloth with DFSPH: a light sheet sealed between two water layers stays put and comes to rest",
          "[cloth][fluid][dfsph][stability]") {
  // Issue 14 (session 17): scenes/tests/dfsph_cloth_sandwich.yaml, a 5 kg/m^2 sheet spanning a 0.1 m
  // tank wall to wall, 11 cm of water sealed below it and 9 cm above, 1.5 cm between the sheet and
  // the lower layer's top particles (d); DFSPH at its default steps (5 ms at most). Physics:
  //  - the sheet and the water above it fall at most through the gap d, so no node is faster than
  //    a free fall through it: the sheet's kinetic energy stays under m g d (7.4e-3 J);
  //  - the layer below is sealed and incompressible: the sheet sags less than d into it;
  //  - it comes to rest, to within the solver's tolerance: each step may leave the average density
  //    error eta = fluid.dfsph.density_error, so the sealed layer (depth h) may breathe by eta h per
  //    step of dt; over the last 0.2 s the sheet's kinetic energy stays under 1/2 m (eta h / dt)^2
  //    with dt the largest step (2.8e-6 J);
  //  - no particle passes the sheet.
  // Measured (pocl, 2 cores): largest kinetic energy 2.5e-4 J (WCSPH 3.1e-3 J), 2.6e-8 J at most over
  // the last 0.2 s (WCSPH 9e-10 J), lowest node 9.2 mm below the plane, 300 steps (WCSPH 3,812). Mutations, each fails: the nodes staggered
  // (fluid.dfsph.cloth_coupling: staggered): the flow blows up at t = 0.045 s (exit 4); the density
  // solve blind to the divergence solve's node motion (dfsph_node_rate skipped): the sheet never
  // rests (3.4e-3 J over the last 0.2 s).
  // Session 19: the same with the cloth in XPBD substeps of 0.5 ms (cloth[].max_time_step; the
  // scene's one XPBD step per fluid step leaves this sheet soft: strain 7 %, 1 % with substeps).
  // Resolved, the light sheet fluttered with period ~2 steps (4.3e-4 J over the last 0.2 s) until its
  // wet nodes moved with an added mass in substepped steps (fluid.dfsph.cloth_added_mass, 1 by
  // default): 1.7e-7 J.
  // Mutation: cloth_added_mass 0 fails (4.3e-4 J).
  const bool substeps = GENERATE(false, true);
  INFO("XPBD substeps of 0.5 ms: " << substeps);
  SceneSpec spec = io::loadScene(std::string(SPHAPTICS_SOURCE_DIR) + "/scenes/tests/dfsph_cloth_sandwich.yaml");
  REQUIRE(spec.fluid.solver == FluidSolver::Dfsph);
  REQUIRE(spec.fluid.dfsph.cloth_coupling == DfsphCoupling::Strong);  // the default
  if (substeps) spec.cloth[0].max_time_step = 0.0005;
  const Compiled comp = compile(spec);
  ClContext cl;
  Simulation sim(comp.model, comp.initial, cl);
  const Eigen::Vector3d g(0, 0, -kG);
  const ClothSpec& c = spec.cloth[0];
  const double mass = c.areal_density * c.width * c.length;
  double lower_top = 0;  // the lower layer's top particle centres
  for (const auto& q : comp.initial.pos)
    if (q.z() < c.position.z()) lower_top = std::max(lower_top, double(q.z()));
  const double d = c.position.z() - lower_top;
  const double bound = mass * kG * d;
  const double breathe = spec.fluid.dfsph.density_error * lower_top / spec.fluid.dfsph.max_time_step;  // m/s
  const double rest = 0.5 * mass * breathe * breathe;
  CrossingCounter counter{c.resolution_x, c.resolution_y, {}, 0, 0};
  counter.update(sim);
  double largest = 0, last = 0, lowest = INFINITY;
  for (int f = 0; f < comp.model.num_frames; ++f) {
    sim.advanceFrame();
    counter.update(sim);
    const double ke = sim.cloth()->report(0, g).kinetic;
    largest = std::max(largest, ke);
    if (sim.time() > spec.simulation.duration - 0.2 + 1e-9) last = std::max(last, ke);
    std::vector<Eigen::Vector4f> x, v;
    sim.cloth()->read(x, v);
    for (const auto& n : x) lowest = std::min(lowest, double(n.z()));
  }
  INFO("gap d = " << d << " m; kinetic energy largest " << largest << " J (bound m g d " << bound << " J), over the last 0.2 s "
                  << last << " J (rest: " << rest << " J); lowest node " << lowest << " m; " << counter.crossings
                  << " crossings, " << sim.profile().steps << " steps");
  CHECK(d == Approx(0.015).margin(1e-6));
  CHECK(largest < bound);
  CHECK(lowest > lower_top);
  CHECK(last < rest);
  CHECK(counter.crossings == 0);
  WARN("sandwich, dfsph" << (substeps ? ", substeps" : "") << ": kinetic energy largest " << largest << " J, last 0.2 s " << last << " J, lowest node "
                                                  << c.position.z() - lowest << " m below the plane, " << sim.profile().steps << " steps");
}

TEST_CASE("Cloth: a ball dropped on a cloth is caught, comes to rest, and a heavier one sags it deeper", "[cloth][rigid]") {
  // A 0.3 m square cloth (XPBD, 21 x 21 nodes, 0.5 kg/m^2, edges anchored) and a ball of radius
  // 4 cm dropped from 6 cm above it, density 300 then 600 kg/m^3 (80 g, 160 g); particle coupling:
  // the nodes are projected out of the ball after every Gauss-Seidel sweep and the ball receives
  // their momentum change (core/cloth.h). Checked over 5 s: the ball never passes the cloth (its
  // centre stays above the cloth's lowest node); it comes to rest: a damped oscillator (air and
  // spring damping), its bob's peak-to-peak height in the last 0.5 s is under a quarter of that
  // in 1-1.5 s and under a tenth of the ball's sag (how far below resting on the flat cloth it
  // settles, the oscillator's static displacement); over the last second the anchors carry on average the weight of
  // the ball and of the cloth's free nodes (momentum balance: what the anchors do not carry
  // accelerates the ball and cloth, which on average do not move; the anchored nodes' own weight
  // rests on the anchors directly, not through the springs, so it is not in anchor_force). The
  // tolerance, 2 %: the bob left in the last second (peak to peak < sag / 10, checked) is an
  // oscillator of stiffness M g / sag, whose force swings by at most M g / 20 (5 %), and its mean
  // over more than three periods (f = sqrt(g / sag) / 2 pi ~ 3.5 Hz) is within 5 % / (3 pi) of zero,
  // 0.5 %; the cloth's own ringing takes the rest. The heavier ball sits lower on average.
  ClContext cl;
  std::vector<double> mean_z;
  for (double density : {300.0, 600.0}) {
    SceneSpec s = clothScene(anchoredSquare("net", 0.3, 21, 0.5, 30, 20.0), 60, 16, 5.0);
    const ClothSpec& c = s.cloth[0];
    const RigidBodySpec ball = dynamicBall("ball", 0.04, Eigen::Vector3d(0.5, 0.5, 0.6), density);
    s.rigid_bodies.push_back(ball);
    const Compiled comp = compile(s);
    Simulation sim(comp.model, comp.initial, cl);
    const double M = comp.model.bodies[0].mass, m_cloth = c.areal_density * 0.09;
    // Equal node masses (core/cloth.cpp): the 80 edge nodes of the 441 are anchored.
    const int nodes = c.resolution_x * c.resolution_y, anchored = 2 * c.resolution_x + 2 * (c.resolution_y - 2);
    const double m_free = m_cloth * (nodes - anchored) / nodes;
    bool through = false;
    double z_sum = 0, carried = 0;
    double early_lo = 1, early_hi = -1, late_lo = 1, late_hi = -1;  // ball height in 1-1.5 s and 4.5-5 s
    int n = 0;
    for (int f = 0; f < comp.model.num_frames; ++f) {
      sim.advanceFrame();
      const auto x = positions(sim);
      double lowest = 1;
      for (const auto& p : x) lowest = std::min(lowest, double(p.z()));
      const double z = sim.bodies()[0].x.z(), t = sim.time();
      through = through || z < lowest;
      if (t > 1.0 + 1e-9 && t < 1.5 + 1e-9) early_lo = std::min(early_lo, z), early_hi = std::max(early_hi, z);
      if (t > 4.5 + 1e-9) late_lo = std::min(late_lo, z), late_hi = std::max(late_hi, z);
      if (sim.time() > 4.0 + 1e-9) {
        z_sum += sim.bodies()[0].x.z();
        carried += -sim.cloth()->report(0, Eigen::Vector3d(0, 0, -kG)).anchor_force.z();
        ++n;
      }
    }
    carried /= n;
    mean_z.push_back(z_sum / n);
    INFO("density " << density << ": mean ball height " << mean_z.back() << " m; anchors carry " << carried
                    << " N on average, ball and free cloth nodes weigh " << (M + m_free) * kG << " N; bob peak to peak "
                    << early_hi - early_lo << " m in 1-1.5 s, " << late_hi - late_lo << " m in 4.5-5 s");
    CHECK_FALSE(through);
    CHECK(late_hi - late_lo < 0.25 * (early_hi - early_lo));
    const double sag = c.position.z() + ball.radius - mean_z.back();
    INFO("sag " << sag << " m");
    CHECK(sag > 0);
    CHECK(late_hi - late_lo < 0.1 * sag);
    CHECK(std::abs(carried - (M + m_free) * kG) <= 0.02 * (M + m_free) * kG);
  }
  CHECK(mean_z[1] < mean_z[0]);
}

TEST_CASE("Cloth: a heavy ball on a light sheet at long steps stays on it when the steps are split (max_time_step)", "[cloth][rigid][stability]") {
  // The sheet of scenes/balls_on_cloth.yaml (5 kg/m^2, 8 mm nodes, 10^4 N/m springs, 16 sweeps, edges
  // anchored), 0.2 m square, and its metal ball (R = 3 cm, 7800 kg/m^3: 0.88 kg on nodes of 0.3 g),
  // placed 5 mm above it, at 5 ms steps (DFSPH's longest; no fluid here). In one XPBD step of 5 ms
  // the 16 sweeps hold the springs too little against the ball, which goes through the sheet (session
  // 18: the same in water with DFSPH); split into substeps of at most 0.5 ms (cloth[].max_time_step)
  // the sheet catches it. Checked: with the split, the ball's centre stays above the sheet's lowest
  // node at every frame, and over the last 1.5 s the anchors carry on average the weight of the ball
  // and of the free nodes (momentum balance, as in the test above) within 2 %: the ball still bobs by
  // up to +-7 mm at ~1.5 Hz, whose momentum change over the window, M 2 A w / 1.5 s, is at most 0.7 %
  // of the weight (measured: 0.1 % off). Without the split the same scene loses the ball (measured:
  // on the floor, the anchors carry 1.6 N of 9.8 N), so the check can fail. The automatic substep
  // (max_time_step 0, the default) is checked to come out below the 0.5 ms that holds the ball.
  ClContext cl;
  for (const bool split : {true, false}) {
    SceneSpec s = clothScene(anchoredSquare("sheet", 0.2, 26, 5, 16, 5.0), 200, 1, 3.0);
    ClothSpec& c = s.cloth[0];
    c.max_time_step = split ? 5e-4 : std::numeric_limits<double>::infinity();
    s.rigid_bodies.push_back(dynamicBall("metal", 0.03, Eigen::Vector3d(0.5, 0.5, 0.535), 7800));
    if (split) {
      // The automatic substep (max_time_step 0, the default) for this ball and sheet:
      // sqrt(0.05 L0 n m / W) = sqrt(0.05 x 8 mm x 16 x 0.296 g / 8.11 N) = 0.48 ms.
      SceneSpec a = s;
      a.cloth[0].max_time_step = 0.0;
      const double h = compile(a).model.cloth.xpbd_dt_limit;
      INFO("automatic substep " << h << " s");
      CHECK(h == Approx(std::sqrt(0.05 * 0.008 * 16 * (0.2 / 676) / (compile(a).model.bodies[0].mass * kG))).epsilon(1e-3));
      CHECK(h < 5e-4);
    }
    const Compiled comp = compile(s);
    Simulation sim(comp.model, comp.initial, cl);
    const double M = comp.model.bodies[0].mass, m_cloth = c.areal_density * 0.04;
    const int nodes = c.resolution_x * c.resolution_y, anchored = 2 * c.resolution_x + 2 * (c.resolution_y - 2);
    const double weight = (M + m_cloth * (nodes - anchored) / nodes) * kG;
    bool through = false;
    double carried = 0, z_lo = 1, z_hi = 0;
    int n = 0;
    for (int f = 0; f < comp.model.num_frames; ++f) {
      sim.advanceFrame();
      double lowest = 1;
      for (const auto& p : positions(sim)) lowest = std::min(lowest, double(p.z()));
      const double z = sim.bodies()[0].x.z();
      through = through || z < lowest;
      if (sim.time() > 1.5 + 1e-9) {
        carried += -sim.cloth()->report(0, Eigen::Vector3d(0, 0, -kG)).anchor_force.z();
        z_lo = std::min(z_lo, z), z_hi = std::max(z_hi, z);
        ++n;
      }
    }
    carried /= n;
    INFO((split ? "split into " : "one step, ") << sim.cloth()->lastXpbdSubsteps() << " substep(s): ball through the sheet: "
         << through << "; anchors carry " << carried << " N on average over 1.5-3 s for the ball and free nodes' "
         << weight << " N; ball centre " << z_lo << " .. " << z_hi << " m (sheet placed at 0.5 m)");
    if (split) {
      CHECK(sim.cloth()->lastXpbdSubsteps() == 10);
      CHECK_FALSE(through);
      CHECK(std::abs(carried - weight) <= 0.02 * weight);
      WARN("heavy ball, split steps: anchors " << carried << " N for " << weight << " N, ball centre " << z_lo << " .. " << z_hi << " m");
    } else {
      CHECK(sim.cloth()->lastXpbdSubsteps() == 1);
      CHECK(through);  // the scene is hard enough to tell
    }
  }
}

TEST_CASE("Cloth with DFSPH: a heavy ball on a sheet over sealed water is held, and the sheet moves no faster than the ball",
          "[cloth][fluid][rigid][dfsph][stability]") {
  // Issue 14 (session 18): scenes/tests/dfsph_ball_on_sealed_sheet.yaml, balls_on_cloth.yaml's metal
  // ball (R = 3 cm, 7,800 kg/m^3) dropped from 5 mm onto its sheet, which seals 11 cm of water; 9 cm
  // above. DFSPH at its default steps, the cloth in substeps of at most 0.5 ms. Checked over 1.5 s:
  //  - the ball never passes the sheet (its centre above the lowest node at every frame), and no
  //    fluid particle does;
  //  - over the last 0.5 s the sheet, moved only by the ball (the water is sealed, anchors fixed),
  //    moves no faster than the ball bobbing on it: its kinetic energy under 1/2 m_sheet v_max^2, v_max
  //    the ball's largest speed then (the whole sheet at the ball's speed bounds it).
  // Measured (pocl, 2 cores): ball mean height 0.1296 m over 1-1.5 s (WCSPH 0.1294), the ball's largest
  // speed then 0.11 m/s, the sheet's largest kinetic energy 5.0e-5 J against a bound of ~1.2e-3 J
  // (WCSPH 4.2e-5 J). Mutations, each fails: one XPBD step per fluid step (max_time_step .inf): the
  // ball goes through the sheet to the floor; the density solve blind to the cloth's own step (no dry
  // step, dfsph_node_dry skipped): the sheet keeps 6.8e-3 J against that run's bound of 6.2e-4 J.
  SceneSpec spec = io::loadScene(std::string(SPHAPTICS_SOURCE_DIR) + "/scenes/tests/dfsph_ball_on_sealed_sheet.yaml");
  REQUIRE(spec.fluid.solver == FluidSolver::Dfsph);
  const Compiled comp = compile(spec);
  ClContext cl;
  Simulation sim(comp.model, comp.initial, cl);
  const Eigen::Vector3d g(0, 0, -kG);
  const ClothSpec& c = spec.cloth[0];
  const double mass = c.areal_density * c.width * c.length;
  CrossingCounter counter{c.resolution_x, c.resolution_y, {}, 0, 0};
  counter.update(sim);
  bool through = false;
  double ke_late = 0, v_late = 0, z_sum = 0;
  int n = 0;
  for (int f = 0; f < comp.model.num_frames; ++f) {
    sim.advanceFrame();
    counter.update(sim);
    std::vector<Eigen::Vector4f> x, v;
    sim.cloth()->read(x, v);
    double lowest = INFINITY;
    for (const auto& q : x) lowest = std::min(lowest, double(q.z()));
    const rigid::BodyState& b = sim.bodies()[0];
    through = through || b.x.z() < lowest;
    if (sim.time() > spec.simulation.duration - 0.5 + 1e-9) {
      ke_late = std::max(ke_late, sim.cloth()->report(0, g).kinetic);
      v_late = std::max(v_late, b.v.norm());
      z_sum += b.x.z();
      ++n;
    }
  }
  const double bound = 0.5 * mass * v_late * v_late;
  INFO("ball through the sheet: " << through << "; ball mean height over the last 0.5 s " << z_sum / n
                                   << " m, largest speed " << v_late << " m/s; sheet kinetic energy largest " << ke_late
                                   << " J (bound " << bound << " J); " << counter.crossings << " crossings, "
                                   << sim.profile().steps << " steps");
  CHECK_FALSE(through);
  CHECK(counter.crossings == 0);
  CHECK(ke_late < bound);
  WARN("ball on sealed sheet, dfsph: mean height " << z_sum / n << " m, sheet " << ke_late << " J for a bound of " << bound
                                                   << " J, " << sim.profile().steps << " steps");
}

namespace {
/// scenes/tests/dfsph_cloth_push_blob.yaml with fluid.dfsph.cloth_added_mass = C: the largest drift of
/// the total momentum (water, ball, nodes, and what the water has yet to take of the added mass's
/// reaction) from the ball's initial momentum p0, and the largest momentum the sheet took.
struct ClothBlobMomentum {
  double p0 = 0, sheet = 0, worst = 0, pending = 0;
  long steps = 0;
  uint64_t viscosity_iterations = 0;
};
/// `landing`: no ball; the water is a 10 cm cube above the sheet, moving down onto it at 0.5 m/s.
/// `syrup`: the water is a laminar liquid of 0.01 m^2/s, its viscosity solved implicitly.
ClothBlobMomentum clothBlobMomentum(double C, bool landing, bool syrup = false) {
  SceneSpec spec = io::loadScene(std::string(SPHAPTICS_SOURCE_DIR) + "/scenes/tests/dfsph_cloth_push_blob.yaml");
  spec.fluid.dfsph.cloth_added_mass = C;
  if (syrup) {
    spec.fluid.viscosity_model = ViscosityModel::Laminar;
    REQUIRE(spec.fluid.phases.size() == 1);
    spec.fluid.phases[0].viscosity = 0.01;
    spec.fluid.dfsph.viscosity_solve = ViscositySolve::Implicit;
  }
  if (landing) {
    spec.rigid_bodies.clear();
    spec.fluid.blocks[0].min = Eigen::Vector3d(0.2, 0.2, 0.315);
    spec.fluid.blocks[0].max = Eigen::Vector3d(0.3, 0.3, 0.415);
    spec.fluid.blocks[0].velocity = Eigen::Vector3d(0, 0, -0.5);
  }
  const Compiled comp = compile(spec);
  ClContext cl;
  Simulation sim(comp.model, comp.initial, cl);
  const double m = comp.model.params.phase_mass[0];
  auto momenta = [&](Eigen::Vector3d& water_ball, Eigen::Vector3d& sheet) {
    const ParticleFrame f = sim.readFrame();
    water_ball = landing ? Eigen::Vector3d::Zero() : Eigen::Vector3d(comp.model.bodies[0].mass * sim.bodies()[0].v);
    for (std::size_t i = 0; i < f.size(); ++i) water_ball += m * Eigen::Vector3d(f.vx[i], f.vy[i], f.vz[i]);
    std::vector<Eigen::Vector4f> x, v;
    sim.cloth()->read(x, v);
    sheet.setZero();
    for (std::size_t k = 0; k < x.size(); ++k) sheet += v[k].head<3>().cast<double>() / double(x[k].w());  // w = 1 / m
  };
  Eigen::Vector3d water_ball, sheet;
  momenta(water_ball, sheet);
  const Eigen::Vector3d p0 = water_ball + sheet;  // the ball's, or the landing water's
  ClothBlobMomentum out;
  out.p0 = p0.norm();
  for (int f = 0; f < comp.model.num_frames; ++f) {
    sim.advanceFrame();
    momenta(water_ball, sheet);
    const Eigen::Vector3d pending = sim.cloth()->pendingAddedMassMomentum();
    out.worst = std::max(out.worst, (water_ball + sheet + pending - p0).norm());
    out.sheet = std::max(out.sheet, sheet.norm());
    out.pending = std::max(out.pending, pending.norm());
  }
  out.steps = sim.profile().steps;
  out.viscosity_iterations = sim.profile().viscosity_iterations;
  return out;
}
}  // namespace

TEST_CASE("Cloth with DFSPH: a ball pushing water against a free sheet conserves the total momentum, with the added mass too",
          "[cloth][fluid][dfsph]") {
  // Newton's third law between water, a ball and cloth (issue 14): gravity off, no wall within reach
  // (scenes/tests/dfsph_cloth_push_blob.yaml): a free 0.05 kg sheet inside a block of water at rest,
  // a ball below it moving up at 1 m/s. The nodes gather the reaction to the pressure, viscous and
  // (session 19) wall-contact forces they exert (gatherClothForces); with fluid.dfsph.cloth_added_mass
  // each node with water on both sides moves with an added mass M in its own step, and the water near
  // it takes the momentum M (v' - v) before the next step's solves (clothAddedMass): counted here as
  // pending until then. So water + ball + sheet + pending may drift by float rounding only. The
  // cloth's step keeps positions in float: at 0.3 m (ulp 3e-8 m) each 0.5 ms substep's velocities
  // (x - x_prev) / h carry up to 6e-5 m/s of rounding on ~0.15 kg of nodes and added mass, a random
  // walk over the run's ~200 substeps of ~1.3e-4 N s: the check allows twice that. The sheet must take
  // a real share: over 5 % of the ball's momentum, or half of m_sheet x 0.5 m/s from landing water.
  // Also without the ball: the water lands on the sheet from above at 0.5 m/s and presses on it, where
  // the extrapolated walls' contact acts between them.
  // Measured (session 19): the ball, C = 0 drift 6.0e-6 kg m/s with the sheet at 0.0044, C = 1 5.1e-5
  // (0.0045); landing, C = 0 1.1e-5 (0.022), C = 1 8.6e-5 (0.024). Mutations, each fails: the water's
  // reaction not enqueued (dfsph_node_added_mass_reaction): 5.3e-3 (the ball, C = 1); the extrapolated
  // walls' contact from the nodes without its reaction on them (as before session 19): 1.8e-3
  // (landing, C = 1).
  const double C = GENERATE(0.0, 1.0);
  const bool landing = GENERATE(false, true);
  INFO("fluid.dfsph.cloth_added_mass " << C << (landing ? ", water landing on the sheet" : ", the ball"));
  const ClothBlobMomentum b = clothBlobMomentum(C, landing);
  INFO("the initial momentum " << b.p0 << " kg m/s; the sheet's largest " << b.sheet << "; worst total drift " << b.worst
                              << "; largest pending reaction " << b.pending << "; " << b.steps << " steps");
  const double sheet_mass = 5.0 * 0.1 * 0.1;
  const double rounding = 0.15 * (std::nextafter(0.3f, 1.0f) - 0.3f) / 0.0005 * std::sqrt(200.0);  // N s
  CHECK(b.sheet > (landing ? 0.5 * sheet_mass * 0.5 : 0.05 * b.p0));
  if (C > 0) CHECK(b.pending > 0.0);  // the added mass acted
  CHECK(b.worst < 2.0 * rounding);
  WARN("cloth push blob, dfsph, cloth_added_mass " << C << (landing ? ", landing" : "") << ": p0 " << b.p0 << " kg m/s, sheet " << b.sheet
                                                   << ", drift " << b.worst << ", pending up to " << b.pending << ", "
                                                   << b.steps << " steps");
}

TEST_CASE("Cloth with DFSPH and implicit viscosity: a ball pushing syrup against a free sheet conserves the total momentum",
          "[cloth][fluid][dfsph]") {
  // The test above in a laminar liquid of 0.01 m^2/s, 10^4 x water's, its viscosity solved implicitly
  // (fluid.dfsph.viscosity_solve: implicit; the scene's cloth takes 0.5 ms substeps, as the loader asks of
  // cloth with it, docs/dfsph.md, session 38). Since
  // session 38 the free nodes are unknowns of the backward-Euler solve with the fluid (kernels/viscosity.cl,
  // viscosity_cg_node_*), and the nodes (and the ball) take the reaction of the same pair terms evaluated
  // at the solve's velocities (DfsphSolver::viscousVelocities, nodeViscousVelocities). So the total
  // momentum may drift by the float rounding above only. The steps are longer than the explicit viscous
  // bound 0.125 h^2 / nu = 1.25 ms: fewer than 0.1 s / 1.25 ms = 80 steps.
  // The sheet must take a real share of the landing water's momentum, as above. With the ball the
  // syrup takes its momentum within its Stokes time m / (6 pi mu R) ~ 9 ms, near it; the sheet, 5 cm
  // above the ball, takes ~2.5 %, so only the total is checked there.
  // Measured (session 38, the nodes in the solve): drift 4.0e-5 / 8.6e-5 kg m/s (the ball, C = 0 / 1),
  // 3.2e-5 / 8.9e-5 (landing), the landing sheet 0.023 kg m/s, 20-21 steps, 6-7 CG iterations per step.
  // (Session 37, the nodes held during the solve: 3.4e-5 / 7.4e-5 and 2.0e-5 / 8.1e-5.) Mutation: the
  // reaction from the velocities before the solve (viscous_kept_ = false in DfsphSolver::viscositySolve):
  // drift 1.9e-3 (the ball) and 1.5e-3 / 1.2e-2 (landing, C = 0 / 1) in session 37: fails.
  const double C = GENERATE(0.0, 1.0);
  const bool landing = GENERATE(false, true);
  INFO("fluid.dfsph.cloth_added_mass " << C << (landing ? ", syrup landing on the sheet" : ", the ball"));
  const ClothBlobMomentum b = clothBlobMomentum(C, landing, true);
  INFO("the initial momentum " << b.p0 << " kg m/s; the sheet's largest " << b.sheet << "; worst total drift " << b.worst
                              << "; " << b.steps << " steps, " << b.viscosity_iterations << " CG iterations");
  const double sheet_mass = 5.0 * 0.1 * 0.1;
  const double rounding = 0.15 * (std::nextafter(0.3f, 1.0f) - 0.3f) / 0.0005 * std::sqrt(200.0);  // N s
  CHECK(b.viscosity_iterations > 0);
  CHECK(b.steps < 80);
  if (landing) CHECK(b.sheet > 0.5 * sheet_mass * 0.5);
  CHECK(b.worst < 2.0 * rounding);
  WARN("cloth push blob in syrup, implicit viscosity, cloth_added_mass " << C << (landing ? ", landing" : "") << ": p0 "
                                                                         << b.p0 << " kg m/s, sheet " << b.sheet << ", drift "
                                                                         << b.worst << ", " << b.steps << " steps, "
                                                                         << b.viscosity_iterations << " CG iterations");
}

TEST_CASE("Cloth with DFSPH and implicit viscosity: syrup landing on a light free sheet carries it no faster than itself",
          "[cloth][fluid][dfsph]") {
  // The nodes as unknowns of the implicit viscosity solve (kernels/viscosity.cl, viscosity_cg_node_*,
  // session 38). scenes/tests/dfsph_cloth_push_blob.yaml without the ball, gravity off: a 10 cm cube of a
  // laminar liquid of 0.1 m^2/s (10^5 x water's) lands at 0.5 m/s on a free 0.1 m sheet of 0.5 kg/m^2
  // (5 g; a node weighs 3.5e-5 kg, a thirtieth of a fluid particle). In such a liquid a node's viscous
  // relaxation time m_k / sum_i m_i k_ik is ~1e-4 s, far below the 5 ms steps, so the sheet moves with
  // the liquid around it; driven by nothing else, it cannot move faster than the liquid's fastest
  // particle. With the nodes held at their velocity during the solve and given its reaction afterwards
  // (session 37), the relative velocity of a node and its liquid is multiplied each step by
  // 1 - (1 + m_f / m_k) s, s = dt k / (1 + dt k) -> 1 (docs/dfsph.md): such a node overshoots.
  // The scene's cloth takes its xpbd step in 0.5 ms substeps, as the loader asks of cloth with the implicit
  // viscosity (docs/dfsph.md, session 38).
  // Carried at the liquid's speed, the sheet may exceed it by the solve's tolerance: its velocities are
  // those of a residual fluid.dfsph.viscosity_tolerance (1e-3) of the initial one.
  // Measured (session 38): the sheet at 0.497728 m/s where the liquid's fastest is 0.497606 (ratio
  // 1.00025), 20 steps; the nodes' spread (standard deviation of their vertical speed) at most 0.021 m/s.
  // Mutation: the nodes held during the solve (session 37's coupling): the sheet at 1.69x the liquid's
  // fastest: fails.
  SceneSpec spec = io::loadScene(std::string(SPHAPTICS_SOURCE_DIR) + "/scenes/tests/dfsph_cloth_push_blob.yaml");
  spec.fluid.viscosity_model = ViscosityModel::Laminar;
  REQUIRE(spec.fluid.phases.size() == 1);
  spec.fluid.phases[0].viscosity = 0.1;
  spec.fluid.dfsph.viscosity_solve = ViscositySolve::Implicit;
  spec.rigid_bodies.clear();
  spec.fluid.blocks[0].min = Eigen::Vector3d(0.2, 0.2, 0.315);
  spec.fluid.blocks[0].max = Eigen::Vector3d(0.3, 0.3, 0.415);
  spec.fluid.blocks[0].velocity = Eigen::Vector3d(0, 0, -0.5);
  REQUIRE(spec.cloth.size() == 1);
  spec.cloth[0].areal_density = 0.5;
  const Compiled comp = compile(spec);
  ClContext cl;
  Simulation sim(comp.model, comp.initial, cl);
  double worst_ratio = 0, sheet_top = 0, liquid_top = 0, spread = 0;
  for (int f = 0; f < comp.model.num_frames; ++f) {
    sim.advanceFrame();
    const ParticleFrame p = sim.readFrame();
    double fastest = 0;
    for (std::size_t i = 0; i < p.size(); ++i)
      fastest = std::max(fastest, Eigen::Vector3d(p.vx[i], p.vy[i], p.vz[i]).norm());
    std::vector<Eigen::Vector4f> x, v;
    sim.cloth()->read(x, v);
    Eigen::Vector3d mom = Eigen::Vector3d::Zero();
    double mass = 0, vz = 0, vz2 = 0;
    for (std::size_t k = 0; k < x.size(); ++k) {
      const double m = 1.0 / double(x[k].w());
      mom += m * v[k].head<3>().cast<double>();
      mass += m;
      vz += v[k].z();
      vz2 += double(v[k].z()) * v[k].z();
    }
    const double n = double(x.size()), speed = mom.norm() / mass;
    spread = std::max(spread, std::sqrt(std::max(vz2 / n - (vz / n) * (vz / n), 0.0)));
    if (speed / fastest > worst_ratio) worst_ratio = speed / fastest, sheet_top = speed, liquid_top = fastest;
  }
  INFO("worst frame: the sheet at " << sheet_top << " m/s, the liquid's fastest " << liquid_top << " m/s; the nodes' largest spread "
                                    << spread << " m/s; " << sim.profile().steps << " steps");
  CHECK(sim.profile().viscosity_iterations > 0);
  CHECK(worst_ratio <= 1.0 + spec.fluid.dfsph.viscosity_tolerance);
  WARN("light sheet under landing syrup, implicit viscosity: sheet/liquid speed " << worst_ratio << " (" << sheet_top << " / "
                                                                                   << liquid_top << " m/s), node spread " << spread
                                                                                   << " m/s, " << sim.profile().steps << " steps");
}

TEST_CASE("Cloth with DFSPH and implicit viscosity: a light hammock carries its syrup at 5 ms steps, its own step in "
          "0.5 ms substeps", "[cloth][fluid][dfsph]") {
  // scenes/tests/dfsph_hammock_syrup.yaml with a 2 kg/m^2 cloth (0.08 kg) and a liquid of 0.1 m^2/s (10^5 x
  // water's): 0.4 kg of syrup falls 2 cm into it, at DFSPH's 5 ms steps (40x the explicit viscous bound),
  // the nodes unknowns of the viscosity solve and the cloth's xpbd step in 0.5 ms substeps (what the loader
  // asks for: session 38; its automatic max_time_step chooses them since session 39). At rest the anchors carry the weight of the cloth and the syrup, 4.709 N; over
  // 1.5-2 s (the explicit solve at its bound has rested by then: -0.7 %, 5.9e-6 J) their mean must be within
  // 5 %, as the hydrostatic tanks' pressures, and no syrup may leave the hammock (below 0.15 m).
  // Measured (session 38, the substeps set by hand; session 39, automatic: the same): +0.3 % (4.721 N), 423
  // steps, the cloth's kinetic energy 2.1e-5 J. Mutations: the cloth in one step per fluid step (before
  // session 39 the automatic step here): -39 % (2.85 N, 4.0e-2 J), fails. (The nodes held in the viscosity solve, with the substeps: -0.9 % but 9.3e-4 J, 44x: this check
  // passes; the landing sheet and the slab tests check the nodes' rows.)
  SceneSpec spec = io::loadScene(std::string(SPHAPTICS_SOURCE_DIR) + "/scenes/tests/dfsph_hammock_syrup.yaml");
  spec.fluid.dfsph.viscosity_solve = ViscositySolve::Implicit;
  REQUIRE(spec.fluid.phases.size() == 1);
  spec.fluid.phases[0].viscosity = 0.1;
  REQUIRE(spec.cloth.size() == 1);
  spec.cloth[0].areal_density = 2.0;
  REQUIRE(spec.cloth[0].max_time_step == 0.0);  // automatic
  const Compiled comp = compile(spec);
  REQUIRE(comp.model.cloth.xpbd_dt_limit == kImplicitViscosityXpbdStep);
  ClContext cl;
  Simulation sim(comp.model, comp.initial, cl);
  const Eigen::Vector3d g(0, 0, -9.81);
  double carried = 0, ke = 0;
  int n = 0;
  for (int f = 0; f < comp.model.num_frames; ++f) {
    sim.advanceFrame();
    if (sim.time() < 1.5 - 1e-9) continue;
    const auto r = sim.cloth()->report(0, g);
    carried += -r.anchor_force.z();
    ke += r.kinetic;
    ++n;
  }
  const ParticleFrame p = sim.readFrame();
  int spilled = 0;
  for (std::size_t i = 0; i < p.size(); ++i) spilled += p.z[i] < 0.15f;
  const double weight = (2.0 * 0.2 * 0.2 + comp.initial.size() * comp.model.params.phase_mass[0]) * 9.81;
  carried /= n;
  INFO("anchors " << carried << " N for " << weight << " N (" << 100 * (carried / weight - 1) << " %); cloth kinetic energy "
                  << ke / n << " J; spilled " << spilled << "; " << sim.profile().steps << " steps");
  CHECK(spilled == 0);
  CHECK(std::abs(carried / weight - 1.0) < 0.05);
  WARN("light hammock in 0.1 m^2/s syrup, implicit at 5 ms, cloth substeps 0.5 ms: anchors " << carried << " N for " << weight
                                                                                            << " N, KE " << ke / n << " J, "
                                                                                            << sim.profile().steps << " steps");
}

TEST_CASE("Cloth: fluid placed across a cloth is cleared to a spacing from its nodes at compile time", "[cloth][fluid]") {
  // A water block through a cloth plane: the particles closer than dx to a node would meet the
  // boundary's contact repulsion at once (the first balls_on_cloth scene blew the cloth up), so
  // compile() removes them and says so; the rest stay.
  ClothSpec c;
  c.name = "plane";
  c.width = c.length = 0.2;
  c.resolution_x = c.resolution_y = 26;
  c.position = Eigen::Vector3d(0.5, 0.5, 0.105);
  SceneSpec s = clothScene(c, 60, 2, 0.1);
  s.fluid.particle_spacing = 0.01;
  s.fluid.blocks.resize(1);
  s.fluid.blocks[0].min = Eigen::Vector3d(0.4, 0.4, 0.0);
  s.fluid.blocks[0].max = Eigen::Vector3d(0.6, 0.6, 0.2);
  const Compiled comp = compile(s);
  const double dx = 0.01;
  double nearest = INFINITY;
  for (std::size_t p = 0; p < comp.initial.size(); ++p)
    for (const auto& x : comp.model.cloth.x0)
      nearest = std::min(nearest, double((comp.initial.pos[p].head<3>() - x.head<3>()).norm()));
  INFO("particles " << comp.initial.size() << " of 8000; nearest to a node " << nearest << " m");
  CHECK(nearest >= dx * (1 - 1e-6));
  CHECK(comp.initial.size() < 8000u);
  CHECK(comp.initial.size() >= 8000u - 3 * 400u);  // at most the layers within dx of the plane
  CHECK(std::any_of(comp.model.notes.begin(), comp.model.notes.end(),
                    [](const std::string& n) { return n.find("cloth nodes removed") != std::string::npos; }));
}

TEST_CASE("Cloth: the domain's closed walls hold free nodes, as they hold the fluid (both solvers)", "[cloth]") {
  // A free 8 x 8 cloth, 0.1 m above the floor of the closed domain [0, 1]^3, falls (0.14 s) and
  // lies on the floor: no node below it at any frame end, none moving into it at the end. Without
  // the walls it would be 1.1 m below the floor after 0.5 s.
  for (ClothSolver solver : {ClothSolver::Xpbd, ClothSolver::Explicit}) {
    ClothSpec s;
    s.name = "sheet";
    s.resolution_x = 8;
    s.resolution_y = 8;
    s.width = 0.2;
    s.length = 0.2;
    s.position = Eigen::Vector3d(0.5, 0.5, 0.1);
    s.stretch_stiffness = 1e3;
    s.solver = solver;
    ClContext cl;
    const Compiled comp = compile(clothScene(s, 60, 4, 0.5));
    Simulation sim(comp.model, comp.initial, cl);
    float lowest = 1.0f, into_floor = 0.0f;
    for (int f = 0; f < comp.model.num_frames; ++f) {
      sim.advanceFrame();
      for (const Eigen::Vector4f& x : positions(sim)) lowest = std::min(lowest, x.z());
    }
    std::vector<Eigen::Vector4f> x, v;
    sim.cloth()->read(x, v);
    for (const Eigen::Vector4f& u : v) into_floor = std::min(into_floor, u.z());
    INFO((solver == ClothSolver::Xpbd ? "xpbd" : "explicit") << ": lowest node z " << lowest << " m, fastest into the floor "
                                                              << -into_floor << " m/s");
    CHECK(lowest >= 0.0f);
    CHECK(lowest < 0.01f);          // it did reach the floor
    CHECK(into_floor > -1e-6f);     // and rests on it
  }
}
