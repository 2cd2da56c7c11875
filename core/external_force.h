// External forces on rigid bodies, from outside the simulation: the interface through which a
// grabbed body gets the coupling spring of a haptic device (haptics/ implements it, cli/ wires it).
// core/ declares it and calls it once per step (Stage::Haptics) before the bodies are integrated.
#pragma once

#include "core/rigid.h"

#include <Eigen/Core>

#include <vector>

namespace sph {

/// A force through the centre of mass and a torque about it, world frame, and how they answer the
/// body's own motion in the step: at the step's end the wrench is (force, torque) - damping (u' - u),
/// u = (v, w) the body's velocities, which the body's integration takes implicitly
/// (rigid::BodyState::external_damping; a stiff spring-damper on a light body is then stable at any
/// step). Zero damping: an explicit wrench.
struct BodyWrench {
  Eigen::Vector3d force = Eigen::Vector3d::Zero();   ///< (unit: N)
  Eigen::Vector3d torque = Eigen::Vector3d::Zero();  ///< (unit: N m)
  rigid::Matrix6d damping = rigid::Matrix6d::Zero(); ///< symmetric, positive semi-definite (unit: N s/m, N s, N m s)
};

class ExternalForceSource {
 public:
  virtual ~ExternalForceSource() = default;
  /// Called once per time step, at its start, before the fluid's solves (so that DFSPH's strong body
  /// coupling moves the bodies inside them under this wrench; session 25): `time` is the step's start,
  /// `dt` its length (unit: s); `states` the bodies in Model::bodies order, at the step's start (their
  /// fluid forces are the last step's: a source reads only poses and velocities). Writes one wrench
  /// per body into `out` (already sized, zeroed).
  virtual void apply(double time, double dt, const std::vector<rigid::RigidBody>& bodies,
                     const std::vector<rigid::BodyState>& states, std::vector<BodyWrench>& out) = 0;
};

}  // namespace sph
