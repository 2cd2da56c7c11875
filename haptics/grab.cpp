#include "haptics/grab.h"

#include <cmath>
#include <limits>

namespace sph::haptics {

GrabController::GrabController(Mapping mapping, GrabSettings settings, std::vector<Grabbable> candidates)
    : mapping_(std::move(mapping)), settings_(settings), candidates_(std::move(candidates)) {
  // K_s = K_d / (g s) (../shared/haptics.md, "Simulation side"), for the gain and scale given here.
  reference_ = settings_.gain * mapping_.scale;
  ks_ = settings_.stiffness / reference_;
}

void GrabController::setMapping(const Mapping& m) {
  // The target moves by the change of mapping at the current device position: move the spring's
  // rest offset with it, so that the held body feels no jump.
  if (held_ >= 0) rest_ += m.toScene(device_x_) - mapping_.toScene(device_x_);
  mapping_ = m;
}

void GrabController::update(const DeviceState& device, const std::vector<rigid::BodyState>& states,
                            std::vector<BodyWrench>& out, double dt) {
  // The device target in the scene.
  device_x_ = device.position;
  target_ = mapping_.toScene(device.position);
  const Eigen::Vector3d target_v = mapping_.velocityToScene(device.velocity);
  const bool pressed = (device.buttons & 1u) != 0;

  // Press: the nearest grabbable body within reach, at its closest surface point (ties: first listed).
  if (pressed && !was_pressed_ && held_ < 0) {
    double best = settings_.reach;
    for (std::size_t c = 0; c < candidates_.size(); ++c) {
      const rigid::BodyState& s = states[candidates_[c].body];
      const Eigen::Vector3d local = s.q.conjugate() * (target_ - s.x);
      const Eigen::Vector3d p = candidates_[c].closest(local);
      const double d = (p - local).norm();
      if (d <= best) {
        best = d;
        held_ = static_cast<long>(c);
        grasp_ = p;
        rest_ = target_ - s.toWorld(p);
        q_grab_ = s.q;
      }
    }
  }
  // Release: the coupling ends; the body keeps its momentum.
  if (!pressed && was_pressed_) held_ = -1;
  was_pressed_ = pressed;
  coupling_.setZero();
  if (held_ < 0) return;

  // Coupling spring and damper between the target and the grasp point, acting at the grasp point,
  // implicit in the body's motion over the step (the top of grab.h): the force at the step's end if
  // the grasp point kept its velocity, K_s (p_t - p_g') + (K_s dt + B_s) (v_t - v_g), and its rate
  // with the body's velocities u = (v, w), c J^T J, c = K_s dt + B_s, J u = v - [r]x w the grasp
  // point's velocity.
  const Grabbable& g = candidates_[static_cast<std::size_t>(held_)];
  const rigid::BodyState& s = states[g.body];
  const Eigen::Vector3d r = s.q * grasp_;
  const Eigen::Vector3d pg = s.x + r + rest_;
  const Eigen::Vector3d vg = s.v + s.w.cross(r);
  const double ks = bodyStiffness();
  const double bs = 2.0 * settings_.damping_ratio * std::sqrt(ks * g.mass);
  const double c = ks * dt + bs;  // (unit: N s/m)
  const Eigen::Vector3d f = ks * (target_ - pg) + c * (target_v - vg);
  coupling_ = f;
  BodyWrench& w = out[g.body];
  w.force += f;
  w.torque += r.cross(f);
  Eigen::Matrix3d rx;  // [r]x, rx v = r x v
  rx << 0.0, -r.z(), r.y(), r.z(), 0.0, -r.x(), -r.y(), r.x(), 0.0;
  w.damping.topLeftCorner<3, 3>() += c * Eigen::Matrix3d::Identity();
  w.damping.topRightCorner<3, 3>() -= c * rx;
  w.damping.bottomLeftCorner<3, 3>() += c * rx;
  w.damping.bottomRightCorner<3, 3>() -= c * rx * rx;

  // Orientation hold: an angular spring-damper towards the orientation at the grab, as stiff and as
  // damped as the linear coupling on every axis (tau = I_w (w_n^2 theta_e - 2 zeta w_n w)).
  if (settings_.hold_orientation) {
    Eigen::Quaterniond qe = q_grab_ * s.q.conjugate();
    if (qe.w() < 0) qe.coeffs() = -qe.coeffs();  // the short way round
    const Eigen::AngleAxisd aa(qe.normalized());
    const Eigen::Vector3d theta = aa.angle() * aa.axis();
    const Eigen::Matrix3d R = s.q.toRotationMatrix();
    const Eigen::Matrix3d inertia_world = R * g.inertia * R.transpose();
    const double wn = std::sqrt(ks / g.mass);
    // Implicit as the force: at the step's end theta_e has turned by -dt w', so the rate is
    // c_w I_w, c_w = w_n^2 dt + 2 zeta w_n.
    const double cw = wn * wn * dt + 2.0 * settings_.damping_ratio * wn;  // (unit: 1/s)
    w.torque += inertia_world * (wn * wn * theta - cw * s.w);
    w.damping.bottomRightCorner<3, 3>() += cw * inertia_world;
  }
}

LocalModel GrabController::localModel(double stamp, const std::vector<rigid::BodyState>& states) const {
  LocalModel m;
  m.stamp = stamp;
  // Felt stiffness and damping K_d = g s K_s, B_d scaled alike: the gain ("haptic strength") and the
  // scale set while running act here (K_s on the body stays as it was).
  m.stiffness = settings_.stiffness * feltFactor();
  m.damping = settings_.damping * feltFactor();
  m.ttl = settings_.ttl;
  m.coupled = held_ >= 0;
  if (held_ < 0) return m;
  // The grasp point, mapped back to the device: the anchor the hand is pulled to.
  const rigid::BodyState& s = states[candidates_[static_cast<std::size_t>(held_)].body];
  const Eigen::Vector3d r = s.q * grasp_;
  m.anchor = mapping_.toDevice(s.x + r + rest_);
  m.anchor_velocity = mapping_.velocityToDevice(s.v + s.w.cross(r));
  if (settings_.force_as_feed_forward) {
    // Felt force = -g x (the coupling force on the body), in the device frame: the force that acted
    // over the last step (the state's, core/rigid.h BodyState::external_force), or the last update's.
    const Eigen::Vector3d& acted = s.external_damping.isZero(0.0) ? coupling_ : s.external_force;
    m.feed_forward = -settings_.gain * (mapping_.rotation.transpose() * acted);
    m.coupled = false;
  }
  return m;
}

}  // namespace sph::haptics
