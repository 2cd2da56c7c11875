// Contact between rigid bodies, and of bodies with the domain's closed walls, on the host in double.
//
// Method: speculative contacts solved by sequential impulses (Catto, "Iterative Dynamics with
// Temporal Coherence", GDC 2005, and "Modeling and Solving Constraints", GDC 2009; the speculative
// contacts of Box2D: a contact whose gap would close within the step may approach by at most
// gap / dt, so a body lands on a surface without passing it and a resting one stays put).
//
//   per step:  velocities (gravity, fluid)          rigid::integrateVelocity
//              find contacts ─► solve impulses      ContactSolver::solve       (this file)
//              positions                            rigid::integratePosition
//              remove penetration (split impulses)  ContactSolver::correctPositions
//
// Contact points are mesh vertices: each vertex of body A near body B is tested against B's closed
// mesh (closest point on B's triangles through a grid built once in B's frame, SurfaceIndex), and
// each vertex of B against A; every vertex near a closed wall against the wall. A point's signed
// gap is its distance to the surface, negative inside; inside or outside comes from the angle-
// weighted pseudo-normal of the closest feature (Baerentzen & Aanaes 2005), which is exact for a
// closed, consistently wound mesh. The contact normal is the face normal when the closest point is
// inside a triangle, else the direction from the closest point to the vertex.
//
// All contacts of a step (walls and body pairs) are solved together, each in turn in a fixed
// order (deterministic), with accumulated, clamped impulses: the normal impulse >= 0 and the
// friction impulse within the Coulomb bound mu * normal impulse. The sweeps go on until none
// changes a contact's velocity by more than 1e-4 |g| dt, at most 128: a ball's ring of vertices
// on a faceted bowl converges slowly, and fewer sweeps (16, 32) left it rocking by millimetres.
// Restitution acts on impact only (approach faster than 2 |g| dt, which resting contact never
// reaches). Material mixing as in Box2D: mu = sqrt(mu_a mu_b), e = max(e_a, e_b); a wall takes
// the body's own values. Static and kinematic bodies have infinite mass (kinematic ones move at
// their scripted velocity and push, but are not pushed).
//
// Penetration (from rounding, unconverged sweeps or rotation within a step) is removed by split
// impulses (Catto 2009): a second, normal-only solve on pseudo-velocities that move the bodies'
// positions and are then discarded, so it adds no momentum or kinetic energy (no Baumgarte term
// in the velocity solve).
//
// Limits: vertices only (an edge of A crossing an edge of B between vertices is not seen: meshes
// with long edges, such as boxes, touch corner to face, not edge to edge); the signed distance
// trusts the nearest surface, so a vertex pushed more than half a body's thickness through it
// would be pushed out the far side.
#pragma once

#include "core/mesh_distance.h"
#include "core/rigid.h"
#include "core/scene_spec.h"

#include <Eigen/Core>

#include <cstdint>
#include <memory>
#include <vector>

namespace sph::rigid {

/// One contact point between body a and body b (or a wall), in world coordinates.
struct Contact {
  int a = 0;                                          ///< the body pushed along +n (an index into the bodies)
  int b = -1;                                         ///< the body pushed along -n; -1: a wall
  int other = -1;                                     ///< b, or for a wall -1 - (2 axis + side)
  uint32_t vertex = 0;                                ///< the vertex of a's mesh
  Eigen::Vector3d point = Eigen::Vector3d::Zero();    ///< the vertex (unit: m)
  Eigen::Vector3d ra = Eigen::Vector3d::Zero();       ///< arm: point - centre of mass of a (unit: m)
  Eigen::Vector3d rb = Eigen::Vector3d::Zero();       ///< arm: point - centre of mass of b (unit: m)
  Eigen::Vector3d n = Eigen::Vector3d::UnitZ();       ///< unit normal, from b towards a
  double gap = 0;                                     ///< signed distance along n, negative inside (unit: m)
  double target = 0;                                  ///< lowest allowed normal relative velocity (unit: m/s)
  double kn = 0;                                      ///< inverse effective mass along n (unit: 1/kg)
  double mu = 0;                                      ///< friction coefficient (unit: 1)
  double lambda = 0;                                  ///< accumulated normal impulse (unit: N s)
  Eigen::Vector3d friction = Eigen::Vector3d::Zero(); ///< accumulated tangential impulse (unit: N s)
  double push = 0;                                    ///< accumulated split (position) impulse (unit: N s)
};

class ContactSolver {
 public:
  /// Builds each body's contact geometry (a surface grid and pseudo-normals in its frame). From
  /// the particle `spacing` (unit: m): contacts are kept within dx/4 beyond what the bodies can
  /// travel in a step (so a penetration up to dx/4 is still seen and removed), and penetration
  /// below dx/1000 (rounding, not geometry) is left alone by the position correction.
  ContactSolver(const std::vector<RigidBody>& bodies, double spacing);
  ~ContactSolver();
  ContactSolver(const ContactSolver&) = delete;
  ContactSolver& operator=(const ContactSolver&) = delete;

  /// Finds the contacts of the dynamic bodies with the closed walls (`walls`; null: none), with
  /// each other and with static and kinematic bodies, and solves them: changes v, L and w of the
  /// dynamic bodies and records every body's contact force and torque (impulse / dt; the reaction
  /// on static and kinematic bodies too). Velocities must already include this step's gravity and
  /// fluid force. Returns the number of contacts.
  int solve(const std::vector<RigidBody>& bodies, std::vector<BodyState>& states, const DomainSpec* walls,
            const Eigen::Vector3d& g, double dt);

  /// After the position update: moves dynamic bodies out of the penetrations of this step's
  /// contacts (split impulses, positions only).
  void correctPositions(const std::vector<RigidBody>& bodies, std::vector<BodyState>& states, double dt);

  /// The contacts of the last solve (for tests and diagnostics).
  const std::vector<Contact>& contacts() const { return contacts_; }

 private:
  struct Shape;
  std::vector<std::unique_ptr<Shape>> shapes_;  // one per body
  std::vector<Contact> contacts_;
  std::vector<Eigen::Vector3d> push_v_, push_w_;  // split-impulse pseudo-velocities per body (unit: m/s, rad/s)
  double slop_ = 0;    // (unit: m)
  double margin_ = 0;  // (unit: m)
};

}  // namespace sph::rigid
