// The `run` command: scene file -> compiled model -> frames on the device -> output files.
#pragma once

#include "core/live_frame.h"
#include "core/simulation.h"
#include "haptics/mouse.h"
#include "haptics/record.h"

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace sph::app {

struct RunOptions {
  std::string scene;                  ///< scene file
  std::string out;                    ///< output folder (overrides output.directory)
  std::string device;                 ///< "cpu", "gpu", an index, or "" (SPHAPTICS_DEVICE / default)
  std::vector<std::string> sets;      ///< "key.path=value" overrides
  std::vector<std::string> disable;   ///< stage names to switch off
  double duration = -1.0;             ///< simulated seconds; < 0 = the scene's (unless duration_given)
  bool duration_given = false;        ///< --duration was on the command line: `duration` must be finite and > 0
  double max_memory = 0;              ///< refuse scenes estimated to need more (unit: bytes; 0 = the machine's memory)
  bool quiet = false;                 ///< no progress line, no summary
  bool profile_kernels = false;       ///< time every kernel dispatch (waits after each; slower) and print the table
  bool write_output = true;           ///< false: simulate only (benchmarks)
  std::string record;                 ///< with interactive: write the device readings per step and a state hash per frame here
  const haptics::Recording* replay = nullptr;  ///< replay this recording (its frames; every hash checked)
  bool interactive = false;           ///< live: the servo on its own thread in real time, frames paced to the wall clock
  /// A window's link (core/live_frame.h): each frame is published to its mailbox, and its controls
  /// (pause, reset, stop, gain, smoothing) are read once per frame; null = none.
  std::shared_ptr<LiveLink> live_link;
  /// The `mouse` device backend (haptics/mouse.h) instead of the scene's: the window (or a test)
  /// feeds this queue; null = the scene's backend.
  std::shared_ptr<haptics::MouseInput> mouse;
  /// Live runs: called with the session's controls (gain, mapping, smoothing, pause; thread-safe,
  /// applied at frame boundaries) once it has started, and with nullptr before it stops: the hook
  /// for an in-process panel (e.g. the viewer's window).
  std::function<void(haptics::LiveControls*)> live_controls;
};

/// What a finished run measured (for benchmarks and tests).
struct RunResult {
  int exit_code = 0;
  std::string message;           ///< error text when exit_code != 0
  std::string out_dir;
  int frames = 0;
  double sim_time = 0;           ///< (unit: s)
  double wall_seconds = 0;       ///< simulation loop wall time, output and isosurface excluded (unit: s)
  double output_seconds = 0;     ///< main-thread time reading particles back and queueing output (unit: s)
  double iso_seconds = 0;        ///< isosurface on the device, read-back included, frames 1.. (unit: s)
  double loop_seconds = 0;       ///< the whole frame loop: simulation + isosurface + output hand-off (unit: s)
  double writer_seconds = 0;     ///< time the writer thread spent writing files (unit: s)
  std::size_t surface_vertices = 0;   ///< last frame's surface meshes, all phases
  std::size_t surface_triangles = 0;  ///< last frame's surface meshes, all phases
  std::size_t particles = 0;     ///< fluid particles at the end
  Profile profile;
  std::size_t device_bytes = 0;
  uint64_t state_hash = 0;
  std::map<std::string, uint64_t> dispatch_counts;
  std::map<std::string, double> kernel_seconds;  ///< with profile_kernels: wall time per kernel (unit: s)
  std::map<std::string, double> kernel_cpu_seconds;  ///< with profile_kernels: process CPU time per kernel (unit: s)
  std::vector<FrameReport> reports;  ///< one per frame
  bool haptics = false;              ///< a haptic session ran (the scene has a `haptics` section)
  std::size_t haptic_ticks = 0;      ///< servo ticks run (virtual time; live: real ticks)
  double servo_p99 = 0;              ///< live: servo period, 99th percentile (unit: s)
  uint64_t servo_overruns = 0;       ///< live: servo periods over 1.5 T
  int replay_frames_checked = 0;     ///< replay: frames whose state hash matched the recording
  bool stopped_by_window = false;    ///< the live window asked to stop or reset (WindowRequests)
};

/// Surface grid spacing when output.isosurface.spacing is 0, as a fraction of the particle spacing
/// (README "Isosurfaces" gives the measurement behind it).
inline constexpr double kAutoIsoSpacingRatio = 0.5;

/// Runs a scene; every error becomes an exit code and message (2 bad input, 3 device, 4 numerical).
/// `on_frame` (optional) sees the simulation after each frame, e.g. for tests that probe the state.
RunResult runScene(const RunOptions& opt, const std::function<void(Simulation&, const FrameReport&)>& on_frame = {});

}  // namespace sph::app
