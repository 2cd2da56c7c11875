// Rigid bodies (issue 5): shapes, mass properties against closed forms, surface sampling, the
// scene keys and their errors, the rigid-body integrator against free fall, outputs, and a static
// bowl that holds water. Tolerances are derived next to each check.
#include "cli/runner.h"
#include "core/errors.h"
#include "core/mesh_distance.h"
#include "core/model.h"
#include "core/rigid.h"
#include "io/bodies_writer.h"
#include "io/obj_io.h"
#include "io/scene_loader.h"
#include "kernels/shared/sph_kernel.h"
#include "tests/run_binary.h"
#include "tests/scene_issues.h"
#include "tests/temp_dir.h"
#include "tests/floating_block.h"
#include "tests/three_balls.h"

#include <catch2/catch.hpp>

#include <sys/wait.h>

#include <Eigen/Geometry>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

using namespace sph;
namespace fs = std::filesystem;

namespace {

const fs::path kSourceDir = SPHAPTICS_SOURCE_DIR;

double relErr(double a, double b) { return std::abs(a - b) / std::abs(b); }
double relErr(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) { return (a - b).norm() / b.norm(); }

/// The unit-simplex tetrahedron (0, e1, e2, e3), outward-facing, scaled by s.
TriMesh tetrahedron(double s) {
  TriMesh m;
  m.positions = {Eigen::Vector3f::Zero(), Eigen::Vector3f(s, 0, 0), Eigen::Vector3f(0, s, 0), Eigen::Vector3f(0, 0, s)};
  m.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  return m;
}

void transform(TriMesh& m, const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
  for (auto& p : m.positions) p = (R * p.cast<double>() + t).cast<float>();
}

std::string objOf(const TriMesh& m) { return io::objText(m); }

/// The issues of loading `yaml` as `dir/scene.yaml`.
using testing::dump;
using testing::hasIssue;
using testing::issuesOf;

const std::string kDomain = "domain: {min: [0, 0, 0], max: [1, 1, 1]}\n";

}  // namespace

// ---------------------------------------------------------------------------------------------
// Shapes and mass properties
// ---------------------------------------------------------------------------------------------

TEST_CASE("Primitive meshes and the bowl mesh are closed and face outward", "[rigid]") {
  const double edge = 0.005;
  const std::vector<std::pair<std::string, TriMesh>> meshes = {
      {"sphere", rigid::sphereMesh(0.05, edge)},
      {"box", rigid::boxMesh({0.2, 0.1, 0.05})},
      {"cylinder", rigid::cylinderMesh(0.03, 0.1, edge)},
      {"capsule", rigid::capsuleMesh(0.03, 0.1, edge)},
      {"bowl.obj", io::readObj((kSourceDir / "scenes" / "meshes" / "bowl.obj").string())}};
  for (const auto& [name, m] : meshes) {
    INFO(name);
    const EdgeReport e = checkEdges(m);
    CHECK(e.closed());
    CHECK(e.degenerate == 0);
    CHECK(meshVolume(m) > 0.0);  // outward: the divergence theorem gives a positive volume
  }
  // Curved primitives: edges along the circles of about `edge` (the resolution follows the spacing).
  CHECK(rigid::segmentsFor(0.05, edge) == static_cast<int>(std::ceil(2 * M_PI * 0.05 / edge)));
  // The bowl: a shell between radii 0.08 and 0.095 m, so V = 2/3 pi (Ro^3 - Ri^3) up to tessellation
  // (48 segments, 12 rings per quarter: inscribed polygons lose at most (2 pi / 48)^2 ~ 1.7 %).
  const double bowl = 2.0 / 3.0 * M_PI * (std::pow(0.095, 3) - std::pow(0.08, 3));
  CHECK(relErr(meshVolume(meshes[4].second), bowl) < std::pow(2 * M_PI / 48, 2));
}

TEST_CASE("Mass properties of a box are exact", "[rigid]") {
  // V = abc, I = m/12 diag(b^2 + c^2, a^2 + c^2, a^2 + b^2) about the centre. Polyhedral
  // integration is exact for a polyhedron; what remains is the float rounding of the vertex
  // coordinates (relative 6e-8 each; products of up to five coordinates: < 1e-6).
  const Eigen::Vector3d size(0.2, 0.1, 0.05);
  TriMesh box = rigid::boxMesh(size);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Eigen::Vector3d t(1.0, -2.0, 0.5);
  transform(box, R, t);
  const rigid::MassProperties mp = rigid::massProperties(box);
  const double V = size.prod();
  const Eigen::Vector3d s2 = size.cwiseProduct(size);
  const Eigen::Matrix3d I0 = Eigen::Vector3d(s2.y() + s2.z(), s2.x() + s2.z(), s2.x() + s2.y()).asDiagonal() * (V / 12.0);
  CHECK(relErr(mp.volume, V) < 1e-6);
  CHECK((mp.centre - t).norm() < 1e-6 * t.norm());
  CHECK(relErr(mp.inertia, R * I0 * R.transpose()) < 1e-6);
}

TEST_CASE("Mass properties of an asymmetric tetrahedron match the closed form", "[rigid]") {
  // The simplex (0, s e1, s e2, s e3). By the Dirichlet integral int_simplex x^a y^b z^c =
  // a! b! c! / (a + b + c + 3)!:  V = s^3/6, int x = s^4/24, int x^2 = s^5/60, int x y = s^5/120.
  // So c = s/4 (1, 1, 1), C_origin = s^5 (1/60 on the diagonal, 1/120 off it); about the centre
  // C = C_origin - V c c^T and I = trace(C) 1 - C. Then rotated and moved: I' = R I R^T, c' = R c + t.
  const double s = 0.3;
  Eigen::Matrix3d C = Eigen::Matrix3d::Constant(std::pow(s, 5) / 120.0);
  C.diagonal().setConstant(std::pow(s, 5) / 60.0);
  const double V = s * s * s / 6.0;
  const Eigen::Vector3d c = Eigen::Vector3d::Constant(s / 4.0);
  C -= V * c * c.transpose();
  const Eigen::Matrix3d I = C.trace() * Eigen::Matrix3d::Identity() - C;
  // The tensor is not diagonal: a real test of the products of inertia.
  REQUIRE(std::abs(I(0, 1)) > 0.1 * I(0, 0));

  TriMesh tet = tetrahedron(s);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(-1.1, Eigen::Vector3d(0.3, -1, 0.2).normalized()).toRotationMatrix();
  const Eigen::Vector3d t(0.4, 0.1, -0.7);
  transform(tet, R, t);
  const rigid::MassProperties mp = rigid::massProperties(tet);
  // Float vertices after the rotation: relative rounding ~1e-7, so 1e-6 again.
  CHECK(relErr(mp.volume, V) < 1e-6);
  CHECK((mp.centre - (R * c + t)).norm() < 1e-6);
  CHECK(relErr(mp.inertia, R * I * R.transpose()) < 1e-6);
}

TEST_CASE("Mass properties of a tessellated sphere converge to 2/5 m r^2 at second order", "[rigid]") {
  // An inscribed UV sphere with n segments (n/2 rings) misses a volume fraction of order (2 pi/n)^2
  // (chord sag). So: the error is below (2 pi / n)^2, and it drops about 4x per doubling of n.
  const double r = 1.0;
  const double V = 4.0 / 3.0 * M_PI, I = 2.0 / 5.0 * V * r * r;  // unit density
  double prev_v = 0, prev_i = 0;
  for (int n : {16, 32, 64, 128}) {
    const rigid::MassProperties mp = rigid::massProperties(rigid::sphereMesh(r, 2 * M_PI * r / n * (1 - 1e-9)));
    const double ev = relErr(mp.volume, V);
    const double ei = relErr(mp.inertia, I * Eigen::Matrix3d::Identity());
    INFO("n = " << n << ": volume error " << ev << ", inertia error " << ei);
    CHECK(ev < std::pow(2 * M_PI / n, 2));
    CHECK(ei < std::pow(2 * M_PI / n, 2));
    CHECK(mp.centre.norm() < 1e-6);
    if (prev_v > 0) {
      CHECK(prev_v / ev > 3.0);
      CHECK(prev_v / ev < 5.0);
      CHECK(prev_i / ei > 3.0);
      CHECK(prev_i / ei < 5.0);
    }
    prev_v = ev;
    prev_i = ei;
  }
}

TEST_CASE("Cylinder and capsule volumes and inertia approach their closed forms", "[rigid]") {
  // Cylinder: V = pi r^2 h, I_zz = m r^2 / 2, I_xx = m (3 r^2 + h^2) / 12. Capsule: a cylinder plus
  // a sphere, V = pi r^2 h + 4/3 pi r^3. Inscribed polygons of n segments lose (2 pi / n)^2 / 6 of
  // the area, so with n = 128 the relative error is below 5e-4.
  const double r = 0.03, h = 0.1, edge = 2 * M_PI * r / 128 * (1 - 1e-9);
  const rigid::MassProperties cyl = rigid::massProperties(rigid::cylinderMesh(r, h, edge));
  const double Vc = M_PI * r * r * h;
  CHECK(relErr(cyl.volume, Vc) < 5e-4);
  CHECK(relErr(cyl.inertia(2, 2), Vc * r * r / 2) < 1e-3);  // r^2 enters twice: twice the error
  CHECK(relErr(cyl.inertia(0, 0), Vc * (3 * r * r + h * h) / 12) < 1e-3);
  const rigid::MassProperties cap = rigid::massProperties(rigid::capsuleMesh(r, h, edge));
  // The caps are tessellated along both circles (rings and segments): twice the error, 8e-4.
  CHECK(relErr(cap.volume, Vc + 4.0 / 3.0 * M_PI * r * r * r) < 8e-4);
  CHECK(cap.centre.norm() < 1e-6);
}

TEST_CASE("Surface sampling: particles at least 0.75 dx apart and no surface point farther than 0.95 dx from one", "[rigid]") {
  const double dx = 0.01;
  const TriMesh sphere = rigid::sphereMesh(0.05, 0.5 * dx);
  const std::vector<Eigen::Vector3f> pts = rigid::sampleSurface(sphere, dx);
  // Poisson-disk radius 0.75 dx (float rounding aside; 0.8 dx until session 35, when fluid leaked through
  // the holes into a held ball at R / dx = 5).
  double closest = 1e9;
  for (std::size_t i = 0; i < pts.size(); ++i)
    for (std::size_t j = i + 1; j < pts.size(); ++j) closest = std::min(closest, double((pts[i] - pts[j]).norm()));
  CHECK(closest >= 0.75 * dx * (1 - 1e-6));
  // Coverage: every candidate (0.2 dx apart) was rejected only within 0.75 dx of a particle, so
  // every surface point is within 0.75 dx + 0.2 dx = 0.95 dx of one. Probe random surface points.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  double worst = 0;
  for (int k = 0; k < 2000; ++k) {
    const auto& t = sphere.triangles[rng() % sphere.triangles.size()];
    double a = u(rng), b = u(rng);
    if (a + b > 1) a = 1 - a, b = 1 - b;
    const Eigen::Vector3f p = sphere.positions[t[0]] + float(a) * (sphere.positions[t[1]] - sphere.positions[t[0]]) +
                              float(b) * (sphere.positions[t[2]] - sphere.positions[t[0]]);
    double best = 1e9;
    for (const auto& q : pts) best = std::min(best, double((p - q).norm()));
    worst = std::max(worst, best);
  }
  INFO(pts.size() << " particles, " << pts.size() / (meshArea(sphere) / (dx * dx)) << " per dx^2; farthest probe " << worst / dx << " dx from a particle");
  CHECK(worst <= 0.95 * dx);
  // Density: between random sequential adsorption's jamming limit (disks of diameter 0.75 dx cover
  // 0.547 of the plane: 1.24 per dx^2) less the same margin for the sphere's curvature as at 0.8 dx
  // (1.09 -> 0.9, x 0.83: 1.02), and the densest packing (hexagonal at 0.75 dx: 2.05 per dx^2).
  const double per_dx2 = pts.size() / (meshArea(sphere) / (dx * dx));
  CHECK(per_dx2 > 1.02);
  CHECK(per_dx2 < 2.06);
}

// ---------------------------------------------------------------------------------------------
// Scene keys and errors
// ---------------------------------------------------------------------------------------------

TEST_CASE("rigid_bodies: keys load with their defaults, and bodies compile", "[rigid]") {
  testing::TempDir dir;
  dir.write("tet.obj", objOf(tetrahedron(0.1)));
  const std::string yaml = kDomain +
                           "fluid:\n"
                           "  blocks: [{min: [0, 0, 0], max: [0.2, 0.2, 0.2]}]\n"
                           "rigid_bodies:\n"
                           "  - name: ball\n"
                           "    shape: sphere\n"
                           "    radius: 0.05\n"
                           "    position: [0.5, 0.5, 0.5]\n"
                           "    density: 500\n"
                           "    dynamic: true\n"
                           "    grabbable: true\n"
                           "  - name: tet\n"
                           "    shape: mesh\n"
                           "    mesh: tet.obj\n"
                           "    position: [0.3, 0.6, 0.3]\n"
                           "    orientation_axis: [0, 0, 1]\n"
                           "    orientation_angle: 90\n"
                           "    scale: 2\n"
                           "    mass: 1.5\n"
                           "  - name: paddle\n"
                           "    shape: box\n"
                           "    size: [0.02, 0.1, 0.1]\n"
                           "    position: [0.7, 0.5, 0.5]\n"
                           "    density: 1000\n"
                           "    motion: {type: constant, velocity: [0.1, 0, 0], angular_velocity: [0, 0, 1]}\n";
  const SceneSpec s = io::loadScene(dir.write("scene.yaml", yaml).string());
  REQUIRE(s.rigid_bodies.size() == 3);
  const RigidBodySpec d;
  CHECK(s.rigid_bodies[0].shape == BodyShape::Sphere);
  CHECK(s.rigid_bodies[0].grabbable);
  CHECK(s.rigid_bodies[0].friction == d.friction);
  CHECK(s.rigid_bodies[0].restitution == d.restitution);
  CHECK(s.rigid_bodies[0].colour == d.colour);
  CHECK(s.rigid_bodies[1].mesh == (dir.path / "tet.obj").lexically_normal().string());  // relative to the scene
  CHECK(s.rigid_bodies[1].mesh_data.triangles.size() == 4);
  CHECK(s.rigid_bodies[2].motion.type == MotionType::Constant);
  CHECK(s.rigid_bodies[2].motion.angular_velocity == Eigen::Vector3d(0, 0, 1));

  const Compiled c = compile(s);
  REQUIRE(c.model.bodies.size() == 3);
  CHECK(c.model.bodies[0].kind == rigid::BodyKind::Dynamic);
  CHECK(c.model.bodies[1].kind == rigid::BodyKind::Static);
  CHECK(c.model.bodies[2].kind == rigid::BodyKind::Kinematic);
  // Sphere of radius 5 cm at 500 kg/m^3, tessellated at dx / 2 = 1 cm edges (32 segments):
  // within (2 pi / 32)^2 of 4/3 pi r^3 rho.
  CHECK(relErr(c.model.bodies[0].mass, 500 * 4.0 / 3.0 * M_PI * std::pow(0.05, 3)) < std::pow(2 * M_PI / 32, 2));
  // mass given: kept exactly; the scaled tetrahedron (edge 0.2) puts the origin 0.05 from the centre.
  CHECK(c.model.bodies[1].mass == Approx(1.5).epsilon(1e-12));
  const rigid::BodyState s1 = rigid::initialState(c.model.bodies[1]);
  CHECK((s1.toWorld(c.model.bodies[1].origin_offset) - Eigen::Vector3d(0.3, 0.6, 0.3)).norm() < 1e-9);
  // Static bodies join the boundary; every body has surface particles with positive volumes.
  std::size_t walls_only = compile([&] {
                             SceneSpec t = s;
                             t.rigid_bodies.clear();
                             return t;
                           }())
                               .model.boundary.size();
  CHECK(c.model.boundary.size() == walls_only + c.model.bodies[1].particles.size());
  for (const auto& b : c.model.bodies) {
    CHECK(!b.particles.empty());
    for (float v : b.volumes) CHECK(v > 0.0f);
  }
  // Stage mask: moving bodies turn rigid dynamics on; a scene without them leaves it off.
  CHECK(c.model.stages.on(Stage::RigidDynamics));
  SceneSpec only_static = s;
  only_static.rigid_bodies = {s.rigid_bodies[1]};
  CHECK_FALSE(compile(only_static).model.stages.on(Stage::RigidDynamics));
}

TEST_CASE("rigid_bodies: bad input is reported at its location", "[rigid]") {
  testing::TempDir dir;
  TriMesh open = tetrahedron(0.1);
  open.triangles.pop_back();  // a hole: three open edges
  dir.write("open.obj", objOf(open));
  TriMesh inward = tetrahedron(0.1);
  for (auto& t : inward.triangles) std::swap(t[1], t[2]);
  dir.write("inward.obj", objOf(inward));
  const std::string yaml = kDomain +                   // 1
                           "rigid_bodies:\n"           // 2
                           "  - name: a\n"             // 3
                           "    shape: mesh\n"         // 4
                           "    mesh: missing.obj\n"   // 5
                           "    position: [0, 0, 0]\n" // 6
                           "    density: 1000\n"       // 7
                           "  - name: b\n"             // 8
                           "    shape: mesh\n"         // 9
                           "    mesh: open.obj\n"      // 10
                           "    position: [0, 0, 0]\n" // 11
                           "    density: -5\n"         // 12
                           "  - name: c\n"             // 13
                           "    shape: cube\n"         // 14
                           "    position: [0, 0, 0]\n" // 15
                           "    mass: 1\n"             // 16
                           "    density: 1\n"          // 17
                           "  - name: d\n"             // 18
                           "    shape: sphere\n"       // 19
                           "    position: [0, 0, 0]\n" // 20
                           "  - name: e\n"             // 21
                           "    shape: mesh\n"         // 22
                           "    mesh: inward.obj\n"    // 23
                           "    position: [0, 0, 0]\n" // 24
                           "    mass: 2\n"             // 25
                           "    dynamic: true\n"       // 26
                           "    motion: {type: constant}\n";  // 27
  const auto issues = issuesOf(dir, yaml);
  INFO(dump(issues));
  CHECK(hasIssue(issues, 5, {"rigid body 'a'", "mesh file 'missing.obj' not found"}));
  CHECK(hasIssue(issues, 10, {"open.obj", "is not closed", "3 open (boundary) edge(s)"}));
  CHECK(hasIssue(issues, 12, {"'rigid_bodies[1].density' = -5 is out of range", "> 0"}));
  CHECK(hasIssue(issues, 14, {"'cube' is not allowed", "mesh, sphere, box, cylinder, capsule"}));
  CHECK(hasIssue(issues, 16, {"rigid body 'c'", "not both"}));
  CHECK(hasIssue(issues, 18, {"rigid body 'd'", "'density'", "'mass'"}));
  CHECK(hasIssue(issues, 23, {"inward.obj", "negative volume"}));
  CHECK(hasIssue(issues, 27, {"rigid body 'e' is dynamic"}));
  // Locations point into the scene file.
  for (const auto& i : issues) CHECK(fs::path(i.file).filename() == "scene.yaml");
}

TEST_CASE("sphaptics validate: a bad mesh exits 2 naming the scene location and the mesh file", "[rigid]") {
  testing::TempDir dir;
  TriMesh open = tetrahedron(0.1);
  open.triangles.pop_back();
  dir.write("open.obj", objOf(open));
  dir.write("scene.yaml", kDomain +
                              "rigid_bodies:\n"
                              "  - {name: a, shape: mesh, mesh: open.obj, position: [0.5, 0.5, 0.5], density: 1000}\n");
  const testing::Result r = testing::sphaptics(dir.path, {"validate", "scene.yaml"});
  INFO(r.err);
  REQUIRE(r.code != -1);  // exited (no crash)
  CHECK(r.code == 2);
  CHECK(r.err.find("scene.yaml:3:") != std::string::npos);
  CHECK(r.err.find("open.obj is not closed: 3 open (boundary) edge(s)") != std::string::npos);
}

// ---------------------------------------------------------------------------------------------
// Dynamics
// ---------------------------------------------------------------------------------------------

TEST_CASE("Free fall matches x0 + v0 t + g t^2/2 up to the integrator's known error, at 1, 2 and 4 substeps", "[rigid]") {
  // Symplectic Euler (v += g dt, then x += v dt) gives after n steps exactly
  //     x_n = x0 + v0 t + g t^2 / 2 + g t dt / 2,    t = n dt,
  // a first-order error g t dt / 2 that halves with dt. The host integrates in double, so the
  // remaining difference is rounding: below 1e-12 m over these few hundred steps. The rotation
  // is torque-free: the angular momentum is conserved exactly (to rounding) and |q| stays 1.
  const Eigen::Vector3d g(0, 0, -9.81);
  double previous_error = 0;
  for (int substeps : {1, 2, 4}) {
    app::RunOptions o;
    o.scene = (kSourceDir / "scenes" / "tests" / "free_fall.yaml").string();
    o.quiet = true;
    o.write_output = false;
    o.sets = {"simulation.substeps=" + std::to_string(substeps)};
    Eigen::Vector3d x0, v0, L0;
    double worst = 0, worst_L = 0, worst_q = 0, error_at_end = 0;
    const app::RunResult r = app::runScene(o, [&](Simulation& sim, const FrameReport& rep) {
      const rigid::BodyState& s = sim.bodies().at(0);
      if (rep.frame == 0) {  // recover the initial state from the scene
        const rigid::BodyState init = rigid::initialState(sim.model().bodies[0]);
        x0 = init.x, v0 = init.v, L0 = init.L;
      }
      const double t = sim.time(), dt = sim.model().frame_dt / substeps;
      const Eigen::Vector3d predicted = x0 + v0 * t + 0.5 * g * t * t + 0.5 * g * t * dt;
      worst = std::max(worst, (s.x - predicted).norm());
      worst_L = std::max(worst_L, (s.L - L0).norm() / L0.norm());
      worst_q = std::max(worst_q, std::abs(s.q.norm() - 1.0));
      error_at_end = (s.x - (x0 + v0 * t + 0.5 * g * t * t)).norm();
    });
    REQUIRE(r.exit_code == 0);
    REQUIRE(r.frames == 15);
    INFO(substeps << " substeps: deviation from the predicted discrete path " << worst
                  << " m; from the parabola at the end " << error_at_end << " m");
    CHECK(worst < 1e-12);
    CHECK(worst_L < 1e-12);
    CHECK(worst_q < 1e-12);
    CHECK(error_at_end == Approx(0.5 * 9.81 * 0.5 * (1.0 / 30 / substeps)).epsilon(1e-9));
    if (previous_error > 0) CHECK(previous_error / error_at_end == Approx(2.0).epsilon(1e-9));
    previous_error = error_at_end;
  }
}

TEST_CASE("A kinematic body follows its constant motion exactly, and bodies.csv and OBJs are written", "[rigid]") {
  testing::TempDir dir;
  const std::string scene = kDomain +
                            "simulation: {duration: 0.2, frame_rate: 10, substeps: 3}\n"
                            "rigid_bodies:\n"
                            "  - name: paddle\n"
                            "    shape: box\n"
                            "    size: [0.02, 0.2, 0.1]\n"
                            "    position: [0.2, 0.5, 0.5]\n"
                            "    density: 700\n"
                            "    motion: {type: constant, velocity: [0.5, 0, 0], angular_velocity: [0, 0, 3]}\n"
                            "  - name: post\n"
                            "    shape: cylinder\n"
                            "    radius: 0.02\n"
                            "    height: 0.3\n"
                            "    position: [0.8, 0.5, 0.15]\n"
                            "    density: 700\n";
  app::RunOptions o;
  o.scene = dir.write("scene.yaml", scene).string();
  o.out = (dir.path / "out").string();
  o.quiet = true;
  const app::RunResult r = app::runScene(o, [&](Simulation& sim, const FrameReport&) {
    const rigid::BodyState& s = sim.bodies()[0];
    const double t = sim.time();
    // Constant velocity: x = x0 + v t (rounding only); rotation about z by 3 t.
    CHECK((s.x - Eigen::Vector3d(0.2 + 0.5 * t, 0.5, 0.5)).norm() < 1e-12);
    CHECK(s.q.angularDistance(Eigen::Quaterniond(Eigen::AngleAxisd(3 * t, Eigen::Vector3d::UnitZ()))) < 1e-12);
    // The static post does not move.
    CHECK((sim.bodies()[1].x - Eigen::Vector3d(0.8, 0.5, 0.15)).norm() < 1e-12);
  });
  REQUIRE(r.exit_code == 0);
  CHECK(r.dispatch_counts.empty());  // no fluid: no kernel at all
  // bodies.csv: the header, then 2 bodies x (1 initial + 2 frames) rows.
  std::ifstream in(dir.path / "out" / "bodies.csv");
  std::vector<std::string> rows;
  for (std::string line; std::getline(in, line);)
    if (!line.empty() && line[0] != '#') rows.push_back(line);
  REQUIRE(rows.size() == 1 + 2 * 3);
  CHECK(rows[0].rfind("time,body,com_x,com_y,com_z,qw,qx,qy,qz,vx,vy,vz,wx,wy,wz,fluid_fx", 0) == 0);
  CHECK(rows[5].rfind("0.2,paddle,0.3,0.5,0.5,", 0) == 0);
  for (const char* f : {"body_paddle_0000.obj", "body_paddle_0002.obj", "body_post_0002.obj"}) {
    INFO(f);
    REQUIRE(fs::exists(dir.path / "out" / f));
    const TriMesh m = io::readObj((dir.path / "out" / f).string());
    CHECK(checkEdges(m).closed());
  }
  // The paddle's OBJ at frame 2 is in world coordinates: its centroid is at x0 + v t.
  const TriMesh m = io::readObj((dir.path / "out" / "body_paddle_0002.obj").string());
  const rigid::MassProperties mp = rigid::massProperties(m);
  CHECK((mp.centre - Eigen::Vector3d(0.3, 0.5, 0.5)).norm() < 1e-5);  // OBJ text keeps 6 digits
}

// ---------------------------------------------------------------------------------------------
// Static bodies as fluid boundaries
// ---------------------------------------------------------------------------------------------

namespace {
// The bowl's check (the test below), with `sets` applied to the scene; returns the deepest centre
// beyond the inner surface (unit: m).
double bowlHoldsWater(const std::vector<std::string>& sets) {
  // scenes/bowl.yaml: a bowl with inner radius Ri = 0.08 m and outer Ro = 0.095 m (centre c =
  // (0.15, 0.15, 0.15), rim plane z = 0.15) is filled for 0.8 s from a nozzle 2 cm below the rim,
  // then left to settle until t = 2 s. No particle's total head (nozzle height + v^2/2g = 0.138 m)
  // reaches the rim, so none can leave over it. "Through the wall" means: a particle below the rim plane whose
  // centre is farther than Ri + dx/2 from c (inside the shell or beyond it; dx/2 allows for the
  // tessellation of the inner sphere and the particle's own radius of dx/2 pressed against the
  // boundary particles), checked at every frame. And at the end every particle is in the bowl.
  app::RunOptions o;
  o.scene = (kSourceDir / "scenes" / "bowl.yaml").string();
  o.quiet = true;
  o.write_output = false;
  o.sets = sets;
  const Eigen::Vector3d c(0.15, 0.15, 0.15);
  const double Ri = 0.08, dx = 0.01;
  std::size_t worst_frame_count = 0;
  double deepest = 0;  // largest |x - c| - Ri below the rim
  ParticleFrame last;
  const app::RunResult r = app::runScene(o, [&](Simulation& sim, const FrameReport&) {
    last = sim.readFrame();
    std::size_t through = 0;
    for (std::size_t i = 0; i < last.size(); ++i) {
      const Eigen::Vector3d x(last.x[i], last.y[i], last.z[i]);
      if (x.z() >= c.z()) continue;
      const double d = (x - c).norm() - Ri;
      deepest = std::max(deepest, d);
      through += d > 0.5 * dx;
    }
    worst_frame_count = std::max(worst_frame_count, through);
  });
  REQUIRE(r.exit_code == 0);
  INFO(last.size() << " particles; deepest centre " << deepest / dx << " dx beyond the inner surface");
  CHECK(last.size() > 300);
  CHECK(worst_frame_count == 0);
  // At 2 s the water rests in the bowl: every particle below the rim and inside the inner sphere.
  std::size_t held = 0;
  for (std::size_t i = 0; i < last.size(); ++i) {
    const Eigen::Vector3d x(last.x[i], last.y[i], last.z[i]);
    held += x.z() < c.z() && (x - c).norm() < Ri + 0.5 * dx;
  }
  CHECK(held == last.size());
  return deepest;
}
}  // namespace

TEST_CASE("A static bowl holds water for 2 s: no particle passes through its wall", "[rigid]") {
  // scenes/bowl.yaml: a bowl with inner radius Ri = 0.08 m and outer Ro = 0.095 m (centre c =
  // (0.15, 0.15, 0.15), rim plane z = 0.15) is filled for 0.8 s from a nozzle 2 cm below the rim,
  // then left to settle until t = 2 s (bowlHoldsWater above).
  bowlHoldsWater({});
}

TEST_CASE("DFSPH: a static bowl holds water for 2 s: no particle passes through its wall", "[rigid][dfsph]") {
  // The same check with DFSPH. A static body is one irregularly sampled layer of particles, and
  // DFSPH's only hold on a particle that reaches that layer's plane in a hole of the sampling is the
  // contact and, since session 30, the surface's non-penetration after the density solve
  // (kernels/dfsph.cl, dfsph_surface_impulse; scenes/demo_painting.yaml leaked into its tray's wall
  // and blew up without them). That contact keeps every centre at least dx/4 on the fluid side of the
  // nearest face, and the inner surface's flat faces lie inside the sphere of radius Ri (its vertices
  // are on it), so no centre may lie beyond Ri at all. Measured: none (0). Mutation, the session-29
  // contact (0.75 dx, no surface contact): a centre 0.24 dx beyond Ri: fails.
  const double deepest = bowlHoldsWater({"fluid.solver=dfsph"});
  CHECK(deepest <= 0.0);
}

// ---------------------------------------------------------------------------------------------
// Two-way coupling
// ---------------------------------------------------------------------------------------------

namespace {
Eigen::Vector3d fluidMomentum(Simulation& sim) {
  const ParticleFrame f = sim.readFrame();
  const double m = sim.model().params.phase_mass[0];
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < f.size(); ++i) p += m * Eigen::Vector3d(f.vx[i], f.vy[i], f.vz[i]);
  return p;
}
}  // namespace

TEST_CASE("Coupling: a ball pushed into a free blob conserves the total momentum (Newton's third law)", "[rigid]") {
  // Gravity off, no wall within reach: only fluid-fluid and fluid-ball forces act, and each pair
  // force is applied equal and opposite (the ball's share is gathered on the device from the same
  // expression the fluid uses). What remains is float32 rounding: each of the ~1,000 particle
  // velocities is rounded to ~6e-8 relative per step; over ~250 steps, summed at random over the
  // particles, that is ~1e-5 of the momentum exchanged. Tolerance: 1e-3 of the exchanged momentum.
  app::RunOptions o;
  o.scene = (kSourceDir / "scenes" / "tests" / "push_blob.yaml").string();
  o.quiet = true;
  o.write_output = false;
  Eigen::Vector3d p0 = Eigen::Vector3d::Constant(NAN);
  double worst = 0, exchanged = 0;
  const app::RunResult r = app::runScene(o, [&](Simulation& sim, const FrameReport&) {
    const rigid::RigidBody& ball = sim.model().bodies[0];
    const rigid::BodyState& s = sim.bodies()[0];
    if (std::isnan(p0.x())) p0 = ball.mass * rigid::initialState(ball).v;  // fluid starts at rest
    const Eigen::Vector3d p_ball = ball.mass * s.v;
    const Eigen::Vector3d total = fluidMomentum(sim) + p_ball;
    worst = std::max(worst, (total - p0).norm());
    exchanged = std::max(exchanged, (p_ball - p0).norm());
  });
  REQUIRE(r.exit_code == 0);
  REQUIRE(r.dispatch_counts.count("rigid_reduce") == 1);
  INFO("initial momentum " << p0.transpose() << " kg m/s; exchanged " << exchanged << "; worst total drift " << worst);
  CHECK(exchanged > 0.1 * p0.norm());  // the ball really hit the water
  CHECK(worst < 1e-3 * exchanged);
}

TEST_CASE("Coupling: stage mask and determinism with bodies", "[rigid]") {
  // A scene without moving bodies enqueues no rigid kernel; one with them runs the transform,
  // the force gather and the reduction once per step.
  app::RunOptions plain;
  plain.scene = (kSourceDir / "scenes" / "tests" / "tiny_tank.yaml").string();
  plain.quiet = true;
  plain.write_output = false;
  plain.duration = 0.05;
  const app::RunResult none = app::runScene(plain);
  REQUIRE(none.exit_code == 0);
  for (const auto& [name, count] : none.dispatch_counts) CHECK(name.rfind("rigid_", 0) != 0);
  CHECK(none.profile.seconds[static_cast<std::size_t>(Stage::RigidCoupling)] == 0.0);
  CHECK(none.profile.seconds[static_cast<std::size_t>(Stage::RigidDynamics)] == 0.0);

  app::RunOptions o;
  o.scene = (kSourceDir / "scenes" / "tests" / "push_blob.yaml").string();
  o.quiet = true;
  o.write_output = false;
  o.duration = 0.04;
  Eigen::Vector3d xa, xb;
  const app::RunResult a = app::runScene(o, [&](Simulation& sim, const FrameReport&) { xa = sim.bodies()[0].x; });
  const app::RunResult b = app::runScene(o, [&](Simulation& sim, const FrameReport&) { xb = sim.bodies()[0].x; });
  REQUIRE(a.exit_code == 0);
  REQUIRE(b.exit_code == 0);
  // Once per step, and once more to place the bodies for the initial state (frame 0).
  CHECK(a.dispatch_counts.at("rigid_transform") == a.profile.steps + 1);
  CHECK(a.dispatch_counts.at("rigid_fluid_forces") == a.profile.steps);
  CHECK(a.dispatch_counts.at("rigid_reduce") == a.profile.steps);
  CHECK(a.state_hash == b.state_hash);
  CHECK(xa == xb);  // bitwise
}

TEST_CASE("Coupling: a kinematic tool feels a drag opposite to its motion that grows with speed", "[rigid]") {
  // The tool (r = 2.5 cm) runs through the middle of a free blob, gravity off; the force is
  // averaged over the frames while its centre is between x = 0.34 and 0.44 m (fully immersed,
  // away from the blob's ends). Drag opposes the motion (F_x < 0) and grows with speed. Sideways
  // forces vanish by symmetry up to the irregular surface sampling: with the tool's radius 2.5 dx,
  // one boundary particle carries ~1/(pi 2.5^2) = 5 % of the projected area, and a few unbalanced
  // ones give up to ~20 %, so each sideways component must stay below 25 % of the drag. It grows with speed: pressure drag goes as U^2, so doubling U must more than
  // double it (checked: ratio > 2 and below 8, between linear-Stokes and a generous U^3).
  auto meanForce = [](double speed) {
    app::RunOptions o;
    o.scene = (kSourceDir / "scenes" / "tests" / "drag_blob.yaml").string();
    o.quiet = true;
    o.write_output = false;
    o.sets = {"rigid_bodies[0].motion.velocity=[" + std::to_string(speed) + ", 0, 0]"};
    o.duration = 0.2 / speed + 0.02;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    int n = 0;
    const app::RunResult r = app::runScene(o, [&](Simulation& sim, const FrameReport&) {
      const rigid::BodyState& s = sim.bodies()[0];
      if (s.x.x() < 0.34 || s.x.x() > 0.44) return;
      sum += s.fluid_force;
      ++n;
    });
    REQUIRE(r.exit_code == 0);
    REQUIRE(n >= 5);
    return Eigen::Vector3d(sum / n);
  };
  const Eigen::Vector3d slow = meanForce(0.5), fast = meanForce(1.0);
  INFO("mean fluid force at 0.5 m/s: " << slow.transpose() << " N; at 1 m/s: " << fast.transpose() << " N");
  CHECK(slow.x() < 0);
  CHECK(fast.x() < 0);
  CHECK(std::max(std::abs(slow.y()), std::abs(slow.z())) < 0.25 * std::abs(slow.x()));
  CHECK(std::max(std::abs(fast.y()), std::abs(fast.z())) < 0.25 * std::abs(fast.x()));
  CHECK(fast.x() / slow.x() > 2.0);
  CHECK(fast.x() / slow.x() < 8.0);
}

// ---------------------------------------------------------------------------------------------
// Contact with the walls
// ---------------------------------------------------------------------------------------------

TEST_CASE("Contact: bodies resting on the floor stay put, and a dropped ball bounces without gaining energy", "[rigid]") {
  // Resting: gravity adds |g| dt of approach speed per step and the contact removes exactly that
  // (speculative contact at zero gap), so a resting body must not move: within a hundredth of a
  // particle spacing over 2 s (120 frames, 240 steps). The ball's mesh has a flat bottom a hair
  // (r (1 - cos(pi / 2 rings)) = 0.003 dx) above its nominal radius: it settles that far in the
  // first frame, so its speed is checked from the second frame on. The brick's four corner
  // contacts are solved iteratively: a tilt below 1e-4 rad moves a corner by 5 um (0.0005 dx).
  // Bouncing (restitution e = 0.5, dropped from h = 0.2 m): the rebound apex is e^2 h, plus at most
  // the one step of travel at impact, v dt, that a speculative contact may bounce early from.
  app::RunOptions o;
  o.scene = (kSourceDir / "scenes" / "tests" / "resting.yaml").string();
  o.quiet = true;
  o.write_output = false;
  const double dx = 0.01, h = 0.2, e = 0.5, g = 9.81, dt = 1.0 / 120;
  Eigen::Vector3d ball0, brick0;
  double worst_ball = 0, worst_brick = 0, worst_speed = 0, worst_tilt = 0;
  double apex_after_bounce = 0, lowest = 1e9;
  bool bounced = false;
  double prev_vz = 0;
  const app::RunResult r = app::runScene(o, [&](Simulation& sim, const FrameReport& rep) {
    const auto& b = sim.bodies();
    if (rep.frame == 0) {
      ball0 = rigid::initialState(sim.model().bodies[0]).x;
      brick0 = rigid::initialState(sim.model().bodies[1]).x;
    }
    worst_ball = std::max(worst_ball, (b[0].x - ball0).norm());
    worst_brick = std::max(worst_brick, (b[1].x - brick0).norm());
    if (rep.frame > 0) worst_speed = std::max({worst_speed, b[0].v.norm(), b[1].v.norm()});
    worst_tilt = std::max(worst_tilt, b[1].q.angularDistance(Eigen::Quaterniond::Identity()));
    const double bottom = b[2].x.z() - 0.04;
    for (const auto& p : rigid::worldMesh(sim.model().bodies[2], b[2]).positions)
      lowest = std::min(lowest, double(p.z()));
    if (prev_vz < 0 && b[2].v.z() > 0) bounced = true;
    if (bounced && b[2].v.z() <= 0 && apex_after_bounce == 0) apex_after_bounce = bottom;
    prev_vz = b[2].v.z();
  });
  REQUIRE(r.exit_code == 0);
  INFO("ball moved " << worst_ball << " m, brick " << worst_brick << " m, tilt " << worst_tilt << " rad, speed "
                     << worst_speed << " m/s; dropped ball: lowest " << lowest << " m, apex after bounce "
                     << apex_after_bounce << " m");
  CHECK(worst_ball < 0.01 * dx);
  CHECK(worst_brick < 0.01 * dx);
  CHECK(worst_tilt < 1e-4);
  CHECK(worst_speed < 1e-6);
  CHECK(lowest > -1e-6);  // no vertex below the floor (float vertices: 1e-6 m)
  REQUIRE(bounced);
  const double v_impact = std::sqrt(2 * g * h);
  CHECK(apex_after_bounce <= e * e * h + v_impact * dt);
  CHECK(apex_after_bounce >= 0.5 * e * e * h);
}

TEST_CASE("Coupling: three balls of density 500, 1000 and 4000 kg/m^3 order themselves by density", "[rigid]") {
  // The scene and criterion in tests/three_balls.h (shared with the DFSPH test).
  testing::checkThreeBallsOrder({});
}

TEST_CASE("Fluid placed inside or against a body is removed at compile time", "[rigid]") {
  // The winding number tells inside from outside for a closed mesh (1 inside, 0 outside).
  const TriMesh ball = rigid::sphereMesh(0.05, 0.005);
  CHECK(windingNumber(ball, Eigen::Vector3d(0.01, -0.02, 0.03)) == Approx(1.0).margin(1e-9));
  CHECK(windingNumber(ball, Eigen::Vector3d(0.06, 0.0, 0.0)) == Approx(0.0).margin(1e-9));
  // The fast inside test (surface grid and pseudo-normals) that compile() uses agrees with the
  // winding number on points around a sphere, a box and a capsule, on either side of the surface.
  {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-0.08, 0.08);
    for (const TriMesh& mesh : {ball, rigid::boxMesh(Eigen::Vector3d(0.1, 0.06, 0.04)), rigid::capsuleMesh(0.03, 0.06, 0.005)}) {
      const ClosedSurface surface(mesh);
      int disagree = 0, inside = 0;
      for (int k = 0; k < 2000; ++k) {
        const Eigen::Vector3d p(u(rng), u(rng), u(rng));
        const bool w = windingNumber(mesh, p) > 0.5;
        disagree += surface.inside(p) != w;
        inside += w;
      }
      CHECK(disagree == 0);
      CHECK(inside > 50);  // both sides sampled
    }
  }
  // A block of water through a sphere: no particle left inside it or within dx of its particles
  // (where the boundary contact force would act on the first step).
  SceneSpec s = io::loadSceneFromString(kDomain +
                                            "fluid: {particle_spacing: 0.01, blocks: [{min: [0, 0, 0], max: [0.4, 0.4, 0.3]}]}\n"
                                            "rigid_bodies: [{name: b, shape: sphere, radius: 0.06, position: [0.2, 0.2, 0.2], "
                                            "density: 500, dynamic: true}]\n",
                                        "scene.yaml");
  const Compiled c = compile(s);
  const std::size_t full = 40 * 40 * 30;
  const rigid::RigidBody& body = c.model.bodies[0];
  const rigid::BodyState s0 = rigid::initialState(body);
  double nearest = 1e9;
  std::size_t inside = 0, bad_ids = 0;
  for (std::size_t i = 0; i < c.initial.size(); ++i) {
    const Eigen::Vector3d x = c.initial.pos[i].head<3>().cast<double>();
    inside += (x - s0.x).norm() <= 0.06;
    for (const auto& p : body.particles) nearest = std::min(nearest, (x - s0.toWorld(p.cast<double>())).norm());
    bad_ids += c.initial.id[i] != i;  // ids stay the creation order, without gaps
  }
  CHECK(inside == 0);
  CHECK(bad_ids == 0);
  INFO(full - c.initial.size() << " removed; nearest remaining particle " << nearest / 0.01 << " dx from the body's");
  CHECK(nearest >= 0.01 * (1 - 1e-6));
  // The removed ones: the sphere (~905 lattice points in 4/3 pi 6^3 dx^3) and a shell about dx thick.
  CHECK(full - c.initial.size() > 905);
  CHECK(full - c.initial.size() < 2500);
}

TEST_CASE("Coupling: Archimedes: a block of half the water's density floats with half its height submerged", "[rigid]") {
  // scenes/tests/floating_block.yaml; the scene, the measurement and the tolerances are in
  // tests/floating_block.h, shared with the DFSPH test (test_dfsph.cpp).
  const testing::FloatingBlock b = testing::floatingBlock({});
  REQUIRE(b.exit_code == 0);
  INFO("draft " << b.draft << " m (expected 0.03 m), mean fluid force " << b.frame_end_force << " N, weight " << b.weight << " N");
  CHECK(std::abs(b.draft - 0.03) < 0.05 * 0.03);
  CHECK(std::abs(b.frame_end_force - b.weight) < 0.02 * b.weight);  // at rest: the fluid carries it
}

TEST_CASE("Sampling: a body's face weighs what a domain wall weighs for fluid resting next to it", "[rigid]") {
  // The wall a fluid particle sees at rest dx/2 outside a flat face: the domain's complete lattice
  // (layers dx/2, 3dx/2, ... behind the face, volume dx^3 each). A body's face is one
  // Poisson-disk layer with Akinci volumes, scaled by bodyVolumeScale(), which is calibrated on
  // one box. Checked here on faces of other boxes (other sizes, so other samplings) and at other
  // distances from the face: the density sum and its normal gradient from the face must match
  // the lattice's. Tolerance, cubic spline (H = 2 dx): 3 %, the Poisson sampling's variation
  // over a face (unscaled the excess was 41 %). Wendland C2 (H = 3 dx): 12 %: one layer cannot
  // follow the profile of the three lattice layers its support reaches (measured: density exact
  // at dx/2 but its gradient 10 % low there, density 5 % high at 0.8 dx; unscaled, 85 % high).
  for (const int kernel : {SPH_KERNEL_CUBIC_SPLINE, SPH_KERNEL_WENDLAND_C2}) {
    const double dx = 0.01, H = (kernel == SPH_KERNEL_WENDLAND_C2 ? 3.0 : 2.0) * dx;
    const double scale = bodyVolumeScale(dx, H, kernel);
    INFO("kernel " << kernel << ", scale " << scale);
    CHECK(scale > 0.5);
    CHECK(scale < 1.0);  // a sampled face is denser than the lattice's dx^2 per particle
    for (const Eigen::Vector3d& size : {Eigen::Vector3d(0.17, 0.13, 0.09), Eigen::Vector3d(0.23, 0.21, 0.11)}) {
      const TriMesh box = rigid::boxMesh(size);
      std::vector<Eigen::Vector3f> normals;
      std::vector<Eigen::Vector3f> pts = rigid::sampleSurface(box, dx, &normals);
      for (std::size_t i = 0; i < pts.size(); ++i) pts[i] -= 0.5f * static_cast<float>(dx) * normals[i];
      const std::vector<float> vol = akinciVolumes(pts, static_cast<float>(H), kernel);
      for (const double s : {0.5 * dx, 0.8 * dx}) {
        double body = 0, body_grad = 0, lattice = 0, lattice_grad = 0;
        for (int a = -6; a <= 6; ++a)
          for (int b = -6; b <= 6; ++b) {
            const Eigen::Vector3d q(a * 0.53 * dx, b * 0.47 * dx, 0.5 * size.z() + s);
            for (std::size_t i = 0; i < pts.size(); ++i) {
              const Eigen::Vector3d d = q - pts[i].cast<double>();
              body += scale * vol[i] * sph_w(kernel, static_cast<float>(d.norm()), static_cast<float>(H));
              body_grad += scale * vol[i] * sph_grad_factor(kernel, static_cast<float>(d.norm()), static_cast<float>(H)) * d.z();
            }
            for (int k = 0; k < 5; ++k)
              for (int i = -5; i <= 5; ++i)
                for (int j = -5; j <= 5; ++j) {
                  const Eigen::Vector3d d(q.x() - (std::round(q.x() / dx) + i) * dx, q.y() - (std::round(q.y() / dx) + j) * dx,
                                          s + (k + 0.5) * dx);
                  const double V0 = dx * dx * dx;
                  lattice += V0 * sph_w(kernel, static_cast<float>(d.norm()), static_cast<float>(H));
                  lattice_grad += V0 * sph_grad_factor(kernel, static_cast<float>(d.norm()), static_cast<float>(H)) * d.z();
                }
          }
        INFO("box " << size.transpose() << ", probe " << s / dx << " dx out: density ratio " << body / lattice
                    << ", gradient ratio " << body_grad / lattice_grad);
        const double tol = kernel == SPH_KERNEL_CUBIC_SPLINE ? 0.03 : 0.12;
        CHECK(std::abs(body / lattice - 1) < tol);
        CHECK(std::abs(body_grad / lattice_grad - 1) < tol);
      }
    }
  }
}

TEST_CASE("Coupling: viscous torque on a turning cylinder follows circular Couette flow", "[rigid]") {
  // scenes/tests/rotating_cylinder.yaml at depths 6 and 10 cm. In Stokes flow (Re = 0.08) the
  // torque is T(D) = tau' D + T_ends: the floor and the free surface disturb the flow near them
  // alike at both depths, so tau' = (T(10 cm) - T(6 cm)) / 4 cm is the torque per unit height of
  // circular Couette flow, tau' = 4 pi mu omega R^2 Ro^2 / (Ro^2 - R^2) (Landau & Lifshitz, Fluid
  // Mechanics, section 18), mu = rho nu = 5 Pa s. The tank is square, half-side 6 cm: Ro lies
  // between the inscribed 6 cm and the circumscribed 8.5 cm circle (factor 1.125 .. 1.059).
  // Tolerance: where the no-slip surface sits is known to about dx/2 either side of the body's
  // true surface (its particles are dx/2 inside it, the fluid's dx/2 outside), so R^2 within
  // (1 +- dx/R), +-33 % at R = 3 dx. Measured in development: -10 .. -16 % at R = 3 dx, and
  // -4 .. -7.5 % at R = 4 dx in a 16 cm tank. Without the viscous term the torque is ~0.
  const double R = 0.02, nu = 0.005, rho = 1000, omega = 1, dx = 0.0066667;
  auto torque = [&](double depth) {
    app::RunOptions o;
    o.scene = (kSourceDir / "scenes" / "tests" / "rotating_cylinder.yaml").string();
    o.quiet = true;
    o.write_output = false;
    std::ostringstream set;
    set << "fluid.blocks[0].max=[0.12, 0.12, " << depth << "]";
    o.sets = {set.str()};
    double sum = 0;
    int n = 0;
    const app::RunResult r = app::runScene(o, [&](Simulation& sim, const FrameReport&) {
      if (sim.time() < 0.8 - 1e-9) return;  // steady: Ro^2 / nu = 0.7 s
      sum += sim.bodies()[0].fluid_torque.z();
      ++n;
    });
    REQUIRE(r.exit_code == 0);
    REQUIRE(n >= 5);
    return sum / n;
  };
  const double shallow = torque(0.06), deep = torque(0.10);
  const double slope = (deep - shallow) / 0.04;  // N m per m of depth; negative: it resists
  const double mu = rho * nu;
  const double infinite = 4 * M_PI * mu * omega * R * R;
  auto couette = [&](double Ro) { return infinite * Ro * Ro / (Ro * Ro - R * R); };
  const double lo = couette(0.06 * std::sqrt(2.0)) * (1 - dx / R), hi = couette(0.06) * (1 + dx / R);
  INFO("torque at 6 cm " << shallow << " N m, at 10 cm " << deep << " N m: " << -slope
                         << " N m/m resisting; Couette " << couette(0.06 * std::sqrt(2.0)) << " .. " << couette(0.06)
                         << ", allowed " << lo << " .. " << hi);
  CHECK(-slope > lo);
  CHECK(-slope < hi);
}

TEST_CASE("Coupling: a block denser than water sinks to the floor", "[rigid]") {
  // scenes/tests/floating_block.yaml with the block at 2000 kg/m^3 (twice the water's) and
  // dx = 1.5 cm: it sinks and comes to rest on the floor. As with the heavy ball of the three-ball
  // test, at most one particle layer stays trapped under its flat bottom (the fluid cannot resolve
  // a film thinner than a spacing), so its bottom must end within 1.5 dx of the floor, at rest,
  // with floor contact and fluid together carrying its weight (10 %: the trapped layer's pressure
  // noise). Measured: from 8.7 to 4.1 cm, bottom 0.76 dx above the floor, fluid force = weight to 0.3 %
  // (session 31: bodies in water touch the walls across a film of dx, Model::wall_film; now from 8.7 to
  // 4.5 cm, bottom 1.0 dx above the floor, fluid 7.17 N + contact 9.79 N against the weight 16.95 N).
  app::RunOptions o;
  o.scene = (kSourceDir / "scenes" / "tests" / "floating_block.yaml").string();
  o.quiet = true;
  o.write_output = false;
  o.sets = {"rigid_bodies[0].density=2000", "fluid.particle_spacing=0.015", "simulation.duration=1.0"};
  double start = 0, mass = 0;
  rigid::BodyState end;
  const app::RunResult r = app::runScene(o, [&](Simulation& sim, const FrameReport&) {
    if (start == 0) start = sim.bodies()[0].x.z();
    mass = sim.model().bodies[0].mass;
    end = sim.bodies()[0];
  });
  REQUIRE(r.exit_code == 0);
  const double dx = 0.015, h = 0.06, weight = mass * 9.81;
  INFO("start " << start << " m, end " << end.x.z() << " m (bottom " << (end.x.z() - 0.5 * h) / dx << " dx above the floor), speed "
                << end.v.norm() << " m/s; fluid " << end.fluid_force.z() << " N + contact " << end.contact_force.z()
                << " N against the weight " << weight << " N");
  CHECK(end.x.z() < start - h / 2);  // it went down, not floated
  CHECK(end.x.z() - 0.5 * h < 1.5 * dx);
  CHECK(end.v.norm() < 0.01);  // at rest: under 1 cm/s
  CHECK(std::abs(end.fluid_force.z() + end.contact_force.z() - weight) < 0.1 * weight);
}

TEST_CASE("rigid: the fictitious mass keeps a steady acceleration and stabilises a lagged added mass", "[rigid]") {
  // rigid::integrateVelocity with a fictitious mass M (fluid.dfsph.body_added_mass; Baek &
  // Karniadakis 2012): (m + M) a_n = F_n + M a_{n-1}. A model of DFSPH's staggered coupling: the
  // fluid answers the body's last step's acceleration in full, F_n = F0 - m_a a_{n-1}, whose exact
  // answer is the added-mass acceleration a* = F0 / (m + m_a). Plain update: a_n = (F0 - m_a
  // a_{n-1}) / m, its error times -m_a / m per step: it grows when m_a > m (the released 500
  // kg/m^3 ball, m_a ~ 1.6 m per 3.3 ms step, docs/forces.md session 11). With M: times (M - m_a)
  // / (m + M). And with no fluid answer (m_a = 0) a steady force still gives F0 / m: the error
  // shrinks by M / (m + M) per step.
  rigid::RigidBody body;
  body.kind = rigid::BodyKind::Dynamic;
  body.mass = 0.5;  // kg
  body.inertia = body.inv_inertia = Eigen::Matrix3d::Identity();
  const double F0 = 0.5, dt = 0.003;  // N, s
  const Eigen::Vector3d g = Eigen::Vector3d::Zero();
  // The acceleration after `steps` steps of the model with answer m_a (kg) and fictitious mass M (kg).
  auto run = [&](double m_a, double M, int steps) {
    rigid::BodyState s;
    for (int n = 0; n < steps; ++n) {
      s.fluid_force = Eigen::Vector3d(0, 0, F0 - m_a * s.accel.z());
      const Eigen::Vector3d v0 = s.v;
      rigid::integrateVelocity(body, s, g, dt, M);
      s.accel = (s.v - v0) / dt;
    }
    return s.accel.z();
  };
  const double m_a = 1.6 * body.mass, exact = F0 / (body.mass + m_a);
  // Plain: the error after 30 steps is 1.6^30 ~ 1e6 times the first step's.
  CHECK(std::abs(run(m_a, 0.0, 30) - exact) > 1e3 * std::abs(run(m_a, 0.0, 1) - exact));
  // A sphere's 1/2 rho V = m here (a 500 kg/m^3 ball): ratio -0.3 per step, 1e-15 after 30.
  CHECK(std::abs(run(m_a, body.mass, 30) - exact) < 1e-9 * exact);
  // Lighter (m_a < m): both converge to the same answer.
  CHECK(std::abs(run(0.5 * body.mass, 0.0, 60) - F0 / (1.5 * body.mass)) < 1e-9 * F0);
  CHECK(std::abs(run(0.5 * body.mass, body.mass, 60) - F0 / (1.5 * body.mass)) < 1e-9 * F0);
  // No fluid answer: F0 / m (ratio 1/2 per step), not F0 / (m + M).
  CHECK(std::abs(run(0.0, body.mass, 60) - F0 / body.mass) < 1e-9 * F0 / body.mass);
  // M = 0 is the plain update, bit for bit.
  rigid::BodyState a, b;
  a.fluid_force = b.fluid_force = Eigen::Vector3d(0.1, -0.2, 0.3);
  a.accel = b.accel = Eigen::Vector3d(1.0, 2.0, -3.0);
  rigid::integrateVelocity(body, a, Eigen::Vector3d(0, 0, -9.81), dt, 0.0);
  b.v += dt * (body.mass * Eigen::Vector3d(0, 0, -9.81) + b.fluid_force) / body.mass;
  CHECK(a.v == b.v);
  // The fictitious force (rigid::fictitiousForce, given back to the fluid by the Simulation) is
  // all that moves the body besides its forces: m (v' - v) = dt (F + F_M), F_M = M (a_{n-1} - a_n).
  rigid::BodyState c;
  c.fluid_force = Eigen::Vector3d(0.1, -0.2, 0.3);
  c.external_force = Eigen::Vector3d(0.05, 0.0, -0.1);
  c.accel = Eigen::Vector3d(1.0, 2.0, -3.0);
  c.v = Eigen::Vector3d(0.2, 0.1, -0.3);
  const Eigen::Vector3d gz(0, 0, -9.81), v0 = c.v, a_prev = c.accel;
  const double M = 0.7;  // kg
  const Eigen::Vector3d F_M = rigid::fictitiousForce(body, c, gz, M);
  rigid::integrateVelocity(body, c, gz, dt, M);
  const Eigen::Vector3d F = body.mass * gz + c.fluid_force + c.external_force;
  CHECK((body.mass * (c.v - v0) - dt * (F + F_M)).norm() < 1e-12);
  CHECK((F_M - M * (a_prev - (c.v - v0) / dt)).norm() < 1e-9);
  CHECK(rigid::fictitiousForce(body, c, gz, 0.0).norm() == 0.0);
}

TEST_CASE("Coupling: no water leaks into a held ball shaken in a tank at R / dx = 5", "[rigid]") {
  // scenes/tests/accel_ball.yaml at dx = 6 mm (R / dx = 5), without its settle: the tank starts with
  // gravity on, rings, and the held ball is shaken from 0.05 s (A = 3 mm, 10 Hz; one period here). A
  // body is one sampled layer of particles dx/2 inside its surface R (as the walls' first layer), so a
  // fluid centre deeper than dx/2 inside R has gone through the layer (the landing test below uses the
  // same criterion). Until session 35 the sampler's Poisson-disk radius was 0.8 dx, its largest holes 0.70 dx
  // in radius at R / dx = 5, and the fluid-body contact reaches dx/2: the first centre went through by
  // 0.04 s, and after the tank's 0.5 s settle 8 centres (WCSPH; DFSPH 3) sat inside the ball bouncing at
  // up to 1.9 m/s. At 0.75 dx (holes 0.67 dx) none goes through (docs/forces.md, sessions 34-35).
  // WCSPH only: it leaked the most. Measured (session 35): the deepest centre 0.06 mm outside R. Mutation:
  // with the sampling back at 0.8 dx, a centre 20.1 mm inside R at 0.04 s: fails.
  app::RunOptions o;
  o.scene = (kSourceDir / "scenes" / "tests" / "accel_ball.yaml").string();
  o.quiet = true;
  o.write_output = false;
  o.sets = {"fluid.particle_spacing=0.006", "simulation.settle_time=0", "simulation.duration=0.15",
            "fluid.solver=wcsph"};
  double deepest = -1.0;  // (unit: m) the deepest fluid centre inside the ball's sphere (negative: outside)
  double deepest_t = 0.0, R = 0, dx = 0;
  int through = 0;  // frames with a centre more than dx/2 inside
  const app::RunResult r = app::runScene(o, [&](Simulation& sim, const FrameReport&) {
    REQUIRE(sim.bodies().size() == 1);
    R = sim.model().bodies[0].spec.radius;
    dx = sim.model().dx;
    const Eigen::Vector3d c = sim.bodies()[0].x;
    const ParticleFrame f = sim.readFrame();
    double frame_deepest = -1.0;
    for (std::size_t i = 0; i < f.size(); ++i)
      frame_deepest = std::max(frame_deepest, R - (Eigen::Vector3d(f.x[i], f.y[i], f.z[i]) - c).norm());
    if (frame_deepest > deepest) deepest = frame_deepest, deepest_t = sim.time();
    through += frame_deepest > 0.5 * dx ? 1 : 0;
  });
  INFO(r.message << "; R / dx " << R / dx << ", deepest fluid centre " << deepest * 1000 << " mm inside R at t = "
                 << deepest_t << " s (negative: outside), " << through << " frame(s) with one past dx/2");
  REQUIRE(r.exit_code == 0);
  CHECK(through == 0);
}

TEST_CASE("Coupling: a heavy ball landing on the floor rests on a film of water and swallows none of it", "[rigid]") {
  // scenes/floating_bodies.yaml (WCSPH, its own solver): the 4,000 kg/m^3 ball (R = 3 cm, dx = 1 cm)
  // falls 22 cm through the water and lands at 1.3 m/s at t = 0.23 s. Before session 31 its surface
  // reached the floor; the last fluid particle under it, held from below by the floor's contact, went
  // through a hole of the ball's one sampled layer and stayed 2-3 cm inside the ball for the rest of
  // the run. In water, bodies now touch the closed walls across a film of one spacing (Model::wall_film:
  // one fluid layer, the thinnest film SPH resolves). Checked to 0.5 s, 0.27 s past
  // the landing: no fluid centre inside the ball's sphere in any frame, and the ball rests with its
  // surface dx above the floor (its centre at R + dx within dx/10: the contact's slop and one step's
  // travel are far smaller), not bouncing (vertical speed under 1 cm/s; it may roll with the water,
  // which still sloshes from the three balls' entry). Measured: deepest centre 0.27 mm outside,
  // centre 0.03991 m at 0.5 s (at most 0.03997 after 0.3 s), rolling at 1.4 cm/s. Mutation: without
  // the film, a particle up to 28.6 mm deep in 9 frames from 0.23 s and the centre at R: fails.
  // Swallowed means through the ball's one sampled layer, which lies dx/2 inside R: a centre more than
  // dx/2 inside R in any frame, or any centre inside R at the end. Until
  // session 35 any centre inside R in any frame failed; with the denser sampling (Poisson-disk radius
  // 0.75 dx, against the leak into a held ball at R / dx = 5, the test above) one centre of the film
  // pressed under the landing ball grazes the layer, 0.37 mm (0.04 dx) inside R in one frame, and is
  // out again by the next. (A non-penetration contact at the body's surface instead of the film kept the
  // particle out, but the squeezed particle was a spring that kicked the ball 1.9 cm up, at up to 110 N
  // of fluid force against 3.3 N of weight under water: it would fail the check after 0.3 s.)
  app::RunOptions o;
  o.scene = (kSourceDir / "scenes" / "floating_bodies.yaml").string();
  o.quiet = true;
  o.write_output = false;
  o.sets = {"simulation.duration=0.5"};
  double deepest = -1.0;  // (unit: m) how far the deepest fluid centre is inside the ball (negative: outside)
  double last = -1.0;     // ... in the last frame
  int inside_frames = 0;
  double z_landed_max = -1.0;  // highest centre after the landing (t >= 0.3 s)
  rigid::BodyState end;
  double R = 0, dx = 0;
  const app::RunResult r = app::runScene(o, [&](Simulation& sim, const FrameReport&) {
    std::size_t metal = sim.model().bodies.size();
    for (std::size_t b = 0; b < sim.model().bodies.size(); ++b)
      if (sim.model().bodies[b].spec.name == "metal") metal = b;
    REQUIRE(metal < sim.model().bodies.size());
    R = sim.model().bodies[metal].spec.radius;
    dx = sim.model().dx;
    end = sim.bodies()[metal];
    const ParticleFrame f = sim.readFrame();
    last = -1.0;
    for (std::size_t i = 0; i < f.size(); ++i)
      last = std::max(last, R - (Eigen::Vector3d(f.x[i], f.y[i], f.z[i]) - end.x).norm());
    deepest = std::max(deepest, last);
    inside_frames += last > 0.0 ? 1 : 0;
    if (sim.time() >= 0.3 - 1e-9) z_landed_max = std::max(z_landed_max, end.x.z());
  });
  INFO(r.message << "; deepest centre " << deepest * 1000 << " mm inside the ball (negative: outside), " << inside_frames
                 << " frame(s) with one inside R, in the last frame " << last * 1000 << " mm; centre at rest " << end.x.z() << " m (R + dx = " << R + dx
                 << "), highest after 0.3 s " << z_landed_max << " m, velocity " << end.v.transpose() << " m/s");
  REQUIRE(r.exit_code == 0);
  CHECK(deepest < 0.5 * dx);
  CHECK(last <= 0.0);
  CHECK(std::abs(end.x.z() - (R + dx)) < 0.1 * dx);
  CHECK(z_landed_max < R + 1.1 * dx);
  CHECK(std::abs(end.v.z()) < 0.01);
}
