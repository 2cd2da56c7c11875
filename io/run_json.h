// run.json: what was run (scene, device, version), how it ended, and where the time went.
#pragma once

#include "core/simulation.h"

#include <string>
#include <vector>

namespace sph::io {

struct RunInfo {
  std::string status;        ///< "running", "complete", "interrupted" or "failed"
  std::string message;       ///< error text when not complete
  std::string scene_file;
  std::string scene_json;    ///< the resolved scene (io::sceneToJson)
  std::string device;
  std::string stages;        ///< enabled stages
  std::vector<std::string> notes;
  int frames = 0;
  double sim_time = 0;       ///< (unit: s)
  double wall_seconds = 0;   ///< (unit: s)
  std::size_t particles = 0;
  double particle_steps_per_second = 0;
  double isosurface_seconds = 0;  ///< surface field and marching cubes on the device (unit: s)
  double output_seconds = 0;      ///< main-thread read-back and hand-off of output (unit: s)
  double writer_seconds = 0;      ///< the writer thread's time writing files (unit: s)
  Profile profile;
};

/// Writes the file atomically (temporary file, then rename). Throws std::runtime_error on failure.
void writeRunJson(const std::string& path, const RunInfo& info);

/// JSON string literal with escapes.
std::string jsonString(const std::string& s);

}  // namespace sph::io
