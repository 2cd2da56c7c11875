// Frames of a running simulation for a live window (`sphaptics run --interactive` with a display).
//
//   simulation thread ──publish(shared_ptr<const LiveFrame>)──► LiveMailbox ──latest()──► renderer
//   renderer ──WindowRequests (atomics: pause, reset, stop, gain, smoothing)──► simulation thread
//
// The mailbox holds only the newest frame: publishing swaps one pointer under a mutex that is held
// for the swap alone (never while a frame is copied or drawn), so the simulation never waits for
// the renderer, however slow it is; a renderer that falls behind skips frames. A frame is
// immutable once published, and the renderer keeps its own reference while it draws.
#pragma once

#include "core/mesh.h"
#include "core/particle_frame.h"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

namespace sph {

/// What does not change during a run: the domain, the particle size, the bodies' meshes.
struct LiveScene {
  std::string title;                                   ///< scene file
  Eigen::Vector3f domain_min = Eigen::Vector3f::Zero();  ///< (unit: m)
  Eigen::Vector3f domain_max = Eigen::Vector3f::Ones();  ///< (unit: m)
  float particle_radius = 0.005f;                      ///< half the spacing (unit: m)
  double frame_rate = 30;                              ///< output frames per simulated second (unit: 1/s)
  std::vector<std::string> body_names;
  std::vector<TriMesh> body_meshes;                    ///< body frame, origin at the centre of mass (unit: m)
  std::vector<Eigen::Vector3f> body_colours;           ///< linear RGB
  std::vector<Eigen::Vector3f> cloth_colours;          ///< linear RGB, one per cloth
  bool haptics = false;                                ///< a haptic device drives the run
};

/// The haptic device as the window draws it, scene frame.
struct LiveHaptics {
  Eigen::Vector3d cursor = Eigen::Vector3d::Zero();  ///< device position mapped to the scene (unit: m)
  Eigen::Vector3d grasp = Eigen::Vector3d::Zero();   ///< grasp point on the held body (unit: m)
  long held = -1;                                    ///< held body (index into LiveScene::body_meshes), -1 none
  Eigen::Vector3d force = Eigen::Vector3d::Zero();   ///< force sent to the device, scene axes (unit: N)
  uint64_t servo_ticks = 0;                          ///< servo ticks so far
  double servo_seconds = 0;                          ///< clock time of those ticks (unit: s)
  double gain = 1;                                   ///< force gain in use (unit: 1)
  int smoothing = 0;                                 ///< rolling-average window in use (unit: frames), 0 = servo smoothing
};

/// One published frame.
struct LiveFrame {
  int frame = 0;                                     ///< output frame index
  double time = 0;                                   ///< simulated time (unit: s)
  double wall = 0;                                   ///< wall time since the run started (unit: s)
  ParticleFrame particles;                           ///< fluid particles
  std::vector<Eigen::Vector3f> body_positions;       ///< centre of mass per body (unit: m)
  std::vector<Eigen::Quaternionf> body_orientations; ///< body -> world per body
  std::vector<TriMesh> cloths;                       ///< one mesh per cloth, world (unit: m)
  LiveHaptics haptics;
  bool finished = false;                             ///< the run has ended (last frame)
};

/// The newest frame, swapped in by the simulation and read by the renderer.
class LiveMailbox {
 public:
  void setScene(std::shared_ptr<const LiveScene> scene) {
    std::lock_guard<std::mutex> lock(mutex_);
    scene_ = std::move(scene);
  }
  std::shared_ptr<const LiveScene> scene() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return scene_;
  }
  /// Simulation thread: replaces the newest frame (the mutex covers the pointer swap only).
  void publish(std::shared_ptr<const LiveFrame> frame) {
    std::shared_ptr<const LiveFrame> old;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      old = std::exchange(frame_, std::move(frame));
      ++published_;
    }
    // `old` is released here, outside the lock (freeing a big frame takes time).
  }
  /// Renderer: the newest frame (null before the first).
  std::shared_ptr<const LiveFrame> latest() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return frame_;
  }
  uint64_t published() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return published_;
  }

 private:
  mutable std::mutex mutex_;
  std::shared_ptr<const LiveScene> scene_;
  std::shared_ptr<const LiveFrame> frame_;
  uint64_t published_ = 0;
};

/// Requests from the window to the simulation thread, read once per frame (a live session passes
/// pause, gain and smoothing on to its own controls, haptics::LiveControls in haptics/live.h).
struct WindowRequests {
  std::atomic<bool> paused{false};  ///< the simulation waits between frames
  std::atomic<bool> reset{false};   ///< end this run and start the scene again
  std::atomic<bool> stop{false};    ///< end the run (window closed)
  std::atomic<double> gain{std::numeric_limits<double>::quiet_NaN()};     ///< new force gain; NaN = unchanged (unit: 1)
  /// New smoothing: the rolling-average window (unit: frames; the paper's method), 0 = the servo's
  /// own smoothing (haptics/servo.h); NaN = unchanged.
  std::atomic<double> smoothing{std::numeric_limits<double>::quiet_NaN()};
};

/// The link between a run and its window.
struct LiveLink {
  LiveMailbox mailbox;
  WindowRequests requests;
};

}  // namespace sph
