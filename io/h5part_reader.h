// Reading particles.h5part (the layout io/h5part_writer.h writes): the viewer's one place for HDF5
// reading. A file still being written (particles.h5part.partial) can be read too: the file is
// opened read-only without HDF5's file lock, each complete step is flushed by the writer, and a
// step that cannot be read yet is reported as an error rather than a crash.
#pragma once

#include "core/particle_frame.h"

#include <cstdint>
#include <string>

namespace sph::io {

class H5PartReader {
 public:
  /// Opens the file read-only. Throws std::runtime_error naming the path when it cannot be opened.
  explicit H5PartReader(const std::string& path);
  ~H5PartReader();
  H5PartReader(const H5PartReader&) = delete;
  H5PartReader& operator=(const H5PartReader&) = delete;

  /// Number of consecutive groups Step#0, Step#1, ... in the file (as it was when opened).
  int steps() const { return steps_; }
  /// Reads Step#k. Throws std::runtime_error naming the file and step when a field is missing,
  /// has the wrong length or cannot be read.
  /// Step k. With `fluid_only` (the default) the entries whose `type` is not fluid (rigid-body
  /// particles, cloth nodes) are left out; files without a `type` dataset hold only fluid.
  ParticleFrame readStep(int k, bool fluid_only = true) const;
  /// Simulated time of Step#k (unit: s), from its TimeValue attribute.
  double stepTime(int k) const;

 private:
  int64_t file_ = -1;  // hid_t
  int steps_ = 0;
  std::string path_;
};

}  // namespace sph::io
