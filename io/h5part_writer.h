// particles.h5part: one group Step#k per output frame (k = 0, 1, 2, ... consecutive), each with a
// float64 scalar attribute TimeValue and datasets x y z velocity_0 velocity_1 velocity_2 density
// pressure phase id colour_0 colour_1 colour_2, all of the same length: the layout ParaView's
// H5PartReader opens (see shared/clients.md).
#pragma once

#include "core/particle_frame.h"

#include <cstdint>
#include <string>

namespace sph::io {

class H5PartWriter {
 public:
  /// Creates (truncates) the file. Throws std::runtime_error naming the path on failure.
  explicit H5PartWriter(const std::string& path);
  ~H5PartWriter();
  H5PartWriter(const H5PartWriter&) = delete;
  H5PartWriter& operator=(const H5PartWriter&) = delete;

  /// Appends Step#<stepsWritten()> with TimeValue = frame.time.
  void writeStep(const ParticleFrame& frame);
  int stepsWritten() const { return steps_; }
  /// Flushes and closes; called by the destructor if not called before.
  void close();

 private:
  int64_t file_ = -1;  // hid_t
  int steps_ = 0;
  std::string path_;
};

}  // namespace sph::io
