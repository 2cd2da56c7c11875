// OpenVDB export: grids, classes and the world transform read back through OpenVDB.
#include "io/vdb_writer.h"
#include "temp_dir.h"

#include <catch2/catch.hpp>

#include <cctype>
#include <cmath>

using namespace sph;
using sph::testing::fileBytes;
using sph::testing::TempDir;

namespace {
// A smooth blob: 1 inside radius r0, falling linearly to 0 at r1 (the shape of an SPH density field).
DenseGrid blob(const Eigen::Vector3d& origin, double spacing, int n, const Eigen::Vector3d& centre, double r0, double r1) {
  DenseGrid g;
  g.origin = origin;
  g.spacing = spacing;
  g.dims = {n, n + 2, n + 4};  // unequal so a transposed layout would show
  g.values.resize(static_cast<std::size_t>(g.dims[0]) * g.dims[1] * g.dims[2]);
  for (int k = 0; k < g.dims[2]; ++k)
    for (int j = 0; j < g.dims[1]; ++j)
      for (int i = 0; i < g.dims[0]; ++i) {
        const double r = (g.position(i, j, k) - centre).norm();
        g.values[g.index(i, j, k)] = static_cast<float>(std::clamp((r1 - r) / (r1 - r0), 0.0, 1.0));
      }
  return g;
}
}  // namespace

TEST_CASE("VDB density grid reads back with its name, class and world transform", "[vdb]") {
  TempDir dir;
  const Eigen::Vector3d origin(0.25, -0.5, 1.0), centre(0.6, -0.1, 1.45);
  const double spacing = 0.02;
  const DenseGrid g = blob(origin, spacing, 40, centre, 0.1, 0.2);
  const std::string path = (dir.path / "fluid_0000.vdb").string();
  io::writeVdb(path, {{"density", &g}});

  const auto info = io::readVdbInfo(path);
  REQUIRE(info.size() == 1);
  CHECK(info[0].name == "density");
  CHECK(info[0].grid_class == "Fog Volume");
  CHECK(info[0].value_type == "float");
  CHECK(info[0].voxel_size == Approx(spacing).epsilon(1e-12));
  CHECK((info[0].index_origin_world - origin).norm() < 1e-12);
  CHECK(info[0].max_active == Approx(1.0f));
  // Every sample above zero is active; the ball of radius 0.2 holds about 4/3 pi 0.2^3 / 0.02^3 voxels.
  std::size_t nonzero = 0;
  for (float v : g.values) nonzero += v > 0.f;
  CHECK(info[0].active_voxels == nonzero);

  // Values at world points: the centre is inside (1), a point on the r = 0.15 shell is 0.5, far away 0.
  CHECK(io::sampleVdb(path, "density", centre) == Approx(1.0f).margin(1e-6));
  CHECK(io::sampleVdb(path, "density", centre + Eigen::Vector3d(0.15, 0, 0)) == Approx(0.5f).margin(0.02));
  CHECK(io::sampleVdb(path, "density", origin) == Approx(0.0f).margin(1e-6));
  CHECK_FALSE(std::filesystem::exists(path + ".tmp"));
}

TEST_CASE("VDB level set 'surface' is a signed distance to the iso surface", "[vdb]") {
  TempDir dir;
  const Eigen::Vector3d origin(0, 0, 0), centre(0.4, 0.42, 0.44);
  const double spacing = 0.02;
  const DenseGrid g = blob(origin, spacing, 40, centre, 0.1, 0.2);
  const DenseGrid heavy = blob(origin, spacing, 40, centre, 0.05, 0.1);
  const std::string path = (dir.path / "f.vdb").string();
  io::VdbOptions opt;
  opt.level_set = true;
  opt.iso = 0.5f;  // the r = 0.15 sphere
  io::writeVdb(path, {{"density", &g}, {"density_heavy", &heavy}}, opt);
  const auto info = io::readVdbInfo(path);
  REQUIRE(info.size() == 3);
  CHECK(info[1].name == "density_heavy");
  CHECK(info[2].name == "surface");
  CHECK(info[2].grid_class == "Level Set");
  // The linear ramp is exact under trilinear interpolation, so the distance is exact up to the
  // rebuild's own error (a fraction of a voxel): allow half a voxel.
  for (double r : {0.11, 0.15, 0.18}) {
    const float d = io::sampleVdb(path, "surface", centre + Eigen::Vector3d(0, r, 0));
    CHECK(d == Approx(r - 0.15).margin(0.5 * spacing));
  }
}

TEST_CASE("VDB writer reports unwritable paths and bad grids", "[vdb]") {
  TempDir dir;
  const DenseGrid g = blob(Eigen::Vector3d::Zero(), 0.1, 4, Eigen::Vector3d::Zero(), 0.1, 0.2);
  CHECK_THROWS_WITH(io::writeVdb((dir.path / "no" / "such" / "dir.vdb").string(), {{"density", &g}}),
                    Catch::Contains("dir.vdb"));
  DenseGrid bad = g;
  bad.values.pop_back();
  CHECK_THROWS(io::writeVdb((dir.path / "bad.vdb").string(), {{"density", &bad}}));
  CHECK_THROWS_WITH(io::readVdbInfo((dir.path / "missing.vdb").string()), Catch::Contains("missing.vdb"));
}

TEST_CASE("VDB files of the same grids are the same bytes, and their UUID tells different grids apart", "[vdb]") {
  // OpenVDB writes a random UUID into every file's header (io::Archive), so two runs of one scene
  // gave .vdb files that differed in 36 bytes and could not be compared byte for byte; the writer
  // replaces it with one derived from the rest of the file (io/vdb_writer.cpp). Mutation: with the
  // replacement off, `a` and `b` differ (checked).
  TempDir dir;
  const DenseGrid g = blob(Eigen::Vector3d::Zero(), 0.02, 20, Eigen::Vector3d(0.2, 0.2, 0.2), 0.05, 0.1);
  const DenseGrid other = blob(Eigen::Vector3d::Zero(), 0.02, 20, Eigen::Vector3d(0.2, 0.2, 0.2), 0.06, 0.1);
  io::VdbOptions opt;
  opt.level_set = true;
  const std::string a = (dir.path / "a.vdb").string(), b = (dir.path / "b.vdb").string(),
                    c = (dir.path / "c.vdb").string();
  io::writeVdb(a, {{"density", &g}}, opt);
  io::writeVdb(b, {{"density", &g}}, opt);
  io::writeVdb(c, {{"density", &other}}, opt);
  const std::string ba = fileBytes(a), bb = fileBytes(b), bc = fileBytes(c);
  REQUIRE(ba.size() > 100);
  std::size_t first_difference = std::string::npos;  // (the bytes themselves are binary: not printed)
  for (std::size_t i = 0; i < std::max(ba.size(), bb.size()); ++i)
    if (i >= ba.size() || i >= bb.size() || ba[i] != bb[i]) {
      first_difference = i;
      break;
    }
  INFO("sizes " << ba.size() << " and " << bb.size() << ", first differing byte " << first_difference);
  CHECK(first_difference == std::string::npos);
  // The UUID sits after the magic number and the three version numbers and one flag (21 bytes):
  // 36 characters in the 8-4-4-4-12 form; the one of different grids differs.
  REQUIRE(bc.size() > 57);
  const std::string ua = ba.substr(21, 36), uc = bc.substr(21, 36);
  INFO("UUIDs " << ua << " and " << uc);
  CHECK(ua != uc);
  for (const std::string& u : {ua, uc})
    for (std::size_t i = 0; i < u.size(); ++i) {
      if (i == 8 || i == 13 || i == 18 || i == 23) CHECK(u[i] == '-');
      else CHECK(std::isxdigit(static_cast<unsigned char>(u[i])));
    }
  // still a file OpenVDB reads, with its grids
  const auto info = io::readVdbInfo(a);
  REQUIRE(info.size() == 2);
  CHECK(info[0].name == "density");
  CHECK(info[1].name == "surface");
}
