// The `mouse` device backend: a desktop mouse as a 3-DOF haptic device, for anyone without a Touch.
//
//   window ──MouseEvent (camera, move, button, wheel)──► MouseInput (queue) ──read()──► MouseDevice
//   MouseDevice ──write(F)──► MouseInput::force() ──► the window draws the force as an arrow
//
// The cursor moves a 3D point in the plane that faces the camera at the current depth (distance
// along the viewing direction from the eye); the wheel changes the depth; the left button is
// button 0 (grab). Nothing is felt: the force the servo sends is kept for drawing. The geometry
// is a pure function (cursorToScene) and the input is a queue of events, each with a clock time
// (0 = as soon as read), so tests drive the backend with synthetic events and no window.
#pragma once

#include "haptics/device.h"
#include "haptics/grab.h"

#include <Eigen/Core>

#include <memory>
#include <mutex>
#include <utility>
#include <vector>

namespace sph::haptics {

/// A pinhole camera as the window has it: eye, orthonormal axes, vertical field of view, viewport.
struct MouseCamera {
  Eigen::Vector3d eye = Eigen::Vector3d::Zero();       ///< (unit: m)
  Eigen::Vector3d forward = Eigen::Vector3d::UnitY();  ///< viewing direction, unit
  Eigen::Vector3d right = Eigen::Vector3d::UnitX();    ///< screen x, unit
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();       ///< screen y (up), unit
  double fovy = 40.0;                                  ///< vertical field of view (unit: deg)
  double width = 1280, height = 720;                   ///< viewport (unit: pixels)
};

/// The scene point under cursor pixel (x, y) (origin at the top-left, y down) in the plane facing
/// the camera at `depth` along the viewing direction (unit: m): the ray through the pixel centre
/// of a perspective projection, cut at that depth.
Eigen::Vector3d cursorToScene(const MouseCamera& cam, double x, double y, double depth);
/// The inverse: (x, y, depth) of a scene point (pixels, pixels, metres).
Eigen::Vector3d sceneToCursor(const MouseCamera& cam, const Eigen::Vector3d& p);

/// One input event. `time` is the device clock's time at which it applies (0 = at the next read).
struct MouseEvent {
  enum class Kind { Camera, Move, Button, Wheel };
  Kind kind = Kind::Move;
  double time = 0;          ///< (unit: s)
  double x = 0, y = 0;      ///< Move: cursor (unit: pixels)
  bool pressed = false;     ///< Button: left button down
  double steps = 0;         ///< Wheel: notches (positive = away from the eye)
  MouseCamera camera;       ///< Camera: the view the cursor is read in
  double depth = -1;        ///< Camera: new depth (unit: m); < 0 keeps the current one
};

/// The queue between the window (any thread) and the device (servo thread), and the force back.
class MouseInput {
 public:
  void push(const MouseEvent& e);
  /// Events due at `now` (time <= now), in the order pushed; later ones stay queued.
  std::vector<MouseEvent> take(double now);
  void setForce(const Eigen::Vector3d& f);
  Eigen::Vector3d force() const;  ///< last force sent to the device, device frame (unit: N)
  void setPoint(const Eigen::Vector3d& p, double depth);
  Eigen::Vector3d point() const;  ///< the 3D point the cursor moves, scene (unit: m)
  double depth() const;           ///< its depth (unit: m)

 private:
  mutable std::mutex mutex_;
  std::vector<MouseEvent> queue_;
  Eigen::Vector3d force_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d point_ = Eigen::Vector3d::Zero();
  double depth_ = 0;
};

/// The device: reads the queue at each read(), maps the cursor to the scene and back to the
/// device frame through the scene's workspace mapping (so the grab sees an ordinary device).
class MouseDevice : public Device {
 public:
  MouseDevice(std::shared_ptr<MouseInput> input, const Clock& clock, Mapping mapping, DeviceSpec spec = mouseSpec());
  void open() override { open_ = true; }
  void close() override { open_ = false; }
  DeviceSpec spec() const override { return spec_; }
  void read(DeviceState& s) override;
  void write(const Eigen::Vector3d& force) override;
  /// A device with the Touch's force and stiffness limits (the servo stays as for a real device)
  /// and an unbounded workspace.
  static DeviceSpec mouseSpec();

 private:
  std::shared_ptr<MouseInput> input_;
  const Clock& clock_;
  Mapping mapping_;
  DeviceSpec spec_;
  bool open_ = false;
  bool have_camera_ = false;
  MouseCamera camera_;
  double x_ = 0, y_ = 0, depth_ = 1;
  bool pressed_ = false;
  // Recent readings (clock time, scene point) for the velocity: a finite difference over
  // kVelocityWindow, so that a cursor that jumps once per window event reads as a steady motion;
  // cleared at each press and release (a new gesture starts at rest).
  std::vector<std::pair<double, Eigen::Vector3d>> history_;
  Eigen::Vector3d v_ = Eigen::Vector3d::Zero();

 public:
  static constexpr double kVelocityWindow = 0.04;  ///< (unit: s): two to three window frames
};

}  // namespace sph::haptics
