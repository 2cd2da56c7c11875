// H5Part particle input through the HDF5 C API (layout in io/h5part_writer.h).
#include "io/h5part_reader.h"

#include "io/hdf5_quiet.h"

#include <hdf5.h>

#include <stdexcept>
#include <string>
#include <vector>

namespace sph::io {

namespace {

/// An HDF5 handle closed at scope exit.
class Handle {
 public:
  Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  ~Handle() {
    if (id_ >= 0) close_(id_);
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  hid_t get() const { return id_; }
  bool ok() const { return id_ >= 0; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

std::string stepName(int k) { return "Step#" + std::to_string(k); }

}  // namespace

H5PartReader::H5PartReader(const std::string& path) : path_(path) {
  QuietHdf5 quiet;
  // No file lock: the run that writes the file may still hold it open (HDF5 >= 1.10.7).
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  if (!fapl.ok()) throw std::runtime_error(path + ": cannot create HDF5 file-access properties");
  H5Pset_file_locking(fapl.get(), false, true);
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, fapl.get());
  if (file < 0) throw std::runtime_error(path + ": cannot open the H5Part file");
  file_ = file;
  // Count the consecutive steps, as the writer numbers them.
  while (H5Lexists(file, stepName(steps_).c_str(), H5P_DEFAULT) > 0) ++steps_;
}

H5PartReader::~H5PartReader() {
  if (file_ >= 0) H5Fclose(static_cast<hid_t>(file_));
}

double H5PartReader::stepTime(int k) const {
  QuietHdf5 quiet;
  const std::string name = stepName(k);
  Handle group(H5Gopen2(static_cast<hid_t>(file_), name.c_str(), H5P_DEFAULT), H5Gclose);
  if (!group.ok()) throw std::runtime_error(path_ + ": " + name + ": no such step");
  Handle attr(H5Aopen(group.get(), "TimeValue", H5P_DEFAULT), H5Aclose);
  double t = 0;
  if (!attr.ok() || H5Aread(attr.get(), H5T_NATIVE_DOUBLE, &t) < 0)
    throw std::runtime_error(path_ + ": " + name + ": cannot read TimeValue");
  return t;
}

ParticleFrame H5PartReader::readStep(int k, bool fluid_only) const {
  QuietHdf5 quiet;
  const std::string name = stepName(k);
  auto fail = [&](const std::string& what) { throw std::runtime_error(path_ + ": " + name + ": " + what); };
  if (k < 0 || k >= steps_) fail("no such step (the file has " + std::to_string(steps_) + ")");
  Handle group(H5Gopen2(static_cast<hid_t>(file_), name.c_str(), H5P_DEFAULT), H5Gclose);
  if (!group.ok()) fail("cannot open the group");

  ParticleFrame f;
  f.time = stepTime(k);
  // The length of "x" sets the particle count; every other field must match it.
  long long n = -1;
  auto column = [&](const char* field, hid_t memory_type, auto& out) {
    Handle dataset(H5Dopen2(group.get(), field, H5P_DEFAULT), H5Dclose);
    if (!dataset.ok()) fail(std::string("missing dataset '") + field + "'");
    Handle space(H5Dget_space(dataset.get()), H5Sclose);
    const long long len = space.ok() ? static_cast<long long>(H5Sget_simple_extent_npoints(space.get())) : -1;
    if (len < 0) fail(std::string("cannot read the length of '") + field + "'");
    if (n < 0) n = len;
    if (len != n) fail(std::string("dataset '") + field + "' has " + std::to_string(len) + " entries, 'x' has " + std::to_string(n));
    out.resize(static_cast<std::size_t>(len));
    if (len > 0 && H5Dread(dataset.get(), memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) < 0)
      fail(std::string("cannot read dataset '") + field + "'");
  };
  column("x", H5T_NATIVE_FLOAT, f.x);
  column("y", H5T_NATIVE_FLOAT, f.y);
  column("z", H5T_NATIVE_FLOAT, f.z);
  column("velocity_0", H5T_NATIVE_FLOAT, f.vx);
  column("velocity_1", H5T_NATIVE_FLOAT, f.vy);
  column("velocity_2", H5T_NATIVE_FLOAT, f.vz);
  column("density", H5T_NATIVE_FLOAT, f.density);
  column("pressure", H5T_NATIVE_FLOAT, f.pressure);
  column("phase", H5T_NATIVE_INT32, f.phase);
  column("id", H5T_NATIVE_INT64, f.id);
  column("colour_0", H5T_NATIVE_FLOAT, f.r);
  column("colour_1", H5T_NATIVE_FLOAT, f.g);
  column("colour_2", H5T_NATIVE_FLOAT, f.b);
  // Particle types (written since cloth and bodies joined the file; older files: all fluid).
  if (H5Lexists(group.get(), "type", H5P_DEFAULT) > 0) column("type", H5T_NATIVE_INT32, f.type);
  if (fluid_only && !f.type.empty()) {
    // Keep the fluid entries, in order.
    std::size_t w = 0;
    for (std::size_t i = 0; i < f.type.size(); ++i) {
      if (f.type[i] != kFluid) continue;
      f.x[w] = f.x[i], f.y[w] = f.y[i], f.z[w] = f.z[i];
      f.vx[w] = f.vx[i], f.vy[w] = f.vy[i], f.vz[w] = f.vz[i];
      f.density[w] = f.density[i], f.pressure[w] = f.pressure[i], f.phase[w] = f.phase[i], f.id[w] = f.id[i];
      f.r[w] = f.r[i], f.g[w] = f.g[i], f.b[w] = f.b[i];
      ++w;
    }
    for (auto* v : {&f.x, &f.y, &f.z, &f.vx, &f.vy, &f.vz, &f.density, &f.pressure, &f.r, &f.g, &f.b}) v->resize(w);
    f.phase.resize(w);
    f.id.resize(w);
    f.type.clear();
  }
  return f;
}

}  // namespace sph::io
