#include "core/contact.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

namespace sph::rigid {

// ---------------------------------------------------------------------------------------------
// Contact geometry of one body, in its frame
// ---------------------------------------------------------------------------------------------

struct ContactSolver::Shape {
  explicit Shape(const TriMesh& mesh) : surface(mesh) {}
  ClosedSurface surface;                                // closest points and pseudo-normals (core/mesh_distance.h)
  std::vector<Eigen::Vector3d> vertices;                // the contact points (unit: m)
  double radius = 0;                                    // bounding sphere about the centre of mass (unit: m)
};

ContactSolver::ContactSolver(const std::vector<RigidBody>& bodies, double spacing)
    : slop_(1e-3 * spacing), margin_(0.25 * spacing) {
  for (const RigidBody& body : bodies) {
    auto shape = std::make_unique<Shape>(body.mesh);
    for (const auto& p : body.mesh.positions) {
      shape->vertices.push_back(p.cast<double>());
      shape->radius = std::max(shape->radius, shape->vertices.back().norm());
    }
    shapes_.push_back(std::move(shape));
  }
}

ContactSolver::~ContactSolver() = default;

// ---------------------------------------------------------------------------------------------
// Solving
// ---------------------------------------------------------------------------------------------

namespace {

/// A body as the solver sees it: inverse mass and world inverse inertia (zero for static and
/// kinematic bodies: infinite mass), and its state.
struct Solid {
  BodyState* s = nullptr;
  double inv_mass = 0;
  Eigen::Matrix3d inv_inertia = Eigen::Matrix3d::Zero();
  Eigen::Vector3d velocityAt(const Eigen::Vector3d& r) const { return s->v + s->w.cross(r); }
  /// Impulse P at arm r: momentum and angular momentum (dynamic bodies only).
  void apply(const Eigen::Vector3d& r, const Eigen::Vector3d& P) const {
    if (inv_mass == 0) return;
    s->v += inv_mass * P;
    s->L += r.cross(P);
    s->w = inv_inertia * s->L;
  }
  /// Inverse effective mass along unit d at arm r: 1/m + (r x d) . I^-1 (r x d).
  double inverseMass(const Eigen::Vector3d& r, const Eigen::Vector3d& d) const {
    const Eigen::Vector3d rd = r.cross(d);
    return inv_mass + rd.dot(inv_inertia * rd);
  }
};

constexpr int kMaxSweeps = 128;            // sequential-impulse sweeps over all contacts per step, at most
constexpr double kVelocityTolerance = 1e-4;  // converged: no contact's velocity changed by more than this share of |g| dt
constexpr double kPositionFraction = 0.5;  // share of the penetration the split impulses remove per step

}  // namespace

int ContactSolver::solve(const std::vector<RigidBody>& bodies, std::vector<BodyState>& states, const DomainSpec* walls,
                         const Eigen::Vector3d& g, double dt) {
  contacts_.clear();
  const int n = static_cast<int>(bodies.size());
  auto dynamic = [&](int i) { return bodies[static_cast<std::size_t>(i)].kind == BodyKind::Dynamic; };
  std::vector<Solid> solid(static_cast<std::size_t>(n));
  std::vector<Eigen::Matrix3d> R(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const RigidBody& body = bodies[static_cast<std::size_t>(i)];
    BodyState& s = states[static_cast<std::size_t>(i)];
    s.contact_force.setZero();
    s.contact_torque.setZero();
    solid[static_cast<std::size_t>(i)].s = &s;
    R[static_cast<std::size_t>(i)] = s.q.toRotationMatrix();
    if (body.kind == BodyKind::Dynamic) {
      solid[static_cast<std::size_t>(i)].inv_mass = 1.0 / body.mass;
      solid[static_cast<std::size_t>(i)].inv_inertia = worldInverseInertia(body, s.q);
    }
  }
  // How far any point of body i may travel this step: its speed bound (the velocities already
  // hold this step's gravity; a push from another contact may add about as much again) times dt.
  std::vector<double> travel(static_cast<std::size_t>(n), 0.0);
  for (int i = 0; i < n; ++i) {
    const BodyState& s = states[static_cast<std::size_t>(i)];
    const double speed = s.v.norm() + s.w.norm() * shapes_[static_cast<std::size_t>(i)]->radius;
    travel[static_cast<std::size_t>(i)] = dt * (speed + (dynamic(i) ? 2.0 * g.norm() * dt : 0.0));
  }
  // A contact for every point that may touch within the step: a gap up to twice the travel of
  // both bodies (a push from another contact may speed them up), or a penetration up to the
  // margin (dx/4, so a contact left penetrating is still seen and pushed out). One that will not
  // close its gap only limits the approach to gap / dt, which the bodies do not reach; leaving out
  // the ones farther away keeps the sweeps short.
  auto consider = [&](Contact c, double travel_sum) {
    if (c.gap > 2.0 * travel_sum + slop_) return;
    c.ra = c.point - states[static_cast<std::size_t>(c.a)].x;
    if (c.b >= 0) c.rb = c.point - states[static_cast<std::size_t>(c.b)].x;
    contacts_.push_back(c);
  };

  // Walls: each vertex of a dynamic body against each closed wall of the domain box.
  if (walls) {
    for (int i = 0; i < n; ++i) {
      if (!dynamic(i)) continue;
      const BodyState& s = states[static_cast<std::size_t>(i)];
      const double reach = 2.0 * travel[static_cast<std::size_t>(i)] + margin_;
      for (int ax = 0; ax < 3; ++ax)
        for (int side = 0; side < 2; ++side) {
          if (!walls->closed[static_cast<std::size_t>(2 * ax + side)]) continue;
          Contact c;
          c.a = i;
          c.b = -1;
          c.other = -1 - (2 * ax + side);
          c.n = (side == 0 ? 1.0 : -1.0) * Eigen::Vector3d::Unit(ax);
          c.mu = bodies[static_cast<std::size_t>(i)].spec.friction;
          const auto& vertices = shapes_[static_cast<std::size_t>(i)]->vertices;
          for (c.vertex = 0; c.vertex < vertices.size(); ++c.vertex) {
            c.point = s.x + R[static_cast<std::size_t>(i)] * vertices[c.vertex];
            c.gap = side == 0 ? c.point[ax] - walls->min[ax] : walls->max[ax] - c.point[ax];
            if (c.gap <= reach) consider(c, travel[static_cast<std::size_t>(i)]);
          }
        }
    }
  }

  // Body pairs with a dynamic body whose bounding spheres come within reach this step: the
  // vertices of each against the other's mesh.
  auto vertexContacts = [&](int i, int j, double reach) {
    const Shape& sj = *shapes_[static_cast<std::size_t>(j)];
    const BodyState& si = states[static_cast<std::size_t>(i)];
    const BodyState& s_j = states[static_cast<std::size_t>(j)];
    const Eigen::Matrix3d& Ri = R[static_cast<std::size_t>(i)];
    const Eigen::Matrix3d& Rj = R[static_cast<std::size_t>(j)];
    Contact c;
    c.a = i;
    c.b = j;
    c.other = j;
    c.mu = std::sqrt(bodies[static_cast<std::size_t>(i)].spec.friction * bodies[static_cast<std::size_t>(j)].spec.friction);
    const auto& vertices = shapes_[static_cast<std::size_t>(i)]->vertices;
    for (c.vertex = 0; c.vertex < vertices.size(); ++c.vertex) {
      const Eigen::Vector3d p = si.x + Ri * vertices[c.vertex];
      if ((p - s_j.x).squaredNorm() > (sj.radius + reach) * (sj.radius + reach)) continue;
      const Eigen::Vector3d pj = Rj.transpose() * (p - s_j.x);  // in j's frame
      const SurfaceIndex::Nearest near = sj.surface.index().nearest(pj, reach);
      if (!std::isfinite(near.distance)) continue;
      // Normal and signed gap, in j's frame: inside a triangle, its normal; at an edge or a
      // vertex, along the offset from the closest point (the pseudo-normal when it vanishes).
      const Eigen::Vector3d offset = pj - near.point;
      const Eigen::Vector3d pseudo = sj.surface.pseudoNormal(near.triangle, near.feature);
      Eigen::Vector3d normal;
      if (near.feature == TriangleFeature::Face) {
        normal = pseudo;
        c.gap = normal.dot(offset);
      } else {
        const double sign = pseudo.dot(offset) >= 0.0 ? 1.0 : -1.0;
        normal = near.distance > 1e-9 ? Eigen::Vector3d(sign * offset / near.distance) : pseudo;
        c.gap = sign * near.distance;
      }
      c.point = p;
      c.n = Rj * normal;
      consider(c, travel[static_cast<std::size_t>(i)] + travel[static_cast<std::size_t>(j)]);
    }
  };
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) {
      if (!dynamic(i) && !dynamic(j)) continue;
      const BodyState& si = states[static_cast<std::size_t>(i)];
      const BodyState& sj = states[static_cast<std::size_t>(j)];
      const double ri = shapes_[static_cast<std::size_t>(i)]->radius, rj = shapes_[static_cast<std::size_t>(j)]->radius;
      const double reach = 2.0 * (travel[static_cast<std::size_t>(i)] + travel[static_cast<std::size_t>(j)]) + margin_;
      if ((si.x - sj.x).norm() > ri + rj + reach) continue;
      vertexContacts(i, j, reach);
      vertexContacts(j, i, reach);
    }

  // Targets: a gap may close within the step but not be passed; touching or inside: no approach.
  // On impact (a gap that closes within this step, approached faster than gravity alone brings in
  // two steps), bounce with the restitution.
  const double v_bounce = 2.0 * g.norm() * dt;
  auto relativeNormal = [&](const Contact& c) -> Eigen::Vector3d {
    Eigen::Vector3d vrel = solid[static_cast<std::size_t>(c.a)].velocityAt(c.ra);
    if (c.b >= 0) vrel -= solid[static_cast<std::size_t>(c.b)].velocityAt(c.rb);
    return vrel;
  };
  for (Contact& c : contacts_) {
    const double vn = c.n.dot(relativeNormal(c));
    double e = bodies[static_cast<std::size_t>(c.a)].spec.restitution;
    if (c.b >= 0) e = std::max(e, bodies[static_cast<std::size_t>(c.b)].spec.restitution);
    c.target = c.gap > 0.0 ? -c.gap / dt : 0.0;
    if (-vn > v_bounce && c.gap + dt * vn <= 0.0) c.target = std::max(c.target, -e * vn);  // hits this step
  }

  // Sequential impulses (Catto 2005): each contact in turn, in a fixed order, sweep after sweep;
  // accumulated impulses clamped (normal >= 0, friction within mu * normal).
  BodyState wall_state;  // a wall: infinite mass, at rest
  Solid none;
  none.s = &wall_state;
  // Sweeps until no sweep changes the velocity at any contact by more than a ten-thousandth of
  // what gravity adds in a step (|g| dt), or kMaxSweeps: redundant contacts (a ball's flat bottom
  // on a facet, a chain of bodies down to the floor) converge slowly, and an unconverged solve
  // leaves a residual velocity that rocks a resting body. Contacts that carry no impulse and
  // stay clear of their target are cheap: friction is skipped while the normal impulse is zero.
  // (Warm starting from the last step's impulses was tried and removed: with speculative
  // contacts it lagged the rocking of a ball on a box and fed it.)
  const double settled = kVelocityTolerance * std::max(g.norm() * dt, 1e-12);
  for (Contact& c : contacts_)
    c.kn = solid[static_cast<std::size_t>(c.a)].inverseMass(c.ra, c.n) +
           (c.b >= 0 ? solid[static_cast<std::size_t>(c.b)].inverseMass(c.rb, c.n) : 0.0);
  for (int sweep = 0; sweep < kMaxSweeps; ++sweep) {
    double change = 0;  // the largest velocity change at a contact in this sweep (unit: m/s)
    for (Contact& c : contacts_) {
      const Solid& A = solid[static_cast<std::size_t>(c.a)];
      const Solid& B = c.b >= 0 ? solid[static_cast<std::size_t>(c.b)] : none;
      // Normal: push apart only.
      const double vn = c.n.dot(relativeNormal(c));
      const double lambda = std::max(c.lambda + (c.target - vn) / c.kn, 0.0);
      if (lambda != c.lambda) {
        const Eigen::Vector3d dP = (lambda - c.lambda) * c.n;
        A.apply(c.ra, dP);
        B.apply(c.rb, -dP);
        change = std::max(change, std::abs(lambda - c.lambda) * c.kn);
        c.lambda = lambda;
      }
      // Friction: stop the sliding, within the Coulomb cone |P_t| <= mu P_n.
      if (c.lambda == 0.0 && c.friction.isZero()) continue;
      const Eigen::Vector3d vrel = relativeNormal(c);
      const Eigen::Vector3d vt = vrel - c.n.dot(vrel) * c.n;
      const double slide = vt.norm();
      if (slide <= 0.0) continue;
      const Eigen::Vector3d t = vt / slide;
      const double kt = A.inverseMass(c.ra, t) + B.inverseMass(c.rb, t);
      Eigen::Vector3d f = c.friction - slide / kt * t;
      const double limit = c.mu * c.lambda;
      if (f.norm() > limit) f *= limit / f.norm();
      A.apply(c.ra, f - c.friction);
      B.apply(c.rb, c.friction - f);
      change = std::max(change, (f - c.friction).norm() * kt);
      c.friction = f;
    }
    if (change <= settled) break;
  }

  // Contact force and torque per body: the impulses over dt (equal and opposite on b).
  for (const Contact& c : contacts_) {
    const Eigen::Vector3d P = c.lambda * c.n + c.friction;
    BodyState& a = states[static_cast<std::size_t>(c.a)];
    a.contact_force += P / dt;
    a.contact_torque += c.ra.cross(P) / dt;
    if (c.b < 0) continue;
    BodyState& b = states[static_cast<std::size_t>(c.b)];
    b.contact_force -= P / dt;
    b.contact_torque -= c.rb.cross(P) / dt;
  }

  // Split impulses (Catto 2009): pseudo-velocities that remove a share of the penetration left
  // after this step (gap + dt vn, beyond the slop), normal only, solved like the velocities; they
  // move positions in correctPositions and never enter v or L. Walls are left out: the position
  // update moves a body out of them exactly.
  push_v_.assign(static_cast<std::size_t>(n), Eigen::Vector3d::Zero());
  push_w_.assign(static_cast<std::size_t>(n), Eigen::Vector3d::Zero());
  std::vector<Eigen::Vector3d> push_L(static_cast<std::size_t>(n), Eigen::Vector3d::Zero());
  std::vector<double> depth(contacts_.size(), 0.0);
  bool any = false;
  for (std::size_t k = 0; k < contacts_.size(); ++k) {
    const Contact& c = contacts_[k];
    if (c.b < 0) continue;
    depth[k] = std::max(-(c.gap + dt * c.n.dot(relativeNormal(c))) - slop_, 0.0);
    any = any || depth[k] > 0.0;
  }
  if (!any) return static_cast<int>(contacts_.size());
  auto pushVelocity = [&](int i, const Eigen::Vector3d& r) -> Eigen::Vector3d {  // not an Eigen expression
    return push_v_[static_cast<std::size_t>(i)] + push_w_[static_cast<std::size_t>(i)].cross(r);
  };
  auto pushApply = [&](int i, const Eigen::Vector3d& r, const Eigen::Vector3d& P) {
    const Solid& S = solid[static_cast<std::size_t>(i)];
    if (S.inv_mass == 0) return;
    push_v_[static_cast<std::size_t>(i)] += S.inv_mass * P;
    push_L[static_cast<std::size_t>(i)] += r.cross(P);
    push_w_[static_cast<std::size_t>(i)] = S.inv_inertia * push_L[static_cast<std::size_t>(i)];
  };
  for (int sweep = 0; sweep < kMaxSweeps; ++sweep) {
    double change = 0;
    for (std::size_t k = 0; k < contacts_.size(); ++k) {
      Contact& c = contacts_[k];
      if (c.b < 0) continue;
      const double vn = c.n.dot(pushVelocity(c.a, c.ra) - pushVelocity(c.b, c.rb));
      const double push = std::max(c.push + (kPositionFraction * depth[k] / dt - vn) / c.kn, 0.0);
      if (push == c.push) continue;
      pushApply(c.a, c.ra, (push - c.push) * c.n);
      pushApply(c.b, c.rb, -(push - c.push) * c.n);
      change = std::max(change, std::abs(push - c.push) * c.kn);
      c.push = push;
    }
    if (change <= settled) break;
  }
  return static_cast<int>(contacts_.size());
}

void ContactSolver::correctPositions(const std::vector<RigidBody>& bodies, std::vector<BodyState>& states, double dt) {
  for (std::size_t i = 0; i < push_v_.size() && i < bodies.size(); ++i) {
    if (bodies[i].kind != BodyKind::Dynamic || (push_v_[i].isZero() && push_w_[i].isZero())) continue;
    BodyState& s = states[i];
    s.x += dt * push_v_[i];
    const Eigen::Vector3d theta = dt * push_w_[i];
    const double angle = theta.norm();
    if (angle > 0.0) {
      s.q = (Eigen::Quaterniond(Eigen::AngleAxisd(angle, theta / angle)) * s.q).normalized();
      s.w = worldInverseInertia(bodies[i], s.q) * s.L;  // same angular momentum, new orientation
    }
  }
  push_v_.clear();
  push_w_.clear();
}

}  // namespace sph::rigid
