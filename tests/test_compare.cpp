// Mesh distances and `sphaptics compare`: closest points and Hausdorff distances against closed
// forms, and the command's verdicts and exit codes on OBJ sequences.
#include "cli/compare.h"
#include "core/mesh.h"
#include "core/mesh_distance.h"
#include "io/obj_io.h"
#include "tests/run_binary.h"
#include "tests/temp_dir.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <random>
#include <sstream>

using namespace sph;
using sph::testing::TempDir;
namespace fs = std::filesystem;

namespace {

// UV sphere: `rings` latitude bands, `segments` longitudes, outward triangles, closed.
TriMesh uvSphere(const Eigen::Vector3f& c, float r, int rings, int segments) {
  TriMesh m;
  m.positions.push_back(c + Eigen::Vector3f(0, 0, -r));
  for (int i = 1; i < rings; ++i) {
    const double th = M_PI * i / rings - M_PI / 2;
    for (int j = 0; j < segments; ++j) {
      const double ph = 2 * M_PI * j / segments;
      m.positions.push_back(c + r * Eigen::Vector3f(float(std::cos(th) * std::cos(ph)), float(std::cos(th) * std::sin(ph)),
                                                    float(std::sin(th))));
    }
  }
  m.positions.push_back(c + Eigen::Vector3f(0, 0, r));
  const uint32_t top = static_cast<uint32_t>(m.positions.size() - 1);
  auto ring = [&](int i, int j) { return static_cast<uint32_t>(1 + (i - 1) * segments + (j % segments)); };
  for (int j = 0; j < segments; ++j) m.triangles.push_back({0, ring(1, j + 1), ring(1, j)});
  for (int i = 1; i < rings - 1; ++i)
    for (int j = 0; j < segments; ++j) {
      m.triangles.push_back({ring(i, j), ring(i, j + 1), ring(i + 1, j + 1)});
      m.triangles.push_back({ring(i, j), ring(i + 1, j + 1), ring(i + 1, j)});
    }
  for (int j = 0; j < segments; ++j) m.triangles.push_back({top, ring(rings - 1, j), ring(rings - 1, j + 1)});
  return m;
}

// Axis-aligned box [lo, hi], outward triangles.
TriMesh box(const Eigen::Vector3f& lo, const Eigen::Vector3f& hi) {
  TriMesh m;
  for (int i = 0; i < 8; ++i)
    m.positions.emplace_back(i & 1 ? hi.x() : lo.x(), i & 2 ? hi.y() : lo.y(), i & 4 ? hi.z() : lo.z());
  const uint32_t q[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : q) {
    m.triangles.push_back({f[0], f[1], f[2]});
    m.triangles.push_back({f[0], f[2], f[3]});
  }
  return m;
}

int compare(const std::string& a, const std::string& b, std::string* text = nullptr, double hausdorff = 1.0) {
  app::CompareOptions o;
  o.a = a;
  o.b = b;
  o.hausdorff = hausdorff;
  std::ostringstream out, err;
  const int code = app::compareCommand(o, out, err);
  if (text) *text = out.str() + err.str();
  return code;
}

}  // namespace

TEST_CASE("Closest point on a triangle matches a dense brute-force search", "[compare]") {
  const Eigen::Vector3d a(0, 0, 0), b(1, 0, 0), c(0.2, 0.9, 0.1);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 2.0);
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::Vector3d p(u(rng), u(rng), u(rng));
    const double d = (closestPointOnTriangle(p, a, b, c) - p).norm();
    double brute = 1e30;
    const int n = 200;
    for (int i = 0; i <= n; ++i)
      for (int j = 0; i + j <= n; ++j) {
        const Eigen::Vector3d q = a + (b - a) * (double(i) / n) + (c - a) * (double(j) / n);
        brute = std::min(brute, (q - p).norm());
      }
    // The brute-force lattice is within one lattice diagonal (< 1.5/200) of the true closest point.
    CHECK(d <= brute + 1e-12);
    CHECK(d >= brute - 1.5 / n);
  }
}

TEST_CASE("Surface index distance equals brute force over all triangles", "[compare]") {
  const TriMesh s = uvSphere(Eigen::Vector3f(0.1f, 0.2f, 0.3f), 0.5f, 24, 48);
  const SurfaceIndex index(s);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.5, 1.5);
  for (int trial = 0; trial < 300; ++trial) {
    const Eigen::Vector3d p(u(rng), u(rng), u(rng));
    double brute = 1e30;
    for (const auto& t : s.triangles)
      brute = std::min(brute, (closestPointOnTriangle(p, s.positions[t[0]].cast<double>(), s.positions[t[1]].cast<double>(),
                                                      s.positions[t[2]].cast<double>()) - p).norm());
    CHECK(index.distance(p) == Approx(brute).margin(1e-12));
  }
}

TEST_CASE("Hausdorff distance of shifted boxes and concentric spheres", "[compare]") {
  // A unit box and the same box moved 0.1 along x: every point of one is within 0.1 of the other,
  // and the corner (0,0,0) is exactly 0.1 from the moved box.
  const TriMesh a = box({0, 0, 0}, {1, 1, 1}), b = box({0.1f, 0, 0}, {1.1f, 1, 1});
  CHECK(hausdorff(a, b) == Approx(0.1).margin(1e-6));
  CHECK(hausdorff(a, a) == Approx(0.0).margin(1e-12));
  // Spheres of radius 1 and 1.2: 0.2 apart, less the chord sag of the tessellation
  // (r (1 - cos(pi / segments)) < 2e-3 at 64 segments) in one direction.
  const TriMesh s1 = uvSphere({0, 0, 0}, 1.0f, 32, 64), s2 = uvSphere({0, 0, 0}, 1.2f, 32, 64);
  CHECK(hausdorff(s1, s2) == Approx(0.2).margin(3e-3));
  // Empty meshes: nothing to measure from, infinitely far to measure to.
  CHECK(hausdorffOneSided(TriMesh{}, s1) == 0.0);
  CHECK(std::isinf(hausdorffOneSided(s1, TriMesh{})));
}

TEST_CASE("compare accepts a sequence against itself and rejects a moved vertex", "[compare]") {
  TempDir dir;
  const double dx = 0.02;
  const fs::path ref = dir.path / "ref", moved = dir.path / "moved";
  fs::create_directories(ref);
  fs::create_directories(moved);
  for (int f = 0; f < 3; ++f) {
    TriMesh m = uvSphere(Eigen::Vector3f(0.05f * f, 0, 0), 0.2f, 16, 32);
    char name[64];
    std::snprintf(name, sizeof name, "fluid_water_%04d.obj", f);
    io::writeObj((ref / name).string(), m, "particle_spacing: 0.02 m");
    if (f == 2) m.positions[40].z() += static_cast<float>(1.5 * dx);  // beyond the 1 dx default
    io::writeObj((moved / name).string(), m, "particle_spacing: 0.02 m");
  }
  std::string text;
  CHECK(compare(ref.string(), ref.string(), &text) == 0);
  CHECK(text.find("PASS") != std::string::npos);
  CHECK(compare(ref.string(), moved.string(), &text) == 1);
  CHECK(text.find("fluid_water_0002.obj") != std::string::npos);
  CHECK(text.find("FAIL") != std::string::npos);
  // A looser tolerance (2 dx) accepts the same move.
  CHECK(compare(ref.string(), moved.string(), &text, 2.0) == 0);
  // Single files are compared as one frame whatever their names.
  CHECK(compare((ref / "fluid_water_0000.obj").string(), (moved / "fluid_water_0000.obj").string()) == 0);
  // A frame missing from one side fails.
  fs::remove(moved / "fluid_water_0001.obj");
  CHECK(compare(ref.string(), moved.string(), &text) == 1);
  CHECK(text.find("only in") != std::string::npos);
}

TEST_CASE("compare exits 2 on missing or malformed input, through the executable", "[compare][cli]") {
  TempDir dir;
  io::writeObj((dir.path / "a.obj").string(), box({0, 0, 0}, {1, 1, 1}), "particle_spacing: 0.1 m");
  {
    std::ofstream bad(dir.path / "bad.obj");
    bad << "# particle_spacing: 0.1 m\nv 0 0 0\nv 1 0 0\nthis is not obj\nf 1 2 3\n";
  }
  auto r = sph::testing::sphaptics(dir.path, {"compare", "a.obj", "a.obj"});
  CHECK(r.code == 0);
  r = sph::testing::sphaptics(dir.path, {"compare", "a.obj", "missing.obj"});
  CHECK(r.code == 2);
  CHECK(r.err.find("missing.obj") != std::string::npos);
  r = sph::testing::sphaptics(dir.path, {"compare", "a.obj", "bad.obj"});
  CHECK(r.code == 2);
  CHECK(r.err.find("bad.obj:4:1") != std::string::npos);
  // No spacing in the header and none given: the unit of the tolerances is unknown.
  io::writeObj((dir.path / "plain.obj").string(), box({0, 0, 0}, {1, 1, 1}));
  r = sph::testing::sphaptics(dir.path, {"compare", "plain.obj", "plain.obj"});
  CHECK(r.code == 2);
  r = sph::testing::sphaptics(dir.path, {"compare", "plain.obj", "plain.obj", "--spacing", "0.1"});
  CHECK(r.code == 0);
}
