// Rigid bodies on the host: shapes to closed meshes, mass properties by polyhedral integration,
// boundary-particle sampling of the surface, and the rigid-body integrator.
//
//   RigidBodySpec ──shapeMesh──► TriMesh (body frame) ──massProperties──► m, centre, inertia
//                                   │
//                                   └──sampleSurface──► particles (body frame, about the centre of mass)
//                                                       + Akinci 2012 volumes (model.cpp)
//
// Frames: a body's mesh and particles are stored in its body frame with the origin at the centre
// of mass; the state holds the world position x of the centre of mass and the orientation q
// (body -> world), so a body point p is at x + R(q) p in the world.
#pragma once

#include <cstdint>

#include "core/mesh.h"
#include "core/scene_spec.h"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <vector>

namespace sph::rigid {

/// A body's generalised velocity (v, w) or wrench (F, T), and matrices on them.
using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

// --- Shapes ----------------------------------------------------------------------------------

/// A surface of revolution about the z axis from a profile of (r, z) points (r >= 0). The profile
/// must start and end on the axis (r = 0) to close the surface, and run with the solid on its
/// left when r points right and z up (a sphere: from the south pole up to the north pole). Points
/// on the axis become one vertex; others become rings of `segments` vertices. The triangles face
/// outward (counter-clockwise seen from outside).
TriMesh lathe(const std::vector<Eigen::Vector2d>& profile, int segments);

/// Segments around a circle of radius r so that chords are at most `edge` long (at least 16).
int segmentsFor(double radius, double edge);

/// Closed, outward-facing meshes centred on the origin; curved ones have edges of about `edge`
/// (unit: m) along their circles; the sphere has a small flat polygon at each pole (so that it rests
/// on the floor instead of balancing on a vertex). The cylinder and capsule axes are z; `height` is the cylinder's
/// length and the distance between the capsule's cap centres.
TriMesh sphereMesh(double radius, double edge);
TriMesh boxMesh(const Eigen::Vector3d& size);
TriMesh cylinderMesh(double radius, double height, double edge);
TriMesh capsuleMesh(double radius, double height, double edge);

/// The body's shape in its own frame, scaled: the primitive at a resolution tied to `spacing`
/// (edges of spacing / 2 along curves), or the loaded mesh of shape mesh (spec.mesh_data).
TriMesh shapeMesh(const RigidBodySpec& spec, double spacing);

// --- Mass properties -------------------------------------------------------------------------

/// Mass properties of the solid enclosed by a closed, outward-facing mesh, at unit density.
struct MassProperties {
  double volume = 0;                                    ///< (unit: m^3)
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();     ///< centre of mass (unit: m)
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();    ///< about the centre, per unit density (unit: m^5)
};

/// Polyhedral integration (the divergence theorem as in Mirtich 1996, here as a sum of signed
/// tetrahedra from a reference point): exact for the polyhedron, in double precision.
MassProperties massProperties(const TriMesh& mesh);

// --- Sampling --------------------------------------------------------------------------------

/// Boundary particles on the surface: a Poisson-disk set with minimum distance 0.75 * spacing,
/// chosen greedily (in triangle order, so deterministic) from candidates 0.2 * spacing apart on
/// every triangle. Every point of the surface is then within 0.95 * spacing of a particle; the
/// largest hole on a ball of R / dx 5 is 0.67 spacing in radius. At 0.8 * spacing (until session
/// 35) it was 0.70, and fluid went through such holes into a held ball (tests/test_rigid.cpp, "no
/// water leaks into a held ball"; docs/forces.md, sessions 34-35).
/// With `normals`, also the outward unit normal at each particle (the triangle's; at a mesh
/// vertex, the area-weighted mean of its triangles').
std::vector<Eigen::Vector3f> sampleSurface(const TriMesh& mesh, double spacing,
                                           std::vector<Eigen::Vector3f>* normals = nullptr);

// --- Dynamics --------------------------------------------------------------------------------

enum class BodyKind { Static, Kinematic, Dynamic };

/// One body, compiled (part of the Model; fixed during a run).
struct RigidBody {
  RigidBodySpec spec;                     ///< as written (mesh_data cleared)
  BodyKind kind = BodyKind::Static;
  TriMesh mesh;                           ///< body frame, origin at the centre of mass (unit: m)
  double mass = 0;                        ///< (unit: kg)
  double volume = 0;                      ///< (unit: m^3)
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();      ///< body frame, about the centre (unit: kg m^2)
  Eigen::Matrix3d inv_inertia = Eigen::Matrix3d::Zero();  ///< its inverse (unit: 1/(kg m^2))
  Eigen::Vector3d origin_offset = Eigen::Vector3d::Zero(); ///< scene origin of the shape in the body frame (unit: m)
  std::vector<Eigen::Vector3f> particles; ///< boundary particles, body frame (unit: m)
  std::vector<Eigen::Vector3f> normals;   ///< each particle's outward surface normal, body frame (unit: 1)
  std::vector<float> volumes;             ///< Akinci 2012 volume / dx^3 of each particle (unit: 1)
};

/// The moving part of a body (the Simulation's; read by outputs and, later, haptics).
struct BodyState {
  Eigen::Vector3d x = Eigen::Vector3d::Zero();   ///< centre of mass, world (unit: m)
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();  ///< body -> world, unit length
  Eigen::Vector3d v = Eigen::Vector3d::Zero();   ///< velocity of the centre of mass (unit: m/s)
  Eigen::Vector3d L = Eigen::Vector3d::Zero();   ///< angular momentum about the centre, world (unit: kg m^2/s)
  Eigen::Vector3d w = Eigen::Vector3d::Zero();   ///< angular velocity, world (unit: rad/s)
  Eigen::Vector3d fluid_force = Eigen::Vector3d::Zero();   ///< from the fluid, this step (unit: N)
  Eigen::Vector3d fluid_torque = Eigen::Vector3d::Zero();  ///< about the centre of mass (unit: N m)
  Eigen::Vector3d contact_force = Eigen::Vector3d::Zero(); ///< from contacts, this step (unit: N)
  Eigen::Vector3d contact_torque = Eigen::Vector3d::Zero();///< (unit: N m)
  Eigen::Vector3d external_force = Eigen::Vector3d::Zero(); ///< from outside (a haptic grab), this step (unit: N)
  Eigen::Vector3d external_torque = Eigen::Vector3d::Zero();///< about the centre of mass (unit: N m)
  /// How the external wrench answers the body's own motion in this step: the wrench at the step's
  /// end is (external_force, external_torque) - D (u' - u), u = (v, w), so that integrateVelocity takes
  /// it implicitly, (M + dt D) du = dt W (a haptic grab's spring-damper, haptics/grab.h: stable at any
  /// step for any stiffness). Symmetric positive semi-definite; zero (the default): the wrench is
  /// explicit. Once the body has moved, external_force and external_torque hold the wrench that acted,
  /// W - D du (unit: blocks N s/m, N s, N s, N m s).
  Matrix6d external_damping = Matrix6d::Zero();
  /// the centre's acceleration over the last step from the forces, (v after - v before) / dt before
  /// the contact impulses (the fictitious mass's own a_n: at rest on a floor it tends to the
  /// forces' F / m, so the fictitious force fades there); zero while held (the fictitious mass of
  /// integrateVelocity reads it) (unit: m/s^2)
  Eigen::Vector3d accel = Eigen::Vector3d::Zero();
  /// DFSPH's fictitious-mass force M (a_{n-1} - a_n) of this step (fictitiousForce), part of
  /// fluid_force once the body has moved (Simulation::integrateBodies): the added-mass reaction
  /// the lagged solve has not answered yet; its opposite went to the fluid (unit: N)
  Eigen::Vector3d added_mass_force = Eigen::Vector3d::Zero();
  /// the rate of the angular momentum over the last step from the torques, (L after - L before) / dt
  /// before the contact impulses, I alpha: the rotational twin of `accel` for the fictitious inertia
  /// (integrateVelocity); zero while held (unit: N m)
  Eigen::Vector3d torque_rate = Eigen::Vector3d::Zero();
  /// DFSPH's fictitious-inertia torque (M / (m + M)) (torque_rate - T_n) of this step (fictitiousTorque),
  /// part of fluid_torque once the body has moved; unlike the force, no reaction goes to the fluid (its
  /// sum over any run telescopes to one step's worth: docs/forces.md, session 16) (unit: N m)
  Eigen::Vector3d added_mass_torque = Eigen::Vector3d::Zero();
  /// A body-frame point in the world.
  Eigen::Vector3d toWorld(const Eigen::Vector3d& p) const { return x + q * p; }
};

/// FNV-1a hash of the bodies' poses and velocities (x, q, v, L in double precision), continuing
/// from `seed`: the body part of Simulation::stateHash() and the per-step hash of a haptic recording.
uint64_t hashStates(const std::vector<BodyState>& states, uint64_t seed = 1469598103934665603ull);

/// The initial state of a compiled body (its scene pose and velocities).
BodyState initialState(const RigidBody& body);

/// World-frame inertia R I R^T and its inverse.
Eigen::Matrix3d worldInverseInertia(const RigidBody& body, const Eigen::Quaterniond& q);

/// A body's step is split so that contacts (core/contact.h) act between the two halves:
///     integrateVelocity (all bodies) -> ContactSolver::solve -> integratePosition (all bodies)
///     -> ContactSolver::correctPositions.
/// Dynamic: symplectic (semi-implicit) Euler on momenta,
///     v += dt F / m,   L += dt tau,   w = R I^-1 R^T L,   q <- exp(dt w / 2) q (renormalised),   x += dt v,
/// with gravity g (unit: m/s^2) and the fluid force in the state, so a free fall gives
/// x_n = x0 + v0 t + g t^2 / 2 + g t dt / 2 (first order in dt), and without torque L is conserved
/// exactly. Kinematic with a constant motion: the scripted velocities, integrated exactly;
/// keyframed: nothing here (the pose is a function of time: followKeyframes, called by the
/// Simulation). Static: nothing moves.
/// integrateVelocity: the momenta of a dynamic body (nothing for the others). With a fictitious
/// mass M > 0 (DFSPH's fluid.dfsph.body_added_mass; Simulation::integrateBodies) the translation
/// takes Baek & Karniadakis' (2012, J. Comput. Phys. 231, 629, eq. 9) stabilised update
///     (m + M) a_n = F_n + M a_{n-1},   v += dt a_n,   a_{n-1} = s.accel (the last step's),
/// the same motion as v += dt F / m wherever the acceleration is steady, but stable for a body
/// lighter than the liquid's lagged reaction (the added-mass instability of a staggered coupling).
/// With an external damping D (BodyState::external_damping) the whole update is one 6x6 solve,
///     (diag((m + M) 1, (1 + M / m) I_w) + dt D) du = dt (F_n + M a_{n-1}, T_n + (M / m) tau_{n-1}),
/// (velocityChange; with D = 0 the same as above), and the external wrench that acted is kept.
void integrateVelocity(const RigidBody& body, BodyState& s, const Eigen::Vector3d& g, double dt,
                       double fictitious_mass = 0.0);
/// The change du = (dv, dw) of a dynamic body's velocities that integrateVelocity makes (zero for the
/// others), before the contacts' impulses.
Vector6d velocityChange(const RigidBody& body, const BodyState& s, const Eigen::Vector3d& g, double dt,
                        double fictitious_mass = 0.0);
/// A body's mobility over a step of dt: N = (M + dt D)^-1, M = diag(m 1, I_w), D its external damping
/// ((a, alpha) = N (F, T) for a wrench (F, T); N = diag(1 / m, I_w^-1) without damping). What DFSPH's
/// strong coupling moves the body with inside the solves (Simulation::bodyResponse).
Matrix6d mobility(const RigidBody& body, const BodyState& s, double dt);
/// The fictitious mass's own force on a dynamic body this step (zero for the others, and for M = 0):
///     F_M = M (a_{n-1} - a_n) = M (m a_{n-1} - F_n) / (m + M),
/// a_n = (F_n + M a_{n-1}) / (m + M) as integrateVelocity moves it, F_n = m g + fluid_force +
/// external_force. integrateVelocity's update is v += dt (F_n + F_M) / m, so the fluid must take
/// -F_M dt for the total momentum to be conserved (Simulation::addedMassReaction) (unit: N).
/// With an external damping, a_n is velocityChange's (dt: the step, needed then).
Eigen::Vector3d fictitiousForce(const RigidBody& body, const BodyState& s, const Eigen::Vector3d& g,
                                double fictitious_mass, double dt = 0.0);
/// The rotational twin (session 16): a fictitious inertia J = (M / m) I, the body's own inertia
/// tensor scaled as M scales m (the inertia the body would have at the density C rho0), so that
///     (I + J) alpha_n = T_n + J alpha_{n-1}  <=>  dL = dt (m T_n + M tau_{n-1}) / (m + M),
/// tau_{n-1} = s.torque_rate = I alpha_{n-1}, T_n = fluid_torque + external_torque. Without it a
/// light body turning in the fluid (a wooden spoon held by its end) swings with period 2 and grows,
/// as the translation did. Its torque T_J = M (tau_{n-1} - T_n) / (m + M) (unit: N m).
/// With an external damping, T_J = (M / m) (tau_{n-1} - I_w dw / dt), dw velocityChange's.
Eigen::Vector3d fictitiousTorque(const RigidBody& body, const BodyState& s, double fictitious_mass,
                                 const Eigen::Vector3d& g = Eigen::Vector3d::Zero(), double dt = 0.0);
/// integratePosition: the pose from the velocities. With `walls` (the domain; null = none), a
/// dynamic body left inside a closed wall (by rounding or unresolved contacts) is moved out along
/// the wall's normal, velocities untouched.
void integratePosition(const RigidBody& body, BodyState& s, double dt, const DomainSpec* walls = nullptr);

// --- Keyframed motion -------------------------------------------------------------------------
//
// A keyframed kinematic body follows a C1 path through its keys (poses of the body origin):
//  - position: cubic Hermite per interval, with the finite-difference tangent at interior keys
//        m_k = (h1 d0 + h0 d1) / (h0 + h1),  d0 = (p_k - p_k-1) / h0,  d1 = (p_k+1 - p_k) / h1
//    (h0, h1 the intervals before and after key k; Catmull-Rom when the keys are evenly spaced;
//    exact for a parabola), and m = 0 at the first and last keys, so that the velocity is
//    continuous also where the body starts from and comes back to rest;
//  - orientation: the C1 quaternion Hermite curve of Kim, Kim & Shin (1995, "A general construction
//    scheme for unit quaternion curves with simple high order derivatives", SIGGRAPH), on the
//    interval [t_a, t_b] of length T, u = (t - t_a) / T:
//        q(u) = q_a exp(b1(u) th1) exp(b2(u) th2) exp(b3(u) th3),
//        b1 = 1 - (1 - u)^3,  b2 = 3 u^2 - 2 u^3,  b3 = u^3  (cumulative cubic Bernstein basis),
//        th1 = W_a T / 3,  th3 = W_b T / 3,  th2 = log(exp(-th1) q_a^-1 q_b exp(-th3)),
//    where exp/log map rotation vectors to unit quaternions and back (short way) and W_k is the
//    body-frame angular velocity at key k, from the same finite differences of the relative
//    rotations log(q_k-1^-1 q_k), 0 at the first and last keys. The angular velocity is continuous
//    at the keys; a constant turn about one axis through evenly spaced keys comes out uniform.
//  - velocity and angular velocity are the analytic derivatives of the two curves:
//        w = R(q_a) [b1' th1 + R(e1) b2' th2 + R(e1 e2) b3' th3] / T,  e_i = exp(b_i th_i).
// Before the first key the body holds the first pose, after the last key the last (v = w = 0).

/// The pose of the body origin on a keyframed path and its time derivatives.
struct PathSample {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< body origin, world (unit: m)
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();  ///< d position / dt (unit: m/s)
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity(); ///< body -> world
  Eigen::Vector3d w = Eigen::Vector3d::Zero();         ///< angular velocity, world (unit: rad/s)
};

/// The path through `keys` (at least one, times strictly increasing) at time t (unit: s).
PathSample samplePath(const std::vector<KeyframeSpec>& keys, double t);

/// Sets x, q, v and w of a keyframed kinematic body to its path at time t (unit: s): the centre of
/// mass is x = p - R o (o = origin_offset), moving at v = dp/dt - w x R o. Exact at every t (no
/// integration, no drift).
void followKeyframes(const RigidBody& body, BodyState& s, double t);

/// The body's mesh in world coordinates (for output).
TriMesh worldMesh(const RigidBody& body, const BodyState& s);

}  // namespace sph::rigid
