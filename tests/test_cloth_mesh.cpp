// Cloth from an OBJ triangle mesh (issue 11, cloth[].mesh): lumped node masses, stretch springs
// along edges, bend springs across interior edges; against the closed forms of a square
// triangulated like the rectangle grid, the weight on the anchors at rest, and bad files.
#include "core/cl_context.h"
#include "core/cloth.h"
#include "core/errors.h"
#include "core/model.h"
#include "core/simulation.h"
#include "io/cloth_writer.h"
#include "io/scene_loader.h"
#include "tests/run_binary.h"
#include "tests/scene_issues.h"
#include "tests/temp_dir.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <sstream>
#include <string>

using namespace sph;

namespace {

const double kG = 9.81;

/// An n x n grid of width w in the xy plane, centred on the origin, vertex j * n + i, each cell
/// split along (i, j)-(i+1, j+1) as the rectangle cloth's exported mesh.
std::string squareObj(int n, double w) {
  std::ostringstream o;
  o.precision(17);
  const double h = w / (n - 1);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) o << "v " << -0.5 * w + i * h << " " << -0.5 * w + j * h << " 0\n";
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const int a = j * n + i + 1, b = a + 1, c = a + n + 1, d = a + n;  // OBJ: 1-based
      o << "f " << a << " " << b << " " << c << "\nf " << a << " " << c << " " << d << "\n";
    }
  return o.str();
}

/// A scene with one cloth, no fluid, gravity -z; `cloth` is the item's keys (indented 4).
std::string sceneText(const std::string& cloth, double duration) {
  std::ostringstream s;
  s << "simulation: {duration: " << duration << ", frame_rate: 60, substeps: 4}\n"
    << "domain: {min: [0, 0, 0], max: [1, 1, 1]}\n"
    << "fluid: {particle_spacing: 0.05}\n"
    << "cloth:\n"
    << "  - name: sheet\n"
    << cloth;
  return s.str();
}

const char* kHang =
    "    position: [0.5, 0.5, 0.5]\n"
    "    areal_density: 1\n"
    "    stretch_stiffness: 2000\n"
    "    bend_stiffness: 20\n"
    "    damping: 0.05\n"
    "    air_damping: 10\n"
    "    solver: explicit\n"
    "    anchors:\n"
    "      - {type: box, min: [0.41, 0.41, 0.49], max: [0.421, 0.59, 0.51]}\n"
    "      - {type: box, min: [0.579, 0.41, 0.49], max: [0.59, 0.59, 0.51]}\n";

}  // namespace

TEST_CASE("Cloth mesh: a square OBJ gives lumped masses summing to areal density x area, and its springs",
          "[cloth][mesh]") {
  // 9 x 9 vertices over 0.16 m (h = 0.02 m), areal density 1 kg/m^2. Lumped mass = a third of the
  // adjacent triangles' area: interior vertices touch 6 triangles (h^2), edge vertices 3 (h^2 / 2),
  // the corners on the split diagonal 2 (h^2 / 3), the other two 1 (h^2 / 6). Masses are floats:
  // 1e-6 relative.
  using namespace sph::testing;
  TempDir dir;
  const int n = 9;
  const double w = 0.16, h = w / (n - 1), rho = 1.0;
  dir.write("square.obj", squareObj(n, w));
  const auto scene = dir.write("scene.yaml", sceneText("    mesh: square.obj\n" + std::string(kHang), 0.1));
  const SceneSpec spec = io::loadScene(scene.string());
  REQUIRE(spec.cloth[0].isMesh());
  const Compiled comp = compile(spec);
  const cloth::ClothModel& m = comp.model.cloth;
  REQUIRE(m.nodes() == std::size_t(n * n));
  double sum = 0;
  for (float x : m.mass) sum += x;
  CHECK(sum == Approx(rho * w * w).epsilon(1e-6));
  auto mass = [&](int i, int j) { return double(m.mass[static_cast<std::size_t>(j * n + i)]); };
  CHECK(mass(4, 4) == Approx(rho * h * h).epsilon(1e-6));
  CHECK(mass(4, 0) == Approx(rho * h * h / 2).epsilon(1e-6));
  CHECK(mass(0, 4) == Approx(rho * h * h / 2).epsilon(1e-6));
  CHECK(mass(0, 0) == Approx(rho * h * h / 3).epsilon(1e-6));
  CHECK(mass(n - 1, n - 1) == Approx(rho * h * h / 3).epsilon(1e-6));
  CHECK(mass(n - 1, 0) == Approx(rho * h * h / 6).epsilon(1e-6));
  // Placed like the rectangle: vertex (i, j) where the rectangle's node (i, j) is.
  ClothSpec rect = spec.cloth[0];
  rect.mesh_data = TriMesh{};
  rect.width = rect.length = w;
  rect.resolution_x = rect.resolution_y = n;
  const auto xr = cloth::nodePositions(rect), xm = cloth::nodePositions(spec.cloth[0]);
  for (std::size_t k = 0; k < xr.size(); ++k) CHECK((xr[k] - xm[k]).norm() < 1e-7);  // OBJ vertices are floats
  // Springs: one stretch per edge (2 n (n - 1) grid edges + (n - 1)^2 diagonals), one bend per
  // interior edge (all but the 4 (n - 1) on the boundary).
  std::size_t stretch = 0, bend = 0, shear = 0;
  for (uint32_t k : m.kind) (k == cloth::kStretch ? stretch : k == cloth::kBend ? bend : shear)++;
  const std::size_t edges = 2 * n * (n - 1) + (n - 1) * (n - 1);
  CHECK(stretch == edges);
  CHECK(bend == edges - 4 * (n - 1));
  CHECK(shear == 0);
  // The two box anchors pin the x_min and x_max columns.
  std::size_t pinned = 0;
  for (const auto& x : m.x0) pinned += x.w() == 0.0f;
  CHECK(pinned == std::size_t(2 * n));
  // The exported mesh is the OBJ's triangles.
  CHECK(io::clothMesh(m, 0, spec.cloth[0], m.x0, {}).numTriangles() == std::size_t(2 * (n - 1) * (n - 1)));
}

TEST_CASE("Cloth mesh: hung from two box anchors it comes to rest with its weight on them, like the rectangle",
          "[cloth][mesh][physics]") {
  // The square mesh and the 9 x 9 rectangle of the same size and density, hung by their x_min and
  // x_max columns (explicit springs, so that the spring forces are exact k (L - L0)), settle under
  // air damping (10 1/s: about 10 e-foldings in 1 s). At rest the springs on the anchored nodes
  // carry the weight of the free nodes: within 2 % (the residual motion after 1 s).
  using namespace sph::testing;
  TempDir dir;
  const int n = 9;
  const double w = 0.16;
  dir.write("square.obj", squareObj(n, w));
  const std::string rect_keys = "    width: 0.16\n    length: 0.16\n    resolution_x: 9\n    resolution_y: 9\n";
  double sag[2] = {0, 0};
  int which = 0;
  for (const std::string& keys : {std::string("    mesh: square.obj\n"), rect_keys}) {
    const auto scene = dir.write("hang.yaml", sceneText(keys + kHang, 1.0));
    const Compiled comp = compile(io::loadScene(scene.string()));
    const cloth::ClothModel& m = comp.model.cloth;
    double free_mass = 0;
    for (std::size_t k = 0; k < m.nodes(); ++k)
      if (m.x0[k].w() > 0.0f) free_mass += m.mass[k];
    ClContext cl;
    Simulation sim(comp.model, comp.initial, cl);
    for (int f = 0; f < comp.model.num_frames; ++f) sim.advanceFrame();
    const cloth::ClothReport r = sim.cloth()->report(0, Eigen::Vector3d(0, 0, -kG));
    std::vector<Eigen::Vector4f> x, v;
    sim.cloth()->read(x, v);
    sag[which] = 0.5 - x[static_cast<std::size_t>(4 * n + 4)].z();
    INFO((which ? "rectangle" : "mesh") << ": anchor force " << r.anchor_force.transpose() << " N, weight of the free nodes "
                                        << free_mass * kG << " N, centre sag " << sag[which] << " m");
    CHECK(-r.anchor_force.z() == Approx(free_mass * kG).epsilon(0.02));
    CHECK(sag[which] > 0.0);
    ++which;
  }
  // Same size, density and stretch springs: the sags agree in order of magnitude; the mesh's
  // diagonals are stretch springs (2000 N/m) where the rectangle has shear springs (100 N/m by
  // default) and it lumps less mass on the anchored columns, so they are not equal.
  INFO("sag mesh " << sag[0] << " m, rectangle " << sag[1] << " m");
  CHECK(sag[0] > 0.3 * sag[1]);
  CHECK(sag[0] < 3.0 * sag[1]);
}

TEST_CASE("Cloth mesh: bad files and rectangle-only anchors are reported at their key, exit 2", "[cloth][mesh][input]") {
  using namespace sph::testing;
  TempDir dir;
  dir.write("square.obj", squareObj(3, 0.1));
  dir.write("points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
  // Three triangles on the edge (1, 2): non-manifold.
  dir.write("fin.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 1 1 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n");
  const std::string at = "    position: [0.5, 0.5, 0.5]\n";
  auto issues = issuesOf(dir, sceneText(at + "    mesh: missing.obj\n", 0.1));
  CHECK(hasIssue(issues, 7, {"mesh", "not found"}));
  issues = issuesOf(dir, sceneText(at + "    mesh: points.obj\n", 0.1));
  INFO(dump(issues));
  CHECK(hasIssue(issues, 7, {"points.obj"}));
  issues = issuesOf(dir, sceneText(at + "    mesh: fin.obj\n", 0.1));
  INFO(dump(issues));
  CHECK(hasIssue(issues, 7, {"non-manifold"}));
  // Corners on a mesh cloth; a vertex index past the last: at the anchor, when compiled.
  const auto scene = dir.write("corners.yaml", sceneText(at + "    mesh: square.obj\n    anchors:\n      - {type: corners}\n"
                                                              "      - {type: node, i: 9}\n", 0.1));
  try {
    (void)compile(io::loadScene(scene.string()));
    FAIL("corners on a mesh cloth compiled");
  } catch (const InputError& e) {
    INFO(dump(e.issues()));
    CHECK(hasIssue(e.issues(), 9, {"corners and edge are for the rectangle"}));
    CHECK(hasIssue(e.issues(), 10, {"vertex 9"}));
  }
  const Result r = sphaptics(dir.path, {"validate", dir.write("fin.yaml", sceneText(at + "    mesh: fin.obj\n", 0.1)).string()});
  CHECK(r.code == 2);
  CHECK(r.err.find("fin.yaml:7:") != std::string::npos);
}

TEST_CASE("Cloth mesh: rectangle keys given with a mesh are named in a warning, and validate prints it", "[cloth][mesh][input]") {
  // width (line 7) and resolution_x (line 8) mean nothing for a mesh cloth: one warning each, with
  // its location; the scene still loads and compiles (exit 0).
  using namespace sph::testing;
  TempDir dir;
  dir.write("square.obj", squareObj(9, 0.16));  // as above: the anchors of kHang hold it
  const auto scene = dir.write("scene.yaml", sceneText("    width: 0.3\n    resolution_x: 7\n    mesh: square.obj\n" +
                                                           std::string(kHang), 0.1));
  const Compiled comp = compile(io::loadScene(scene.string()));
  INFO(comp.model.warnings.size());
  REQUIRE(comp.model.warnings.size() == 2u);
  CHECK(comp.model.warnings[0].find("scene.yaml:6:") != std::string::npos);
  CHECK(comp.model.warnings[0].find("'cloth[0].width' is not used") != std::string::npos);
  CHECK(comp.model.warnings[1].find("scene.yaml:7:") != std::string::npos);
  CHECK(comp.model.warnings[1].find("'cloth[0].resolution_x'") != std::string::npos);
  const Result r = sphaptics(dir.path, {"validate", scene.string()});
  CHECK(r.code == 0);
  CHECK(r.err.find("warning: ") != std::string::npos);
  // Without the rectangle keys: no warning.
  const auto clean = dir.write("clean.yaml", sceneText("    mesh: square.obj\n" + std::string(kHang), 0.1));
  CHECK(compile(io::loadScene(clean.string())).model.warnings.empty());
}
