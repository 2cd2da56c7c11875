// Mesh geometry (volume, area, edge topology, welding) and OBJ round trips.
#include "core/errors.h"
#include "core/mesh.h"
#include "io/obj_io.h"
#include "temp_dir.h"

#include <catch2/catch.hpp>

#include <fstream>

using namespace sph;
using sph::testing::TempDir;

namespace {
// Unit cube [0,1]^3 with outward-facing triangles, 8 shared vertices.
TriMesh unitCube() {
  TriMesh m;
  for (int i = 0; i < 8; ++i) m.positions.emplace_back(float(i & 1), float((i >> 1) & 1), float((i >> 2) & 1));
  const uint32_t q[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : q) {
    m.triangles.push_back({f[0], f[1], f[2]});
    m.triangles.push_back({f[0], f[2], f[3]});
  }
  return m;
}
}  // namespace

TEST_CASE("Unit cube: volume 1, area 6, closed", "[mesh]") {
  TriMesh m = unitCube();
  CHECK(meshVolume(m) == Approx(1.0).epsilon(1e-12));
  CHECK(meshArea(m) == Approx(6.0).epsilon(1e-12));
  const EdgeReport r = checkEdges(m);
  CHECK(r.edges == 18);
  CHECK(r.closed());
  m.triangles.pop_back();
  CHECK(checkEdges(m).boundary == 3);
  CHECK_FALSE(checkEdges(m).closed());
  m = unitCube();
  std::swap(m.triangles[0][1], m.triangles[0][2]);
  CHECK(checkEdges(m).misoriented > 0);
}

TEST_CASE("Welding an unshared cube gives the shared cube", "[mesh]") {
  const TriMesh shared = unitCube();
  TriMesh soup;
  for (const auto& t : shared.triangles) {
    const uint32_t base = static_cast<uint32_t>(soup.positions.size());
    for (int k = 0; k < 3; ++k) soup.positions.push_back(shared.positions[t[k]] + Eigen::Vector3f::Constant(1e-7f));
    soup.triangles.push_back({base, base + 1, base + 2});
  }
  CHECK_FALSE(checkEdges(soup).closed());
  weldVertices(soup, 1e-5f);
  CHECK(soup.numVertices() == 8);
  CHECK(checkEdges(soup).closed());
  CHECK(meshVolume(soup) == Approx(1.0).epsilon(1e-5));
}

TEST_CASE("OBJ written and read back keeps counts, positions and normals", "[mesh][obj]") {
  TempDir dir;
  TriMesh m = unitCube();
  for (const auto& p : m.positions) m.normals.push_back((p - Eigen::Vector3f::Constant(0.5f)).normalized());
  const std::string path = (dir.path / "cube.obj").string();
  io::writeObj(path, m, "unit cube\nsecond line");
  const TriMesh r = io::readObj(path);
  REQUIRE(r.numVertices() == 8);
  REQUIRE(r.numTriangles() == 12);
  REQUIRE(r.normals.size() == 8);
  for (std::size_t i = 0; i < 8; ++i) {
    CHECK((r.positions[i] - m.positions[i]).norm() < 1e-6f);
    CHECK((r.normals[i] - m.normals[i]).norm() < 1e-4f);
  }
  CHECK(io::objText(m, "unit cube\nsecond line") == io::objText(m, "unit cube\nsecond line"));
}

TEST_CASE("Unreadable OBJ files are bad input naming the file", "[mesh][obj]") {
  TempDir dir;
  CHECK_THROWS_AS(io::readObj((dir.path / "missing.obj").string()), InputError);
  const std::string empty = (dir.path / "empty.obj").string();
  std::ofstream(empty) << "# nothing\nv 0 0 0\n";
  try {
    io::readObj(empty);
    FAIL("no error");
  } catch (const InputError& e) {
    CHECK(std::string(e.what()).find("empty.obj") != std::string::npos);
  }
}
