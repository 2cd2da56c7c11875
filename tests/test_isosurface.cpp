// Isosurface stage: the marching-cubes table, the device marching cubes on analytic fields
// (watertight, manifold, converging to the exact volume and area), a block of particles at rest,
// and the OBJ sequence a run writes.
#include "core/cl_context.h"
#include "core/isosurface.h"
#include "core/marching_cubes_table.h"
#include "core/mesh.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <random>

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
