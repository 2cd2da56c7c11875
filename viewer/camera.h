// Orbit camera: a target point, a distance, yaw and pitch (Z up), a vertical field of view.
// Matrices are OpenGL's conventions (right-handed eye space looking down -z, clip z in [-w, w]).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>

namespace sph::viewer {

struct OrbitCamera {
  Eigen::Vector3f target{0, 0, 0};  ///< point orbited and looked at (unit: m)
  float distance = 1.0f;            ///< eye to target (unit: m)
  float yaw = -90.0f;               ///< azimuth of the eye about +z from +x; -90 = in front, at -y (unit: deg)
  float pitch = 20.0f;              ///< elevation of the eye above the target's horizontal plane (unit: deg)
  float fovy = 40.0f;               ///< vertical field of view (unit: deg)

  static float rad(float deg) { return deg * 3.14159265f / 180.0f; }

  Eigen::Vector3f eye() const {
    const float cp = std::cos(rad(pitch)), sp = std::sin(rad(pitch));
    return target + distance * Eigen::Vector3f(cp * std::cos(rad(yaw)), cp * std::sin(rad(yaw)), sp);
  }

  /// Look-at view matrix (world -> eye).
  Eigen::Matrix4f view() const {
    const Eigen::Vector3f e = eye();
    const Eigen::Vector3f f = (target - e).normalized();
    const Eigen::Vector3f s = f.cross(Eigen::Vector3f::UnitZ()).normalized();
    const Eigen::Vector3f u = s.cross(f);
    Eigen::Matrix4f m = Eigen::Matrix4f::Identity();
    m.block<1, 3>(0, 0) = s.transpose();
    m.block<1, 3>(1, 0) = u.transpose();
    m.block<1, 3>(2, 0) = -f.transpose();
    m(0, 3) = -s.dot(e);
    m(1, 3) = -u.dot(e);
    m(2, 3) = f.dot(e);
    return m;
  }

  /// Perspective projection; near and far follow the distance so that zooming keeps precision.
  Eigen::Matrix4f projection(float aspect) const {
    const float n = distance * 0.01f, f = distance * 20.0f;
    const float t = 1.0f / std::tan(rad(fovy) * 0.5f);
    Eigen::Matrix4f p = Eigen::Matrix4f::Zero();
    p(0, 0) = t / aspect;
    p(1, 1) = t;
    p(2, 2) = (f + n) / (n - f);
    p(2, 3) = 2.0f * f * n / (n - f);
    p(3, 2) = -1.0f;
    return p;
  }

  /// Frames the box [lo, hi]: looks at its centre from far enough that its bounding sphere fits
  /// the narrower of the two fields of view.
  void frame(const Eigen::Vector3f& lo, const Eigen::Vector3f& hi, float aspect) {
    target = 0.5f * (lo + hi);
    const float radius = std::max(0.5f * (hi - lo).norm(), 1e-3f);
    const float half_v = rad(fovy) * 0.5f;
    const float half_h = std::atan(std::tan(half_v) * aspect);
    distance = radius / std::sin(std::min(half_v, half_h)) * 1.02f;
  }

  /// Orbit by a mouse drag (unit: pixels).
  void orbit(float dx, float dy) {
    yaw -= 0.3f * dx;
    pitch = std::clamp(pitch + 0.3f * dy, -89.0f, 89.0f);
  }

  /// Pan by a mouse drag (unit: pixels) in a viewport `height` pixels high: the target follows the cursor.
  void pan(float dx, float dy, float height) {
    const Eigen::Vector3f f = (target - eye()).normalized();
    const Eigen::Vector3f s = f.cross(Eigen::Vector3f::UnitZ()).normalized();
    const Eigen::Vector3f u = s.cross(f);
    const float metres_per_pixel = 2.0f * distance * std::tan(rad(fovy) * 0.5f) / std::max(height, 1.0f);
    target += metres_per_pixel * (-dx * s + dy * u);
  }

  /// Zoom by wheel steps (positive = closer).
  void zoom(float steps) { distance = std::clamp(distance * std::pow(0.9f, steps), 1e-4f, 1e4f); }
};

}  // namespace sph::viewer
