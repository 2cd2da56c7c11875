// H5Part particle output through the HDF5 C API (layout in io/h5part_writer.h).
//
// What ParaView's H5PartReader needs (shared/clients.md, pitfall 7), and how it is met here:
//  - groups Step#0, Step#1, ... with no gaps   -> the step number is the count of steps written;
//  - a scalar native double attribute TimeValue -> H5T_NATIVE_DOUBLE in a scalar dataspace;
//  - name_0, name_1, name_2 form a vector       -> velocity_0..2, colour_0..2;
//  - every dataset in a step has the same length N (N = 0 is allowed: an empty step).
#include "io/h5part_writer.h"

#include "io/hdf5_quiet.h"

#include <hdf5.h>

#include <stdexcept>
#include <string>
#include <vector>

namespace sph::io {

static_assert(sizeof(hid_t) == sizeof(int64_t), "H5PartWriter keeps its hid_t in an int64_t");

namespace {

/// The most specific description on HDF5's current error stack ("" when empty).
std::string hdf5Reason() {
  std::string reason;
  auto visit = [](unsigned, const H5E_error2_t* error, void* out) -> herr_t {
    if (error && error->desc) *static_cast<std::string*>(out) = error->desc;  // keep the innermost
    return 0;
  };
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_DOWNWARD, visit, &reason);
  // The file drivers put the OS reason into a long description ("..., errno = 28, error message =
  // 'No space left on device', buf = ..."): keep the first clause and the reason only.
  const std::string tag = "error message = '";
  if (const auto at = reason.find(tag); at != std::string::npos) {
    const auto end = reason.find('\'', at + tag.size());
    const std::string why = reason.substr(at + tag.size(), end == std::string::npos ? std::string::npos : end - at - tag.size());
    reason = reason.substr(0, reason.find(':')) + ": " + why;
  }
  return reason;
}

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

}  // namespace

// -----------------------------------------------------------------------------------------------

H5PartWriter::H5PartWriter(const std::string& path) : path_(path) {
  QuietHdf5 quiet;
  const hid_t file = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  if (file < 0) throw std::runtime_error(path + ": cannot create the H5Part file (" + hdf5Reason() + ")");
  file_ = file;
}

H5PartWriter::~H5PartWriter() {
  try {
    close();
  } catch (...) {
    // A destructor must not throw; call close() explicitly to see the error.
  }
}

void H5PartWriter::writeStep(const ParticleFrame& frame) {
  const std::string step_name = "Step#" + std::to_string(steps_);
  auto fail = [&](const std::string& what) {
    throw std::runtime_error(path_ + ": " + step_name + ": " + what);
  };
  if (file_ < 0) fail("the H5Part file is already closed");

  // Every field has one entry per particle (the H5Part layout requires equal lengths).
  const std::size_t n = frame.size();
  const std::size_t sizes[] = {frame.y.size(),       frame.z.size(),     frame.vx.size(),    frame.vy.size(),
                               frame.vz.size(),      frame.density.size(), frame.pressure.size(), frame.phase.size(),
                               frame.id.size(),      frame.r.size(),     frame.g.size(),     frame.b.size()};
  if (!frame.type.empty() && frame.type.size() != n)
    fail("particle types have a different length (" + std::to_string(n) + " vs " + std::to_string(frame.type.size()) + ")");
  for (const std::size_t size : sizes)
    if (size != n) fail("particle fields have different lengths (" + std::to_string(n) + " vs " + std::to_string(size) + ")");

  QuietHdf5 quiet;
  const hid_t file = static_cast<hid_t>(file_);

  // The step group, then its fields; on any failure the half-written group is removed again so
  // that the file keeps only complete, consecutive steps.
  // No creation and modification times in the objects' headers (HDF5 records them by default): the
  // same particles give the same bytes, whenever they are written.
  Handle gcpl(H5Pcreate(H5P_GROUP_CREATE), H5Pclose);
  Handle dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  if (!gcpl.ok() || !dcpl.ok() || H5Pset_obj_track_times(gcpl.get(), 0) < 0 || H5Pset_obj_track_times(dcpl.get(), 0) < 0)
    fail("cannot set up the object creation properties (" + hdf5Reason() + ")");
  Handle group(H5Gcreate2(file, step_name.c_str(), H5P_DEFAULT, gcpl.get(), H5P_DEFAULT), H5Gclose);
  if (!group.ok()) fail("cannot create the group (" + hdf5Reason() + ")");
  try {
    // TimeValue: simulated time of the frame (unit: s), a scalar native double.
    {
      Handle space(H5Screate(H5S_SCALAR), H5Sclose);
      Handle attr(H5Acreate2(group.get(), "TimeValue", H5T_NATIVE_DOUBLE, space.get(), H5P_DEFAULT, H5P_DEFAULT),
                  H5Aclose);
      if (!space.ok() || !attr.ok() || H5Awrite(attr.get(), H5T_NATIVE_DOUBLE, &frame.time) < 0)
        fail("cannot write the TimeValue attribute (" + hdf5Reason() + ")");
    }

    // One 1-D dataset of length n per field; file types are explicit little-endian.
    const hsize_t dims[1] = {static_cast<hsize_t>(n)};
    Handle space(H5Screate_simple(1, dims, nullptr), H5Sclose);
    if (!space.ok()) fail("cannot create a dataspace of " + std::to_string(n) + " particles (" + hdf5Reason() + ")");
    auto column = [&](const char* name, hid_t file_type, hid_t memory_type, const void* data) {
      Handle dataset(H5Dcreate2(group.get(), name, file_type, space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT),
                     H5Dclose);
      if (!dataset.ok()) fail(std::string("cannot create dataset '") + name + "' (" + hdf5Reason() + ")");
      if (n > 0 && H5Dwrite(dataset.get(), memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)
        fail(std::string("cannot write dataset '") + name + "' (" + hdf5Reason() + ")");
    };
    const hid_t f32 = H5T_IEEE_F32LE, i32 = H5T_STD_I32LE, i64 = H5T_STD_I64LE;
    column("x", f32, H5T_NATIVE_FLOAT, frame.x.data());                    // position (unit: m)
    column("y", f32, H5T_NATIVE_FLOAT, frame.y.data());
    column("z", f32, H5T_NATIVE_FLOAT, frame.z.data());
    column("velocity_0", f32, H5T_NATIVE_FLOAT, frame.vx.data());          // velocity (unit: m/s)
    column("velocity_1", f32, H5T_NATIVE_FLOAT, frame.vy.data());
    column("velocity_2", f32, H5T_NATIVE_FLOAT, frame.vz.data());
    column("density", f32, H5T_NATIVE_FLOAT, frame.density.data());       // (unit: kg/m^3)
    column("pressure", f32, H5T_NATIVE_FLOAT, frame.pressure.data());     // (unit: Pa)
    column("phase", i32, H5T_NATIVE_INT32, frame.phase.data());           // index into fluid.phases
    column("id", i64, H5T_NATIVE_INT64, frame.id.data());                 // stable particle id
    column("colour_0", f32, H5T_NATIVE_FLOAT, frame.r.data());            // linear RGB in [0, 1]
    column("colour_1", f32, H5T_NATIVE_FLOAT, frame.g.data());
    column("colour_2", f32, H5T_NATIVE_FLOAT, frame.b.data());
    // ParticleType: 0 fluid, 1 boundary, 2 rigid body, 3 cloth node, 4 soft body (all 0 when not given).
    const std::vector<int32_t> fluid_only(frame.type.empty() ? n : 0, kFluid);
    column("type", i32, H5T_NATIVE_INT32, frame.type.empty() ? fluid_only.data() : frame.type.data());
  } catch (...) {
    H5Ldelete(file, step_name.c_str(), H5P_DEFAULT);
    throw;
  }

  // Flush, so that a run that dies later still leaves a readable file with every finished step.
  if (H5Fflush(file, H5F_SCOPE_LOCAL) < 0) fail("cannot flush the file (" + hdf5Reason() + ")");
  ++steps_;
}

void H5PartWriter::close() {
  if (file_ < 0) return;
  QuietHdf5 quiet;
  const herr_t status = H5Fclose(static_cast<hid_t>(file_));
  file_ = -1;
  if (status < 0) throw std::runtime_error(path_ + ": cannot close the H5Part file (" + hdf5Reason() + ")");
}

}  // namespace sph::io
