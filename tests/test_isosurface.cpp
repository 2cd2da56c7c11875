// Isosurface stage: the marching-cubes table, the device marching cubes on analytic fields
// (watertight, manifold, converging to the exact volume and area), a block of particles at rest,
// and the OBJ sequence a run writes.
#include "cli/runner.h"
#include "core/cl_context.h"
#include "core/isosurface.h"
#include "core/marching_cubes_table.h"
#include "core/mesh.h"
#include "core/model.h"
#include "core/simulation.h"
#include "io/async_writer.h"
#include "io/obj_io.h"
#include "io/scene_loader.h"
#include "io/vdb_writer.h"
#include "kernels/shared/sph_kernel.h"
#include "temp_dir.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <stdexcept>

namespace fs = std::filesystem;

using namespace sph;

namespace {

constexpr const char* kOptions = "-cl-std=CL1.2 -DSPH_KERNEL=0 -DSPH_LAMINAR=0";
constexpr double kPi = 3.14159265358979323846;

// Samples f on a cube [-half, half]^3 with `n` cells per axis.
template <class F>
DenseGrid sample(double half, int n, F f) {
  DenseGrid g;
  g.spacing = 2 * half / n;
  g.origin = Eigen::Vector3d::Constant(-half);
  g.dims = {n + 1, n + 1, n + 1};
  g.values.resize(static_cast<std::size_t>(n + 1) * (n + 1) * (n + 1));
  for (int k = 0; k <= n; ++k)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) g.values[g.index(i, j, k)] = static_cast<float>(f(g.position(i, j, k)));
  return g;
}

}  // namespace

TEST_CASE("iso: the marching-cubes table is complete and needs no unsafe fan", "[iso]") {
  const MarchingCubesTable& t = marchingCubesTable();
  CHECK(t.unsafe_cases == 0);
  CHECK(t.max_triangles <= MarchingCubesTable::kMaxTriangles);
  CHECK(t.triangle_count[0] == 0);
  CHECK(t.triangle_count[255] == 0);
  CHECK(t.triangle_count[1] == 1);    // one corner inside: one triangle
  CHECK(t.triangle_count[3] == 2);    // an edge inside: a quad
  CHECK(t.triangle_count[15] == 2);   // a face inside: a quad
}

TEST_CASE("iso: marching cubes on a sphere is closed and converges to its volume and area", "[iso]") {
  ClContext cl;
  KernelSet kernels(cl, kOptions);
  SurfaceMesher mesher(cl, kernels);
  const double R = 1.0;
  const Eigen::Vector3d centre(0.013, -0.021, 0.007);  // off the grid's symmetry
  const double V = 4.0 / 3.0 * kPi * R * R * R, A = 4.0 * kPi * R * R;
  double prev_v = 1e9, prev_a = 1e9;
  for (int n : {10, 20, 40, 80}) {
    const DenseGrid g = sample(1.3 * R, n, [&](const Eigen::Vector3d& x) { return R - (x - centre).norm(); });
    const TriMesh m = mesher.meshGrid(g, 0.0f);
    const EdgeReport e = checkEdges(m);
    INFO("cells per axis " << n << ": " << m.numVertices() << " vertices, " << m.numTriangles() << " triangles");
    CHECK(e.closed());
    CHECK(e.degenerate == 0);
    // Euler characteristic of a sphere: V - E + F = 2.
    CHECK(static_cast<long>(m.numVertices()) - static_cast<long>(e.edges) + static_cast<long>(m.numTriangles()) == 2);
    const double ev = std::fabs(meshVolume(m) / V - 1.0), ea = std::fabs(meshArea(m) / A - 1.0);
    INFO("volume error " << ev << ", area error " << ea);
    // Linear interpolation puts vertices within O(s^2 / R) of the sphere: the error falls ~4x per halving.
    CHECK(ev < prev_v);
    CHECK(ea < prev_a);
    prev_v = ev;
    prev_a = ea;
    if (n >= 40) {  // s = R / 15 and finer
      CHECK(ev < 0.01);
      CHECK(ea < 0.01);
    }
    // Normals from the field gradient point outward (away from the centre).
    std::size_t outward = 0;
    for (std::size_t i = 0; i < m.numVertices(); ++i)
      if (m.normals[i].cast<double>().dot(m.positions[i].cast<double>() - centre) > 0) ++outward;
    CHECK(outward == m.numVertices());
  }
}

TEST_CASE("iso: marching cubes on random fields is manifold (ambiguous faces included)", "[iso]") {
  ClContext cl;
  KernelSet kernels(cl, kOptions);
  SurfaceMesher mesher(cl, kernels);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int trial = 0; trial < 20; ++trial) {
    // Independent values at the inner nodes give every case, ambiguous faces and cells included;
    // the border is outside, so every component is closed.
    const int n = 10;
    DenseGrid g = sample(1.0, n, [](const Eigen::Vector3d&) { return -1.0; });
    for (int k = 1; k < n; ++k)
      for (int j = 1; j < n; ++j)
        for (int i = 1; i < n; ++i) g.values[g.index(i, j, k)] = u(rng);
    const TriMesh m = mesher.meshGrid(g, 0.0f);
    const EdgeReport e = checkEdges(m);
    INFO("trial " << trial << ": " << m.numTriangles() << " triangles, " << e.boundary << " boundary, "
                  << e.nonmanifold << " non-manifold, " << e.misoriented << " misoriented edges");
    REQUIRE(m.numTriangles() > 0);
    CHECK(e.closed());
    CHECK(e.degenerate == 0);
    CHECK(meshVolume(m) > 0);  // outward winding
  }
}

namespace {

// Tail of the kernel's 1D marginal: G(a) = P(X >= a) for a displacement X distributed as W in 3D,
// i.e. the share of a particle's kernel that lies beyond the plane at distance a. G(0) = 1/2 and
// G(a >= H) = 0. The marginal density is w1(x) = 2 pi int_{|x|}^{H} W(r) r dr.
struct KernelTail {
  double H;
  std::vector<double> G;  // at a = H * i / n
  int n = 2000;
  explicit KernelTail(double support) : H(support) {
    std::vector<double> w1(static_cast<std::size_t>(n) + 1);
    const double dr = H / n;
    for (int i = n; i >= 0; --i) {  // w1 at x_i = i dr, by the midpoint rule over r in [x_i, H]
      double s = 0;
      for (int k = i; k < n; ++k) {
        const double r = (k + 0.5) * dr;
        s += sph_cubic_w(static_cast<float>(r), static_cast<float>(H)) * r * dr;
      }
      w1[static_cast<std::size_t>(i)] = 2 * kPi * s;
    }
    G.assign(static_cast<std::size_t>(n) + 1, 0.0);
    for (int i = n - 1; i >= 0; --i)
      G[static_cast<std::size_t>(i)] =
          G[static_cast<std::size_t>(i) + 1] + 0.5 * (w1[static_cast<std::size_t>(i)] + w1[static_cast<std::size_t>(i) + 1]) * dr;
  }
  double operator()(double a) const {
    if (a >= H) return 0;
    return G[static_cast<std::size_t>(std::lround(a / H * n))];
  }
};

}  // namespace

TEST_CASE("iso: a block of particles at rest gives a closed surface enclosing the block's volume", "[iso]") {
  // Expectation. The particles of a block sit at the centres of the dx-cubes that fill the block
  // B, so the field sum_j V0 W(x - x_j) is a quadrature of the continuum field (chi_B * W)(x)
  // (exact to < 1 % for the cubic spline at H = 2 dx: lattice test in test_physics.cpp).
  // Continuum: across a face, far from edges, the field is 1/2 exactly on the face (W is even),
  // so the iso-0.5 surface lies on B's faces, half a spacing outside the outer particle layer.
  // Outside B the field is <= 1/2 (each face's half-space bounds it), so the surface never leaves B.
  // Near an edge, at depths a, b from its two faces, field >= 1 - G(a) - G(b) (G: the kernel's
  // tail beyond a plane), so the surface can only cut off {G(a) + G(b) >= 1/2} per unit edge
  // length, and at a corner {G(a) + G(b) + G(c) >= 1/2}. Hence
  //   V_B - sum_edges L_e A_edge - 8 C_corner - slack <= V_mesh <= V_B + slack,
  // slack = area(B) * 0.1 dx for the quadrature and for marching cubes' linear interpolation
  // (on a smooth profile of width ~H sampled at dx / 2, both are a few hundredths of dx).
  SceneSpec spec;
  spec.simulation.gravity = Eigen::Vector3d::Zero();
  spec.domain.min = Eigen::Vector3d(0, 0, 0);
  spec.domain.max = Eigen::Vector3d(0.4, 0.3, 0.3);
  spec.fluid.particle_spacing = 0.01;
  spec.fluid.phases.resize(1);
  spec.fluid.phases[0].name = "water";
  spec.fluid.blocks.resize(1);
  spec.fluid.blocks[0].min = Eigen::Vector3d(0.1, 0.08, 0.07);
  spec.fluid.blocks[0].max = Eigen::Vector3d(0.26, 0.2, 0.17);
  Compiled c = compile(spec);
  ClContext cl;
  Simulation sim(c.model, c.initial, cl);
  IsoSettings settings;
  settings.spacing = 0.5 * c.model.dx;
  const std::vector<TriMesh> meshes = sim.surfaceMeshes(settings);
  REQUIRE(meshes.size() == 1);
  const TriMesh& m = meshes[0];
  REQUIRE(m.numTriangles() > 0);
  CHECK(checkEdges(m).closed());

  // B from the particles themselves: half a spacing beyond the outer layer.
  const double dx = c.model.dx, H = c.model.support;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e9), hi = Eigen::Vector3d::Constant(-1e9);
  for (const auto& p : c.initial.pos) {
    lo = lo.cwiseMin(p.head<3>().cast<double>());
    hi = hi.cwiseMax(p.head<3>().cast<double>());
  }
  const Eigen::Vector3d L = (hi - lo).array() + dx;
  REQUIRE((L.array() > 2 * H).all());  // one face per axis within H of any point
  const double VB = L.prod(), AB = 2 * (L.x() * L.y() + L.y() * L.z() + L.z() * L.x());

  // The edge and corner bounds, by quadrature of the kernel tail.
  const KernelTail G(H);
  const int q = 200;
  const double d = H / q;
  double A_edge = 0, C_corner = 0;
  for (int i = 0; i < q; ++i)
    for (int j = 0; j < q; ++j) {
      const double gij = G((i + 0.5) * d) + G((j + 0.5) * d);
      if (gij >= 0.5) A_edge += d * d;
      if (i % 4 == 0 && j % 4 == 0)
        for (int k = 0; k < q; k += 4)
          if (gij + G((k + 0.5) * d) >= 0.5) C_corner += 64 * d * d * d;
    }
  const double deficit = 4 * L.sum() * A_edge + 8 * C_corner;
  const double slack = AB * 0.1 * dx;
  const double V = meshVolume(m);
  INFO("block " << L.transpose() << " m: V_B = " << VB << ", mesh " << V << " (" << (V / VB - 1) * 100
                << " %), allowed [" << VB - deficit - slack << ", " << VB + slack << "]; edge deficit bound "
                << A_edge / (H * H) << " H^2 per unit length");
  CHECK(V <= VB + slack);
  CHECK(V >= VB - deficit - slack);
  // Every vertex of the surface lies within B grown by the slack (never outside the continuum).
  for (const auto& x : m.positions) {
    CHECK((x.cast<double>().array() >= lo.array() - 0.5 * dx - 0.1 * dx).all());
    CHECK((x.cast<double>().array() <= hi.array() + 0.5 * dx + 0.1 * dx).all());
  }
}

namespace {

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

const std::string kTinyIsoScene = R"(simulation: {duration: 0.05, frame_rate: 60, substeps: 2}
domain: {min: [0, 0, 0], max: [0.2, 0.1, 0.2]}
fluid:
  particle_spacing: 0.01
  colour_diffusion: 1.0e-4
  phases:
    - {name: water, rest_density: 1000, colour: [0.2, 0.4, 0.9]}
    - {name: oil, rest_density: 800, colour: [0.9, 0.6, 0.1]}
  blocks:
    - {phase: water, min: [0, 0, 0], max: [0.08, 0.1, 0.06]}
    - {phase: oil, min: [0.12, 0, 0], max: [0.2, 0.1, 0.05]}
output:
  particles: false
  isosurface: {vertex_colours: true}
)";

}  // namespace

TEST_CASE("iso: a run writes one OBJ per phase and frame that reads back, byte-identical across runs", "[iso]") {
  testing::TempDir tmp;
  const fs::path scene = tmp.write("tiny_iso.yaml", kTinyIsoScene);
  std::vector<app::RunResult> runs;
  for (const char* out : {"a", "b"}) {
    app::RunOptions opt;
    opt.scene = scene.string();
    opt.out = (tmp.path / out).string();
    opt.quiet = true;
    runs.push_back(app::runScene(opt));
    INFO(runs.back().message);
    REQUIRE(runs.back().exit_code == 0);
  }
  const int frames = runs[0].frames;
  REQUIRE(frames == 3);
  std::size_t vertices = 0, triangles = 0;
  for (int f = 0; f <= frames; ++f)
    for (const char* phase : {"water", "oil"}) {
      char name[64];
      std::snprintf(name, sizeof name, "fluid_%s_%04d.obj", phase, f);
      const fs::path a = tmp.path / "a" / name, b = tmp.path / "b" / name;
      INFO(name);
      REQUIRE(fs::exists(a));
      const std::string text = slurp(a);
      CHECK(text == slurp(b));
      CHECK(text.find("# particle_spacing: 0.01 m\n") != std::string::npos);
      CHECK(text.find("# phase: " + std::string(phase) + "\n") != std::string::npos);
      const TriMesh m = io::readObj(a.string());
      CHECK(checkEdges(m).closed());
      CHECK(m.normals.size() == m.numVertices());
      // The reader sees what the writer wrote: one 'v' and one 'vn' per vertex, one 'f' per triangle.
      std::size_t v = 0, vn = 0, fc = 0;
      std::istringstream lines(text);
      const Eigen::Vector3f colour = std::string(phase) == "water" ? Eigen::Vector3f(0.2f, 0.4f, 0.9f)
                                                                   : Eigen::Vector3f(0.9f, 0.6f, 0.1f);
      float worst_colour = 0;
      for (std::string line; std::getline(lines, line);) {
        if (line.rfind("v ", 0) == 0) {
          // Vertex colours: the Shepard average over the phase's own particles. The blocks are 4 cm
          // apart, so diffusion has nothing to mix: every vertex has the phase's colour.
          std::istringstream in(line.substr(2));
          Eigen::Vector3f x, c;
          in >> x.x() >> x.y() >> x.z() >> c.x() >> c.y() >> c.z();
          worst_colour = std::max(worst_colour, (c - colour).cwiseAbs().maxCoeff());
        }
        if (line.rfind("v ", 0) == 0) ++v;
        if (line.rfind("vn ", 0) == 0) ++vn;
        if (line.rfind("f ", 0) == 0) ++fc;
      }
      CHECK(m.numVertices() == v);
      CHECK(vn == v);
      CHECK(m.numTriangles() == fc);
      CHECK(worst_colour < 1e-3f);  // 4 significant digits in the file
      if (f == frames) {
        vertices += m.numVertices();
        triangles += m.numTriangles();
      }
    }
  // ... and the last frame holds exactly the meshes the simulation produced.
  CHECK(vertices == runs[0].surface_vertices);
  CHECK(triangles == runs[0].surface_triangles);
}

TEST_CASE("iso: without output.isosurface no isosurface kernel is enqueued", "[iso]") {
  testing::TempDir tmp;
  const fs::path scene = tmp.write("tiny_iso.yaml", kTinyIsoScene);
  auto isoDispatches = [](const app::RunResult& r) {
    uint64_t n = 0;
    for (const auto& [name, count] : r.dispatch_counts)
      if (name.rfind("iso_", 0) == 0 || name.rfind("mc_", 0) == 0) n += count;
    return n;
  };
  app::RunOptions opt;
  opt.scene = scene.string();
  opt.quiet = true;
  opt.write_output = false;
  opt.sets = {"output.isosurface.enabled=false"};
  const app::RunResult off = app::runScene(opt);
  REQUIRE(off.exit_code == 0);
  CHECK(isoDispatches(off) == 0);
  opt.sets.clear();
  const app::RunResult on = app::runScene(opt);
  REQUIRE(on.exit_code == 0);
  // One field pass per output frame (the initial state included), marching cubes per phase.
  CHECK(on.dispatch_counts.at("iso_field") == static_cast<uint64_t>(on.frames + 1));
  CHECK(on.dispatch_counts.at("mc_emit_triangles") == static_cast<uint64_t>(2 * (on.frames + 1)));
  // The isosurface reads the state and never changes it.
  CHECK(on.state_hash == off.state_hash);
}

TEST_CASE("iso: a scene without the section leaves the isosurface off, the section turns it on", "[iso]") {
  testing::TempDir tmp;
  const fs::path with = tmp.write("with.yaml", kTinyIsoScene);
  CHECK(io::loadScene(with.string()).output.isosurface.enabled);
  CHECK_FALSE(io::loadScene(with.string(), {"output.isosurface.enabled=false"}).output.isosurface.enabled);
  const fs::path without = tmp.write("without.yaml", kTinyIsoScene.substr(0, kTinyIsoScene.find("output:")));
  CHECK_FALSE(io::loadScene(without.string()).output.isosurface.enabled);
  CHECK(io::loadScene(without.string(), {"output.isosurface.spacing=0.004"}).output.isosurface.enabled);
}

TEST_CASE("iso: the writer thread runs jobs in order and stops at the first failure", "[iso]") {
  io::AsyncWriter w(2);
  std::vector<int> done;
  for (int i = 0; i < 5; ++i) w.push([&done, i] { done.push_back(i); });
  w.push([] { throw std::runtime_error("disk full"); });
  w.push([&done] { done.push_back(99); });  // dropped: the writer has stopped
  CHECK(w.close() == "disk full");
  CHECK(done == std::vector<int>{0, 1, 2, 3, 4});
  CHECK(w.close() == "disk full");  // idempotent
}

TEST_CASE("iso: a run with vdb writes fluid_%04d.vdb with the fields, the total and the level set", "[iso][vdb]") {
  testing::TempDir tmp;
  const fs::path scene = tmp.write("tiny_iso.yaml", kTinyIsoScene);
  app::RunOptions opt;
  opt.scene = scene.string();
  opt.out = (tmp.path / "run").string();
  opt.quiet = true;
  opt.sets = {"output.isosurface.vdb=true", "output.isosurface.vdb_level_set=true", "output.isosurface.obj=false"};
  const app::RunResult r = app::runScene(opt);
  INFO(r.message);
  REQUIRE(r.exit_code == 0);
  const double dx = 0.01;
  for (int f = 0; f <= r.frames; ++f) {
    char name[32];
    std::snprintf(name, sizeof name, "fluid_%04d.vdb", f);
    const std::string path = (tmp.path / "run" / name).string();
    INFO(name);
    REQUIRE(fs::exists(path));
    CHECK_FALSE(fs::exists(tmp.path / "run" / ("fluid_water_" + std::string(name + 6, 4) + ".obj")));  // obj: false
    const auto info = io::readVdbInfo(path);
    REQUIRE(info.size() == 4);
    std::map<std::string, std::string> classes;
    for (const auto& g : info) classes[g.name] = g.grid_class;
    CHECK(classes == std::map<std::string, std::string>{{"density", "Fog Volume"},
                                                        {"density_water", "Fog Volume"},
                                                        {"density_oil", "Fog Volume"},
                                                        {"surface", "Level Set"}});
    REQUIRE(info[0].name == "density");
    // Voxel = the surface grid spacing (automatic: dx / 2), and the field is ~1 inside the fluid
    // (it is normalised so: sum_j V0 W = 1 on a lattice, within the kernel's lattice-sum error of a
    // few percent plus compression) and below 1e-6 of its maximum (inactive, 0) far above it.
    CHECK(info[0].voxel_size == Approx(0.5 * dx).epsilon(1e-9));
    CHECK(info[0].max_active > 0.9f);
    CHECK(info[0].max_active < 1.15f);
    const Eigen::Vector3d in_water(0.04, 0.05, 0.02), in_oil(0.16, 0.05, 0.02), above(0.1, 0.05, 0.15);
    CHECK(io::sampleVdb(path, "density", in_water) == Approx(1.0).margin(0.1));
    CHECK(io::sampleVdb(path, "density_water", in_water) == Approx(1.0).margin(0.1));
    CHECK(io::sampleVdb(path, "density_oil", in_water) == Approx(0.0).margin(1e-6));
    CHECK(io::sampleVdb(path, "density_oil", in_oil) == Approx(1.0).margin(0.1));
    CHECK(io::sampleVdb(path, "density", above) == Approx(0.0).margin(1e-6));
    // The level set is negative inside (deeper than its narrow band here, 3 voxels: the band's
    // inside value) and positive outside.
    CHECK(io::sampleVdb(path, "surface", in_water) == Approx(-3 * 0.5 * dx).epsilon(1e-5));
    CHECK(io::sampleVdb(path, "surface", Eigen::Vector3d(0.1, 0.05, 0.03)) > 0.0);
  }
}
