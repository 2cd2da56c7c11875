// run.json: what was run (scene, device, version), how it ended, and where the time went.
#pragma once

#include "core/simulation.h"

#include <string>
#include <vector>

namespace sph::io {

/// Numerical warnings summed over a run's frames (run.json "warnings", also under --quiet).
struct RunWarnings {
  uint64_t nonfinite = 0;            ///< particle-frames with NaN/inf position, velocity or density (unit: 1)
  int nonfinite_frames = 0;          ///< frames with any (unit: 1)
  uint64_t cfl_violations = 0;       ///< particle-steps that moved more than h in one step (unit: 1)
  int cfl_violation_frames = 0;      ///< frames with any (unit: 1)
  int cfl_step_frames = 0;           ///< frames whose time step exceeded the CFL / viscous limit (time_step_control: warn) (unit: 1)
  double max_step_over_limit = 0;    ///< largest time step / its limit over those frames (unit: 1)
  uint64_t wall_crossings = 0;       ///< particles put back after crossing a closed wall (unit: 1)
  int wall_crossing_frames = 0;      ///< frames with any (unit: 1)
  uint64_t left_domain = 0;          ///< particle-frames outside the domain through an open wall (unit: 1)
  /// Adds one frame's report.
  void add(const FrameReport& rep);
  /// True when the step of `rep` exceeded its limit (a CFL violation of the time step itself).
  static bool stepOverLimit(const FrameReport& rep) { return rep.dt > rep.dt_limit * (1.0 + 1e-9); }
  /// "480 wall crossings in 12 frames, ..." ("" when there is nothing to report).
  std::string summary() const;
};

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
  RunWarnings warnings;
};

/// Writes the file atomically (temporary file, then rename). Throws std::runtime_error on failure.
void writeRunJson(const std::string& path, const RunInfo& info);

/// JSON string literal with escapes.
std::string jsonString(const std::string& s);

}  // namespace sph::io
