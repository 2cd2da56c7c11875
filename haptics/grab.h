// Grab and release on the simulation side (../shared/haptics.md, "Simulation side").
//
//   device x ──map──► target p_t (scene) ──spring K_s, damper B_s──► grasp point p_g on the body
//   grasp point ──map back──► LocalModel anchor a (device) ──servo──► F = K_d (a - x) + ...
//
// A press of button 0 attaches the nearest grabbable body whose surface is within `reach` of the
// target, at its closest surface point p_g; the gap d0 = p_t - p_g at that moment is kept as the
// spring's rest offset (so a grab starts with no force, no jump); while held, with p_g' = p_g + d0, F_s = K_s (p_t - p_g') + B_s (v_t - v_g) acts at
// p_g (with its torque about the centre of mass), so the body keeps feeling the fluid and contacts
// too; a release ends the coupling and the body goes on with its momentum. The hand feels
// K_d = g s K_s (g the gain, s the mapping scale): in steady state the felt force is -g F_s, i.e.
// g times the fluid and contact forces the hand holds the body against. B_s = 2 zeta sqrt(K_s m).
//
// Orientation (hold_orientation): a hand holds a tool's orientation too, but the Touch renders a
// 3-DOF force only, so a grab at one point would let the body swing about it like a pendulum (the
// painting demo's brush tipped over). While held, an angular spring-damper pulls the body towards
// its orientation at the grab:
//     tau = I_w (w_n^2 theta_e - 2 zeta w_n w),   theta_e = axis-angle of q_grab q^-1,
// I_w = R I R^T the body's world inertia, w_n = sqrt(K_s / m) the linear coupling's natural
// frequency and zeta its damping ratio: every axis turns back as quickly as the grasp point follows
// the target, and as stably (the same w_n dt). The torque acts on the body only; the hand does not
// feel it (no torque is rendered, and the felt force is unchanged).
//
// Implicit in the body's motion (session 26). The body integrates the wrench over the simulation
// step dt. Held at a point r off its centre it answers a force there with the mobility
// Mob = (1/m) 1 + [r]x^T I_w^-1 [r]x (the grasp point's velocity change per unit impulse), up to 4/m
// for a thin rod held at its end, so an explicit spring-damper's rates (B_s dt Mob, K_s dt^2 Mob) are
// up to four times those at the centre: at DFSPH's ~5 ms steps a 12 g wooden spoon held at its top had
// B_s dt Mob = 4.7 and swung with period 2 steps, growing ~5x a step (docs/forces.md, session 25; the
// staggered coupling's fictitious inertia had hidden it). So the wrench is handed over with its rate
// (BodyWrench::damping): the force at the step's end if the grasp point kept its velocity,
//     F_e = K_s (p_t - p_g') + (K_s dt + B_s) (v_t - v_g),
// and D = (K_s dt + B_s) J^T J, J u = v_g, so that the body's step solves (M + dt D) du = dt (F_o + J^T F_e)
// with every other force F_o of the step in it (core/rigid.h, integrateVelocity): backward Euler for
// the coupling, stable at any dt and K_s, with the grasp point's acceleration from the fluid and gravity
// in it, so the steady state is the explicit one's (at rest F_s = K_s (p_t - p_g') = -F_o) and the
// explicit force as dt -> 0. The force that acted, F_e - c J du, is the state's external_force after
// the step. The orientation hold alike: c_w = w_n^2 dt + 2 zeta w_n in the explicit torque and
// c_w I_w in D. DFSPH's strong coupling moves the held body inside its solves with this same
// mobility (M + dt D)^-1 (kernels/shared/body_response.h).
#pragma once

#include "core/external_force.h"
#include "haptics/device.h"
#include "haptics/servo.h"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <functional>
#include <vector>

namespace sph::haptics {

/// x_scene = scale R x_device + offset.
struct Mapping {
  double scale = 1.0;                                   ///< (unit: 1)
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();     ///< (unit: m)
  Eigen::Vector3d toScene(const Eigen::Vector3d& x) const { return scale * (rotation * x) + offset; }
  Eigen::Vector3d toDevice(const Eigen::Vector3d& p) const { return rotation.transpose() * (p - offset) / scale; }
  Eigen::Vector3d velocityToScene(const Eigen::Vector3d& v) const { return scale * (rotation * v); }
  Eigen::Vector3d velocityToDevice(const Eigen::Vector3d& v) const { return rotation.transpose() * v / scale; }
};

struct GrabSettings {
  double gain = 1.0;            ///< felt force / force on the body (unit: 1)
  double stiffness = 250.0;     ///< K_d, felt at the hand (unit: N/m)
  double damping = 1.5;         ///< B_d, felt at the hand (unit: N s/m)
  double damping_ratio = 0.9;   ///< zeta of the body's coupling (unit: 1)
  double reach = 0.05;          ///< largest grab distance, scene (unit: m)
  double ttl = 0.1;             ///< validity of each LocalModel (unit: s)
  /// The paper's mode (Smoothing::RollingAverage): the LocalModel carries the felt force
  /// -g R^T F_s as feed-forward (the servo averages it over frames) instead of the anchor.
  bool force_as_feed_forward = false;
  /// Hold the held body's orientation at the grab (angular spring-damper, not felt).
  bool hold_orientation = true;
};

/// A body the device may grab: its index in Model::bodies, mass, and the closest point of its
/// surface to a point, both in the body frame (origin at the centre of mass).
struct Grabbable {
  std::size_t body = 0;
  double mass = 1.0;  ///< (unit: kg)
  std::function<Eigen::Vector3d(const Eigen::Vector3d&)> closest;
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Identity();  ///< body frame, about the centre of mass (unit: kg m^2)
};

class GrabController {
 public:
  GrabController(Mapping mapping, GrabSettings settings, std::vector<Grabbable> candidates);
  /// Once per simulation step: the device reading, the bodies; writes the coupling wrench of the
  /// held body into `out` (sized as `states`). Grabs on a press of button 0, releases on its release.
  /// `dt`: the step the wrench acts over (unit: s), for its implicit part (the top of this file); 0
  /// gives the explicit spring-damper (its damping is then the rate of a step of length 0).
  void update(const DeviceState& device, const std::vector<rigid::BodyState>& states, std::vector<BodyWrench>& out,
              double dt = 0.0);
  /// The local model for the servo at `stamp` (servo clock), from the current states.
  LocalModel localModel(double stamp, const std::vector<rigid::BodyState>& states) const;
  /// Index of the held body in Model::bodies, or -1.
  long grabbed() const { return held_ < 0 ? -1 : static_cast<long>(candidates_[static_cast<std::size_t>(held_)].body); }
  /// The spring on the body (scene, N/m): K_s = K_d / (g s) for the gain and scale the controller
  /// was made with; it stays fixed when gain and mapping change while running (the body's coupling
  /// keeps its tuning, B_s = 2 zeta sqrt(K_s m)), so a new gain or scale changes what the hand feels.
  double bodyStiffness() const { return ks_; }
  /// The factor on K_d and B_d (and the feed-forward's gain) since construction: (g s) / (g0 s0).
  double feltFactor() const { return settings_.gain * mapping_.scale / reference_; }
  /// Changed while running (the next step uses them). gain >= 0 (0: nothing is felt).
  void setGain(double gain) { settings_.gain = gain; }
  double gain() const { return settings_.gain; }
  /// A new mapping; a held body's rest offset moves with the target so that the body is not yanked.
  void setMapping(const Mapping& m);
  /// The paper's mode on or off (Smoothing::RollingAverage).
  void setForceAsFeedForward(bool on) { settings_.force_as_feed_forward = on; }
  const Mapping& mapping() const { return mapping_; }
  /// The target (scene) of the last update.
  const Eigen::Vector3d& target() const { return target_; }
  /// The grasp point on the held body in the world for these states (the target when none is held) (unit: m).
  Eigen::Vector3d graspWorld(const std::vector<rigid::BodyState>& states) const {
    if (held_ < 0) return target_;
    const std::size_t b = candidates_[static_cast<std::size_t>(held_)].body;
    return b < states.size() ? states[b].toWorld(grasp_) : target_;
  }

 private:
  Mapping mapping_;
  GrabSettings settings_;
  double ks_ = 0;          // body spring K_s (unit: N/m), fixed at construction
  double reference_ = 1;   // g0 s0 at construction (unit: 1)
  Eigen::Vector3d device_x_ = Eigen::Vector3d::Zero();  // last device position (unit: m)
  std::vector<Grabbable> candidates_;
  long held_ = -1;                                   // index into candidates_
  Eigen::Vector3d grasp_ = Eigen::Vector3d::Zero();  // grasp point, body frame (unit: m)
  Eigen::Vector3d rest_ = Eigen::Vector3d::Zero();   // target - grasp point at the grab, world (unit: m)
  Eigen::Quaterniond q_grab_ = Eigen::Quaterniond::Identity();  // body -> world at the grab
  Eigen::Vector3d target_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d coupling_ = Eigen::Vector3d::Zero();  // last F_s on the body, scene (unit: N)
  bool was_pressed_ = false;
};

}  // namespace sph::haptics
