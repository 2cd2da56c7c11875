#include "haptics/mouse.h"

#include <algorithm>
#include <cmath>

namespace sph::haptics {

namespace {
// tan of half the vertical field of view, and the viewport's aspect ratio.
double tanHalf(const MouseCamera& cam) { return std::tan(cam.fovy * M_PI / 360.0); }
double aspect(const MouseCamera& cam) { return cam.width / std::max(cam.height, 1.0); }
}  // namespace

Eigen::Vector3d cursorToScene(const MouseCamera& cam, double x, double y, double depth) {
  // Normalised device coordinates of the cursor (x right, y up, [-1, 1] across the viewport).
  const double nx = 2.0 * x / std::max(cam.width, 1.0) - 1.0;
  const double ny = 1.0 - 2.0 * y / std::max(cam.height, 1.0);
  // The ray through that point of the image plane at unit depth, scaled to `depth`.
  const double t = tanHalf(cam);
  const Eigen::Vector3d ray = cam.forward + nx * t * aspect(cam) * cam.right + ny * t * cam.up;
  return cam.eye + depth * ray;
}

Eigen::Vector3d sceneToCursor(const MouseCamera& cam, const Eigen::Vector3d& p) {
  const Eigen::Vector3d q = p - cam.eye;
  const double depth = q.dot(cam.forward);
  const double t = tanHalf(cam);
  const double nx = q.dot(cam.right) / (depth * t * aspect(cam));
  const double ny = q.dot(cam.up) / (depth * t);
  return {0.5 * (nx + 1.0) * cam.width, 0.5 * (1.0 - ny) * cam.height, depth};
}

void MouseInput::push(const MouseEvent& e) {
  std::lock_guard<std::mutex> lock(mutex_);
  queue_.push_back(e);
}

std::vector<MouseEvent> MouseInput::take(double now) {
  std::lock_guard<std::mutex> lock(mutex_);
  // Due events leave in order; the first one not yet due holds back the ones after it.
  const auto due = std::find_if(queue_.begin(), queue_.end(), [now](const MouseEvent& e) { return e.time > now; });
  std::vector<MouseEvent> out(queue_.begin(), due);
  queue_.erase(queue_.begin(), due);
  return out;
}

void MouseInput::setForce(const Eigen::Vector3d& f) {
  std::lock_guard<std::mutex> lock(mutex_);
  force_ = f;
}

Eigen::Vector3d MouseInput::force() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return force_;
}

void MouseInput::setPoint(const Eigen::Vector3d& p, double depth) {
  std::lock_guard<std::mutex> lock(mutex_);
  point_ = p;
  depth_ = depth;
}

Eigen::Vector3d MouseInput::point() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return point_;
}

double MouseInput::depth() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return depth_;
}

MouseDevice::MouseDevice(std::shared_ptr<MouseInput> input, const Clock& clock, Mapping mapping, DeviceSpec spec)
    : input_(std::move(input)), clock_(clock), mapping_(mapping), spec_(std::move(spec)) {}

DeviceSpec MouseDevice::mouseSpec() {
  DeviceSpec s;
  s.name = "mouse";
  s.workspace_radius = 1e9;  // the cursor goes anywhere on the screen
  s.buttons = 1;
  return s;
}

void MouseDevice::read(DeviceState& s) {
  const double now = clock_.now();
  // Apply the events that are due, in order.
  for (const MouseEvent& e : input_->take(now)) {
    switch (e.kind) {
      case MouseEvent::Kind::Camera:
        camera_ = e.camera;
        have_camera_ = true;
        if (e.depth >= 0) depth_ = e.depth;
        break;
      case MouseEvent::Kind::Move:
        x_ = e.x;
        y_ = e.y;
        break;
      case MouseEvent::Kind::Button:
        // A press or release starts a new gesture: the velocity is measured from here on, so a
        // cursor that jumped onto a body just before the click (a teleport, 3 m/s over the 40 ms
        // window for a 12 cm jump) does not throw the body it grabs (the coupling's damper acts on
        // the target's velocity).
        if (e.pressed != pressed_) {
          history_.clear();
          v_.setZero();
        }
        pressed_ = e.pressed;
        break;
      case MouseEvent::Kind::Wheel:
        // Each notch moves the plane 5 % of its depth away from (positive) or towards the eye.
        depth_ = std::max(depth_ * std::pow(1.05, e.steps), 1e-4);
        break;
    }
  }
  // The cursor's 3D point (the workspace centre until the window has sent a camera).
  const Eigen::Vector3d p = have_camera_ ? cursorToScene(camera_, x_, y_, depth_) : mapping_.offset;
  input_->setPoint(p, depth_);
  // Velocity: finite difference from the oldest reading within the window (kept when no time
  // has passed); readings older than the window are dropped, all but the newest such one.
  history_.emplace_back(now, p);
  std::size_t first = 0;
  while (first + 1 < history_.size() && now - history_[first + 1].first >= kVelocityWindow) ++first;
  history_.erase(history_.begin(), history_.begin() + static_cast<std::ptrdiff_t>(first));
  if (history_.size() > 1 && now > history_.front().first)
    v_ = (p - history_.front().second) / (now - history_.front().first);
  s.time = now;
  s.position = mapping_.toDevice(p);
  s.velocity = mapping_.velocityToDevice(v_);
  s.orientation = Eigen::Quaterniond::Identity();
  s.buttons = pressed_ ? 1u : 0u;
}

void MouseDevice::write(const Eigen::Vector3d& force) { input_->setForce(force); }

}  // namespace sph::haptics
