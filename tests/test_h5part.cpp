// H5PartWriter: the file read back through the HDF5 C API has the layout ParaView's H5PartReader
// needs (shared/clients.md): consecutive Step#0..Step#K-1, a scalar native double TimeValue, and
// equal-length datasets with the values that were written (float32, int32 phase, int64 id).
#include "io/h5part_writer.h"
#include "temp_dir.h"

#include <catch2/catch.hpp>
// sphaptics_io keeps HDF5's include folder private; Debian installs the serial headers under
// hdf5/serial/, which the quoted includes inside hdf5.h then find on their own.
#if __has_include(<hdf5.h>)
#include <hdf5.h>
#else
#include <hdf5/serial/hdf5.h>
#endif

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

namespace fs = std::filesystem;
using sph::ParticleFrame;
using sph::io::H5PartWriter;

namespace {

fs::path tempFile(const std::string& name) {
  const auto tick = std::chrono::steady_clock::now().time_since_epoch().count();
  return fs::temp_directory_path() / ("sphaptics_" + std::to_string(tick) + "_" + name);
}

/// n particles whose fields are distinct functions of the index and the step.
ParticleFrame makeFrame(std::size_t n, double time, int step) {
  ParticleFrame f;
  f.time = time;
  for (std::size_t i = 0; i < n; ++i) {
    const float k = static_cast<float>(i) + 0.25f * static_cast<float>(step);
    f.x.push_back(k);
    f.y.push_back(2 * k);
    f.z.push_back(-k);
    f.vx.push_back(0.5f * k);
    f.vy.push_back(1.5f);
    f.vz.push_back(-9.81f * k);
    f.density.push_back(1000.0f + k);
    f.pressure.push_back(10.0f * k);
    f.phase.push_back(static_cast<int32_t>(i % 3));
    f.id.push_back(static_cast<int64_t>(i) + (int64_t{1} << 40));  // needs 64 bits
    f.r.push_back(0.1f);
    f.g.push_back(0.2f * static_cast<float>(i % 5));
    f.b.push_back(1.0f);
  }
  return f;
}

/// Reads a whole 1-D dataset; checks its file type is `expected_type` (H5Tequal).
template <class T>
std::vector<T> readColumn(hid_t group, const char* name, hid_t memory_type, hid_t expected_type) {
  INFO(name);
  const hid_t dataset = H5Dopen2(group, name, H5P_DEFAULT);
  REQUIRE(dataset >= 0);
  const hid_t type = H5Dget_type(dataset);
  CHECK(H5Tequal(type, expected_type) > 0);
  H5Tclose(type);
  const hid_t space = H5Dget_space(dataset);
  REQUIRE(H5Sget_simple_extent_ndims(space) == 1);
  hsize_t n = 0;
  H5Sget_simple_extent_dims(space, &n, nullptr);
  H5Sclose(space);
  std::vector<T> values(static_cast<std::size_t>(n));
  if (n > 0) CHECK(H5Dread(dataset, memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) >= 0);
  H5Dclose(dataset);
  return values;
}

}  // namespace

TEST_CASE("H5Part file reads back with consecutive steps, TimeValue and the written data", "[io]") {
  const fs::path path = tempFile("particles.h5part");
  const std::vector<std::size_t> sizes = {5, 0, 3};  // an empty step in the middle
  const std::vector<double> times = {0.0, 0.5, 1.0 / 3.0};
  std::vector<ParticleFrame> frames;
  {
    H5PartWriter writer(path.string());
    for (std::size_t s = 0; s < sizes.size(); ++s) {
      frames.push_back(makeFrame(sizes[s], times[s], static_cast<int>(s)));
      writer.writeStep(frames.back());
      CHECK(writer.stepsWritten() == static_cast<int>(s) + 1);
    }
    writer.close();
    writer.close();  // closing twice is harmless
  }

  const hid_t file = H5Fopen(path.string().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);

  // Exactly Step#0..Step#K-1 at the root.
  H5G_info_t root{};
  REQUIRE(H5Gget_info(file, &root) >= 0);
  CHECK(root.nlinks == sizes.size());

  for (std::size_t s = 0; s < sizes.size(); ++s) {
    const std::string name = "Step#" + std::to_string(s);
    INFO(name);
    REQUIRE(H5Lexists(file, name.c_str(), H5P_DEFAULT) > 0);
    const hid_t group = H5Gopen2(file, name.c_str(), H5P_DEFAULT);
    REQUIRE(group >= 0);

    // TimeValue: scalar, native double, the frame's time.
    const hid_t attr = H5Aopen(group, "TimeValue", H5P_DEFAULT);
    REQUIRE(attr >= 0);
    const hid_t atype = H5Aget_type(attr);
    CHECK(H5Tequal(atype, H5T_NATIVE_DOUBLE) > 0);
    H5Tclose(atype);
    const hid_t aspace = H5Aget_space(attr);
    CHECK(H5Sget_simple_extent_type(aspace) == H5S_SCALAR);
    H5Sclose(aspace);
    double time = -1;
    CHECK(H5Aread(attr, H5T_NATIVE_DOUBLE, &time) >= 0);
    CHECK(time == times[s]);  // bitwise: double all the way
    H5Aclose(attr);

    // The 14 datasets, all of length n, with the written values (type: all fluid when not given).
    H5G_info_t info{};
    H5Gget_info(group, &info);
    CHECK(info.nlinks == 14);
    const ParticleFrame& f = frames[s];
    const hid_t f32 = H5T_IEEE_F32LE;
    CHECK(readColumn<float>(group, "x", H5T_NATIVE_FLOAT, f32) == f.x);
    CHECK(readColumn<float>(group, "y", H5T_NATIVE_FLOAT, f32) == f.y);
    CHECK(readColumn<float>(group, "z", H5T_NATIVE_FLOAT, f32) == f.z);
    CHECK(readColumn<float>(group, "velocity_0", H5T_NATIVE_FLOAT, f32) == f.vx);
    CHECK(readColumn<float>(group, "velocity_1", H5T_NATIVE_FLOAT, f32) == f.vy);
    CHECK(readColumn<float>(group, "velocity_2", H5T_NATIVE_FLOAT, f32) == f.vz);
    CHECK(readColumn<float>(group, "density", H5T_NATIVE_FLOAT, f32) == f.density);
    CHECK(readColumn<float>(group, "pressure", H5T_NATIVE_FLOAT, f32) == f.pressure);
    CHECK(readColumn<float>(group, "colour_0", H5T_NATIVE_FLOAT, f32) == f.r);
    CHECK(readColumn<float>(group, "colour_1", H5T_NATIVE_FLOAT, f32) == f.g);
    CHECK(readColumn<float>(group, "colour_2", H5T_NATIVE_FLOAT, f32) == f.b);
    CHECK(readColumn<int32_t>(group, "phase", H5T_NATIVE_INT32, H5T_STD_I32LE) == f.phase);
    CHECK(readColumn<int64_t>(group, "id", H5T_NATIVE_INT64, H5T_STD_I64LE) == f.id);
    CHECK(readColumn<int32_t>(group, "type", H5T_NATIVE_INT32, H5T_STD_I32LE) == std::vector<int32_t>(f.size(), sph::kFluid));
    H5Gclose(group);
  }
  H5Fclose(file);
  fs::remove(path);
}

TEST_CASE("H5PartWriter closes in its destructor and rejects bad input", "[io]") {
  const fs::path path = tempFile("dtor.h5part");
  {
    H5PartWriter writer(path.string());
    writer.writeStep(makeFrame(2, 0.1, 0));

    // Fields of different lengths: an error naming the file and the step; no step is added.
    ParticleFrame bad = makeFrame(4, 0.2, 1);
    bad.id.pop_back();
    try {
      writer.writeStep(bad);
      FAIL("expected std::runtime_error");
    } catch (const std::runtime_error& e) {
      const std::string what = e.what();
      CHECK(what.find(path.string()) != std::string::npos);
      CHECK(what.find("Step#1") != std::string::npos);
    }
    CHECK(writer.stepsWritten() == 1);
    writer.writeStep(makeFrame(1, 0.3, 1));  // still Step#1: steps stay consecutive
  }
  const hid_t file = H5Fopen(path.string().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  H5G_info_t root{};
  H5Gget_info(file, &root);
  CHECK(root.nlinks == 2);
  CHECK(H5Lexists(file, "Step#1", H5P_DEFAULT) > 0);
  H5Fclose(file);
  fs::remove(path);

  // A file that cannot be created: std::runtime_error naming the path.
  const std::string missing = (fs::temp_directory_path() / "sphaptics_no_such_dir" / "p.h5part").string();
  try {
    H5PartWriter writer(missing);
    FAIL("expected std::runtime_error");
  } catch (const std::runtime_error& e) {
    CHECK(std::string(e.what()).find(missing) != std::string::npos);
  }

  // Writing after close is an error too.
  const fs::path closed = tempFile("closed.h5part");
  H5PartWriter writer(closed.string());
  writer.close();
  CHECK_THROWS_AS(writer.writeStep(makeFrame(1, 0, 0)), std::runtime_error);
  fs::remove(closed);
}

TEST_CASE("H5PartWriter: the same frames give the same bytes whenever they are written", "[io]") {
  // HDF5 stamps each group and dataset header with its creation and modification times (1 s
  // resolution) unless told not to: two runs of one scene then differed in 154 bytes of
  // particles.h5part (session 26). Written 1.1 s apart, the files must be equal byte for byte.
  const fs::path a = tempFile("repro_a.h5part"), b = tempFile("repro_b.h5part");
  auto write = [](const fs::path& path) {
    H5PartWriter w(path.string());
    w.writeStep(makeFrame(10, 0.0, 0));
    w.writeStep(makeFrame(10, 0.1, 1));
    w.close();
  };
  write(a);
  std::this_thread::sleep_for(std::chrono::milliseconds(1100));
  write(b);
  const std::string da = sph::testing::fileBytes(a), db = sph::testing::fileBytes(b);
  CHECK(da.size() > 1000);
  REQUIRE(da.size() == db.size());
  std::size_t differ = 0;
  for (std::size_t i = 0; i < da.size(); ++i) differ += da[i] != db[i] ? 1 : 0;
  CHECK(differ == 0);
  fs::remove(a);
  fs::remove(b);
}
