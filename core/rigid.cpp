#include "core/rigid.h"

#include "core/errors.h"

#include <Eigen/Cholesky>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>

namespace sph::rigid {

// ---------------------------------------------------------------------------------------------
// Shapes
// ---------------------------------------------------------------------------------------------

TriMesh lathe(const std::vector<Eigen::Vector2d>& profile, int segments) {
  SPH_ASSERT(profile.size() >= 2 && segments >= 3, "lathe needs two profile points and three segments");
  TriMesh m;
  // Vertices: one per axis point, a ring per off-axis point. ring[i] is the first vertex of point i.
  std::vector<uint32_t> first(profile.size());
  std::vector<bool> on_axis(profile.size());
  for (std::size_t i = 0; i < profile.size(); ++i) {
    const double r = profile[i].x(), z = profile[i].y();
    first[i] = static_cast<uint32_t>(m.positions.size());
    on_axis[i] = r <= 0.0;
    if (on_axis[i]) {
      m.positions.emplace_back(0.0f, 0.0f, static_cast<float>(z));
      continue;
    }
    for (int k = 0; k < segments; ++k) {
      const double phi = 2.0 * M_PI * k / segments;
      m.positions.emplace_back(static_cast<float>(r * std::cos(phi)), static_cast<float>(r * std::sin(phi)),
                               static_cast<float>(z));
    }
  }
  // Bands between consecutive profile points: with a the earlier and b the later point, the
  // triangles (a_k, a_k+1, b_k+1) and (a_k, b_k+1, b_k) face outward for a profile that keeps the
  // solid on its left (checked on the sphere's equator: the normal is +r).
  auto ring = [&](std::size_t i, int k) { return on_axis[i] ? first[i] : first[i] + static_cast<uint32_t>(k % segments); };
  for (std::size_t i = 0; i + 1 < profile.size(); ++i) {
    const std::size_t a = i, b = i + 1;
    if (on_axis[a] && on_axis[b]) continue;
    for (int k = 0; k < segments; ++k) {
      if (!on_axis[a]) m.triangles.push_back({ring(a, k), ring(a, k + 1), ring(b, k + 1)});
      if (!on_axis[b]) m.triangles.push_back({ring(a, k), ring(b, k + 1), ring(b, k)});
    }
  }
  return m;
}

int segmentsFor(double radius, double edge) {
  return std::max(16, static_cast<int>(std::ceil(2.0 * M_PI * radius / std::max(edge, 1e-12))));
}

TriMesh sphereMesh(double radius, double edge) {
  // Rings at polar angles (j + 1/2) pi / rings, closed by a flat polygon at each pole: a sphere
  // meshed with a vertex at the bottom would balance on it (and roll off), one with a flat bottom
  // rests on it.
  const int n = segmentsFor(radius, edge);
  const int rings = std::max(8, n / 2);
  const double delta = M_PI / rings;
  std::vector<Eigen::Vector2d> profile;
  profile.emplace_back(0.0, -radius * std::cos(0.5 * delta));
  for (int j = 0; j < rings; ++j) {
    const double theta = (j + 0.5) * delta;  // from the south pole
    profile.emplace_back(radius * std::sin(theta), -radius * std::cos(theta));
  }
  profile.emplace_back(0.0, radius * std::cos(0.5 * delta));
  return lathe(profile, n);
}

TriMesh boxMesh(const Eigen::Vector3d& size) {
  TriMesh m;
  const Eigen::Vector3d h = 0.5 * size;
  for (int c = 0; c < 8; ++c)
    m.positions.emplace_back(static_cast<float>(c & 1 ? h.x() : -h.x()), static_cast<float>(c & 2 ? h.y() : -h.y()),
                             static_cast<float>(c & 4 ? h.z() : -h.z()));
  // Corner c has bit 0 = +x, bit 1 = +y, bit 2 = +z. Each face as a quad, counter-clockwise from outside.
  const uint32_t quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6},   // -z, +z
                                {0, 1, 5, 4}, {2, 6, 7, 3},   // -y, +y
                                {0, 4, 6, 2}, {1, 3, 7, 5}};  // -x, +x
  for (const auto& q : quads) {
    m.triangles.push_back({q[0], q[1], q[2]});
    m.triangles.push_back({q[0], q[2], q[3]});
  }
  return m;
}

TriMesh cylinderMesh(double radius, double height, double edge) {
  const int n = segmentsFor(radius, edge);
  const double hz = 0.5 * height;
  return lathe({{0.0, -hz}, {radius, -hz}, {radius, hz}, {0.0, hz}}, n);
}

TriMesh capsuleMesh(double radius, double height, double edge) {
  const int n = segmentsFor(radius, edge);
  const int quarter = std::max(4, n / 4);
  const double hz = 0.5 * height;
  std::vector<Eigen::Vector2d> profile;
  for (int j = 0; j <= quarter; ++j) {  // bottom cap: south pole to equator
    const double theta = 0.5 * M_PI * j / quarter;
    profile.emplace_back(j == 0 ? 0.0 : radius * std::sin(theta), -hz - radius * std::cos(theta));
  }
  for (int j = 0; j <= quarter; ++j) {  // top cap: equator to north pole
    const double theta = 0.5 * M_PI * j / quarter;
    profile.emplace_back(j == quarter ? 0.0 : radius * std::cos(theta), hz + radius * std::sin(theta));
  }
  return lathe(profile, n);
}

TriMesh shapeMesh(const RigidBodySpec& spec, double spacing) {
  const double edge = 0.5 * spacing / spec.scale;  // edges of spacing / 2 after scaling
  TriMesh m;
  switch (spec.shape) {
    case BodyShape::Mesh: m = spec.mesh_data; break;
    case BodyShape::Sphere: m = sphereMesh(spec.radius, edge); break;
    case BodyShape::Box: m = boxMesh(spec.size); break;
    case BodyShape::Cylinder: m = cylinderMesh(spec.radius, spec.height, edge); break;
    case BodyShape::Capsule: m = capsuleMesh(spec.radius, spec.height, edge); break;
  }
  for (auto& p : m.positions) p *= static_cast<float>(spec.scale);
  m.normals.clear();
  m.colours.clear();
  return m;
}

// ---------------------------------------------------------------------------------------------
// Mass properties
// ---------------------------------------------------------------------------------------------
//
// Split the solid into signed tetrahedra (o, a, b, c), one per triangle, from a reference point o
// (the vertex mean, to keep the numbers small). With a, b, c relative to o, the tetrahedron has
//     V = a . (b x c) / 6,
// and, mapping it to the unit simplex (x = A u, |det A| = 6 V) where the monomial integrals are
// the Dirichlet values  int u_i = 1/24,  int u_i^2 = 1/60,  int u_i u_j = 1/120,
//     int x dV      = V (a + b + c) / 4
//     int x x^T dV  = V / 20 (a a^T + b b^T + c c^T + s s^T),   s = a + b + c.
// Signed volumes make the parts outside the solid cancel (divergence theorem), so the sums are the
// solid's volume, first and second moments about o. Then, with C = int x x^T dV about the centre
// of mass c (parallel-axis shift C_c = C_o - V c c^T), the inertia tensor per unit density is
//     I = trace(C) 1 - C.
MassProperties massProperties(const TriMesh& mesh) {
  Eigen::Vector3d o = Eigen::Vector3d::Zero();
  for (const auto& p : mesh.positions) o += p.cast<double>();
  if (!mesh.positions.empty()) o /= static_cast<double>(mesh.positions.size());

  double volume = 0.0;
  Eigen::Vector3d first = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d a = mesh.positions[t[0]].cast<double>() - o;
    const Eigen::Vector3d b = mesh.positions[t[1]].cast<double>() - o;
    const Eigen::Vector3d c = mesh.positions[t[2]].cast<double>() - o;
    const double V = a.dot(b.cross(c)) / 6.0;
    const Eigen::Vector3d s = a + b + c;
    volume += V;
    first += V * s / 4.0;
    second += V / 20.0 * (a * a.transpose() + b * b.transpose() + c * c.transpose() + s * s.transpose());
  }
  MassProperties mp;
  mp.volume = volume;
  if (volume <= 0.0) return mp;
  const Eigen::Vector3d centre = first / volume;  // relative to o
  const Eigen::Matrix3d C = second - volume * centre * centre.transpose();
  mp.centre = o + centre;
  mp.inertia = C.trace() * Eigen::Matrix3d::Identity() - C;
  return mp;
}

// ---------------------------------------------------------------------------------------------
// Sampling
// ---------------------------------------------------------------------------------------------

std::vector<Eigen::Vector3f> sampleSurface(const TriMesh& mesh, double spacing, std::vector<Eigen::Vector3f>* normals) {
  const double r = 0.75 * spacing;   // Poisson-disk radius
  const double dense = 0.2 * spacing; // candidate spacing on each triangle
  const double r2 = r * r;
  // Hash grid of cell r over the accepted points.
  auto key = [r](const Eigen::Vector3d& p) {
    return Eigen::Vector3i(static_cast<int>(std::floor(p.x() / r)), static_cast<int>(std::floor(p.y() / r)),
                           static_cast<int>(std::floor(p.z() / r)));
  };
  auto hash = [](const Eigen::Vector3i& k) {
    return (static_cast<int64_t>(k.x()) + (1 << 20)) | ((static_cast<int64_t>(k.y()) + (1 << 20)) << 21) |
           ((static_cast<int64_t>(k.z()) + (1 << 20)) << 42);
  };
  std::unordered_map<int64_t, std::vector<uint32_t>> grid;
  std::vector<Eigen::Vector3d> accepted, accepted_normal;
  auto offer = [&](const Eigen::Vector3d& p, const Eigen::Vector3d& n) {
    const Eigen::Vector3i k = key(p);
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          auto it = grid.find(hash(k + Eigen::Vector3i(dx, dy, dz)));
          if (it == grid.end()) continue;
          for (uint32_t j : it->second)
            if ((accepted[j] - p).squaredNorm() < r2) return;
        }
    grid[hash(k)].push_back(static_cast<uint32_t>(accepted.size()));
    accepted.push_back(p);
    accepted_normal.push_back(n);
  };
  // Area-weighted vertex normals (the cross product's length is twice the area).
  std::vector<Eigen::Vector3d> vertex_normal(mesh.positions.size(), Eigen::Vector3d::Zero());
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d a = mesh.positions[t[0]].cast<double>();
    const Eigen::Vector3d n = (mesh.positions[t[1]].cast<double>() - a).cross(mesh.positions[t[2]].cast<double>() - a);
    for (uint32_t v : t) vertex_normal[v] += n;
  }
  // Vertices first (corners and creases are where gaps would open), then each triangle's
  // barycentric grid of candidates.
  for (std::size_t v = 0; v < mesh.positions.size(); ++v)
    offer(mesh.positions[v].cast<double>(), vertex_normal[v].normalized());
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d a = mesh.positions[t[0]].cast<double>();
    const Eigen::Vector3d b = mesh.positions[t[1]].cast<double>();
    const Eigen::Vector3d c = mesh.positions[t[2]].cast<double>();
    const Eigen::Vector3d normal = (b - a).cross(c - a).normalized();
    const double longest = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
    const int n = std::max(1, static_cast<int>(std::ceil(longest / dense)));
    for (int i = 0; i <= n; ++i)
      for (int j = 0; i + j <= n; ++j) {
        const double u = static_cast<double>(i) / n, v = static_cast<double>(j) / n;
        offer(a + u * (b - a) + v * (c - a), normal);
      }
  }
  std::vector<Eigen::Vector3f> out;
  out.reserve(accepted.size());
  for (const auto& p : accepted) out.push_back(p.cast<float>());
  if (normals) {
    normals->clear();
    for (const auto& n : accepted_normal) normals->push_back(n.cast<float>());
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// Dynamics
// ---------------------------------------------------------------------------------------------

uint64_t hashStates(const std::vector<BodyState>& states, uint64_t h) {
  for (const BodyState& b : states) {
    const double v[13] = {b.x.x(), b.x.y(), b.x.z(), b.q.w(), b.q.x(), b.q.y(), b.q.z(),
                          b.v.x(), b.v.y(), b.v.z(), b.L.x(), b.L.y(), b.L.z()};
    const auto* p = reinterpret_cast<const unsigned char*>(v);
    for (std::size_t i = 0; i < sizeof v; ++i) h = (h ^ p[i]) * 1099511628211ull;
  }
  return h;
}

BodyState initialState(const RigidBody& body) {
  BodyState s;
  const RigidBodySpec& spec = body.spec;
  s.q = Eigen::Quaterniond(Eigen::AngleAxisd(spec.orientation_angle * M_PI / 180.0, spec.orientation_axis.normalized()));
  // The scene places the shape's origin; the state tracks the centre of mass.
  s.x = spec.position - s.q * body.origin_offset;
  if (body.kind == BodyKind::Dynamic && spec.hold_until > 0.0) {
    // Held still until spec.hold_until (Simulation::integrateBodies), then released from rest.
  } else if (body.kind == BodyKind::Dynamic) {
    s.v = spec.velocity;
    s.w = spec.angular_velocity;
    const Eigen::Matrix3d R = s.q.toRotationMatrix();
    s.L = R * body.inertia * R.transpose() * s.w;
  } else if (body.kind == BodyKind::Kinematic && spec.motion.type == MotionType::Keyframes) {
    followKeyframes(body, s, 0.0);
  } else if (body.kind == BodyKind::Kinematic) {
    s.v = spec.motion.velocity;
    s.w = spec.motion.angular_velocity;
  }
  return s;
}

Eigen::Matrix3d worldInverseInertia(const RigidBody& body, const Eigen::Quaterniond& q) {
  const Eigen::Matrix3d R = q.toRotationMatrix();
  return R * body.inv_inertia * R.transpose();
}

namespace {
/// q rotated by the rotation vector `theta` (unit: rad), applied in the world frame.
Eigen::Quaterniond rotated(const Eigen::Quaterniond& q, const Eigen::Vector3d& theta) {
  const double angle = theta.norm();
  if (angle == 0.0) return q;
  return (Eigen::Quaterniond(Eigen::AngleAxisd(angle, theta / angle)) * q).normalized();
}
}  // namespace

namespace {
/// Whether the external wrench answers the body's motion implicitly (BodyState::external_damping).
bool damped(const BodyState& s, double dt) { return dt > 0.0 && !s.external_damping.isZero(0.0); }

/// The step's mass matrix with the external damping implicit, diag((m + M) 1, (1 + M / m) I_w) + dt D
/// (M the fictitious mass; symmetric positive definite, D being semi-definite).
Matrix6d implicitMass(const RigidBody& body, const BodyState& s, double dt, double fictitious_mass) {
  const Eigen::Matrix3d R = s.q.toRotationMatrix();
  const double M = fictitious_mass;
  Matrix6d A = dt * s.external_damping;
  A.topLeftCorner<3, 3>() += (body.mass + M) * Eigen::Matrix3d::Identity();
  A.bottomRightCorner<3, 3>() += (1.0 + M / body.mass) * (R * body.inertia * R.transpose());
  return A;
}
}  // namespace

Vector6d velocityChange(const RigidBody& body, const BodyState& s, const Eigen::Vector3d& g, double dt,
                        double fictitious_mass) {
  Vector6d du = Vector6d::Zero();
  if (body.kind != BodyKind::Dynamic) return du;
  const double m = body.mass, M = fictitious_mass;
  const Eigen::Vector3d force = m * g + s.fluid_force + s.external_force;
  const Eigen::Vector3d torque = s.fluid_torque + s.external_torque;
  if (!damped(s, dt)) {
    // integrateVelocity's explicit update (its comment), as velocities.
    du.head<3>() = dt * (force + M * s.accel) / (m + M);
    du.tail<3>() = worldInverseInertia(body, s.q) * (dt * (torque + fictitiousTorque(body, s, M)));
    return du;
  }
  // (diag((m + M) 1, (1 + M / m) I_w) + dt D) du = dt (F + M a_{n-1}, T + (M / m) tau_{n-1}): the
  // fictitious mass and inertia (Baek & Karniadakis 2012, eq. 9, and its rotational twin) with the
  // external wrench's damping implicit.
  Vector6d rhs;
  rhs.head<3>() = dt * (force + M * s.accel);
  rhs.tail<3>() = dt * (torque + (M / m) * s.torque_rate);
  return implicitMass(body, s, dt, M).ldlt().solve(rhs);
}

Matrix6d mobility(const RigidBody& body, const BodyState& s, double dt) {
  Matrix6d N = Matrix6d::Zero();
  if (body.kind != BodyKind::Dynamic || !(body.mass > 0.0)) return N;
  if (!damped(s, dt)) {
    N.topLeftCorner<3, 3>() = Eigen::Matrix3d::Identity() / body.mass;
    N.bottomRightCorner<3, 3>() = worldInverseInertia(body, s.q);
    return N;
  }
  return implicitMass(body, s, dt, 0.0).ldlt().solve(Matrix6d::Identity());
}

void integrateVelocity(const RigidBody& body, BodyState& s, const Eigen::Vector3d& g, double dt,
                       double fictitious_mass) {
  if (body.kind != BodyKind::Dynamic) return;
  if (damped(s, dt)) {
    // The external wrench implicit in the body's motion (BodyState::external_damping): one 6x6
    // solve; L takes I_w dw (L = I_w w at this orientation), and the state keeps the wrench that acted.
    const Vector6d du = velocityChange(body, s, g, dt, fictitious_mass);
    const Eigen::Matrix3d R = s.q.toRotationMatrix();
    s.v += du.head<3>();
    s.L += R * body.inertia * R.transpose() * du.tail<3>();
    s.w = worldInverseInertia(body, s.q) * s.L;
    const Vector6d acted = -(s.external_damping * du);
    s.external_force += acted.head<3>();
    s.external_torque += acted.tail<3>();
    return;
  }
  // Forces at the start of the step. (Contact acts by impulses, core/contact.h; contact_force only
  // records them.)
  const Eigen::Vector3d force = body.mass * g + s.fluid_force + s.external_force;
  // Baek & Karniadakis 2012, eq. 9: (m + M) a_n = F_n + M a_{n-1} (M = 0: v += dt F / m).
  s.v += dt * (force + fictitious_mass * s.accel) / (body.mass + fictitious_mass);
  // The rotational twin, with J = (M / m) I: dL = dt (T_n + T_J) = dt (m T_n + M tau_{n-1}) / (m + M)
  // (fictitiousTorque; T_J = 0 without a fictitious mass, so then exactly dL = dt T_n).
  s.L += dt * (s.fluid_torque + s.external_torque + fictitiousTorque(body, s, fictitious_mass));
  s.w = worldInverseInertia(body, s.q) * s.L;
}

Eigen::Vector3d fictitiousForce(const RigidBody& body, const BodyState& s, const Eigen::Vector3d& g,
                                double fictitious_mass, double dt) {
  if (body.kind != BodyKind::Dynamic || fictitious_mass == 0.0) return Eigen::Vector3d::Zero();
  // With an external damping: M (a_{n-1} - a_n), a_n the implicit update's.
  if (damped(s, dt)) return fictitious_mass * (s.accel - velocityChange(body, s, g, dt, fictitious_mass).head<3>() / dt);
  // The same forces as integrateVelocity; M (a_{n-1} - a_n) with its a_n (Baek & Karniadakis 2012, eq. 9).
  const Eigen::Vector3d force = body.mass * g + s.fluid_force + s.external_force;
  return fictitious_mass * (body.mass * s.accel - force) / (body.mass + fictitious_mass);
}

Eigen::Vector3d fictitiousTorque(const RigidBody& body, const BodyState& s, double fictitious_mass,
                                 const Eigen::Vector3d& g, double dt) {
  if (body.kind != BodyKind::Dynamic || fictitious_mass == 0.0) return Eigen::Vector3d::Zero();
  if (damped(s, dt)) {
    // (M / m) (tau_{n-1} - I_w alpha_n), alpha_n the implicit update's.
    const Eigen::Matrix3d R = s.q.toRotationMatrix();
    const Eigen::Vector3d dw = velocityChange(body, s, g, dt, fictitious_mass).tail<3>();
    return (fictitious_mass / body.mass) * (s.torque_rate - R * body.inertia * R.transpose() * dw / dt);
  }
  const Eigen::Vector3d torque = s.fluid_torque + s.external_torque;
  return fictitious_mass * (s.torque_rate - torque) / (body.mass + fictitious_mass);
}

void integratePosition(const RigidBody& body, BodyState& s, double dt, const DomainSpec* walls) {
  switch (body.kind) {
    case BodyKind::Static: return;
    case BodyKind::Kinematic:
      if (body.spec.motion.type == MotionType::Keyframes) return;  // followKeyframes(body, s, t) poses it
      // Constant velocity and angular velocity: exact for any dt.
      s.x += dt * s.v;
      s.q = rotated(s.q, dt * s.w);
      return;
    case BodyKind::Dynamic: {
      // q <- exp(dt w / 2) q: the exact rotation by w dt (a unit quaternion), renormalised against
      // rounding; the linearised update q + dt/2 (0, w) q would grow |q| by O(dt^2) each step.
      s.q = rotated(s.q, dt * s.w);
      s.x += dt * s.v;
      s.w = worldInverseInertia(body, s.q) * s.L;  // consistent with the new orientation
      if (walls) {
        // Rounding (or a contact the sweeps did not fully resolve) may leave a vertex inside a
        // wall: move the body out along the wall normal; velocities are left alone (no energy).
        const Eigen::Matrix3d R = s.q.toRotationMatrix();
        for (int a = 0; a < 3; ++a) {
          double below = 0.0, above = 0.0;
          for (const auto& vertex : body.mesh.positions) {
            const double pa = s.x[a] + (R * vertex.cast<double>())[a];
            below = std::max(below, walls->min[a] - pa);
            above = std::max(above, pa - walls->max[a]);
          }
          if (walls->closed[static_cast<std::size_t>(2 * a)] && below > 0.0) s.x[a] += below;
          else if (walls->closed[static_cast<std::size_t>(2 * a + 1)] && above > 0.0) s.x[a] -= above;
        }
      }
      return;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Keyframed motion (see rigid.h for the curves)
// ---------------------------------------------------------------------------------------------

namespace {

/// The unit quaternion of the rotation vector theta (unit: rad).
Eigen::Quaterniond expRotation(const Eigen::Vector3d& theta) {
  const double angle = theta.norm();
  if (angle == 0.0) return Eigen::Quaterniond::Identity();
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, theta / angle));
}

/// The rotation vector of a unit quaternion, the short way (angle in [0, pi]).
Eigen::Vector3d logRotation(Eigen::Quaterniond q) {
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();
  const double s = q.vec().norm();
  if (s == 0.0) return Eigen::Vector3d::Zero();
  return 2.0 * std::atan2(s, q.w()) / s * q.vec();
}

Eigen::Quaterniond keyOrientation(const KeyframeSpec& k) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(k.orientation_angle * M_PI / 180.0, k.orientation_axis.normalized()));
}

/// Tangents at key k: dp/dt (unit: m/s) and the body-frame angular velocity (unit: rad/s);
/// weighted finite differences at interior keys, zero at the ends.
void keyTangents(const std::vector<KeyframeSpec>& keys, std::size_t k, Eigen::Vector3d& m, Eigen::Vector3d& W) {
  m.setZero();
  W.setZero();
  if (k == 0 || k + 1 >= keys.size()) return;
  const KeyframeSpec &a = keys[k - 1], &b = keys[k], &c = keys[k + 1];
  const double h0 = b.time - a.time, h1 = c.time - b.time;
  m = (h1 * (b.position - a.position) / h0 + h0 * (c.position - b.position) / h1) / (h0 + h1);
  const Eigen::Quaterniond qa = keyOrientation(a), qb = keyOrientation(b), qc = keyOrientation(c);
  // log(q_a^-1 q_b) is the rotation vector in a's body frame, the same vector in b's (it is its own axis).
  const Eigen::Vector3d r0 = logRotation(qa.conjugate() * qb), r1 = logRotation(qb.conjugate() * qc);
  W = (h1 * r0 / h0 + h0 * r1 / h1) / (h0 + h1);
}

}  // namespace

PathSample samplePath(const std::vector<KeyframeSpec>& keys, double t) {
  SPH_ASSERT(!keys.empty(), "a keyframed path needs keys");
  PathSample out;
  // Hold before the first and after the last key.
  if (t <= keys.front().time || keys.size() == 1) {
    out.position = keys.front().position;
    out.q = keyOrientation(keys.front());
    return out;
  }
  if (t >= keys.back().time) {
    out.position = keys.back().position;
    out.q = keyOrientation(keys.back());
    return out;
  }
  // The interval [t_a, t_b) that holds t.
  std::size_t a = 0;
  while (a + 2 < keys.size() && t >= keys[a + 1].time) ++a;
  const KeyframeSpec &ka = keys[a], &kb = keys[a + 1];
  const double T = kb.time - ka.time, u = (t - ka.time) / T;
  Eigen::Vector3d ma, Wa, mb, Wb;
  keyTangents(keys, a, ma, Wa);
  keyTangents(keys, a + 1, mb, Wb);

  // Position: cubic Hermite basis and its derivative in u.
  const double u2 = u * u, u3 = u2 * u;
  const double h00 = 2 * u3 - 3 * u2 + 1, h10 = u3 - 2 * u2 + u, h01 = -2 * u3 + 3 * u2, h11 = u3 - u2;
  const double d00 = 6 * u2 - 6 * u, d10 = 3 * u2 - 4 * u + 1, d01 = -6 * u2 + 6 * u, d11 = 3 * u2 - 2 * u;
  out.position = h00 * ka.position + h10 * T * ma + h01 * kb.position + h11 * T * mb;
  out.velocity = (d00 * ka.position + d10 * T * ma + d01 * kb.position + d11 * T * mb) / T;

  // Orientation: Kim, Kim & Shin (1995) cumulative Hermite form.
  const Eigen::Quaterniond qa = keyOrientation(ka), qb = keyOrientation(kb);
  const Eigen::Vector3d th1 = Wa * T / 3.0, th3 = Wb * T / 3.0;
  const Eigen::Vector3d th2 = logRotation(expRotation(-th1) * qa.conjugate() * qb * expRotation(-th3));
  const double v = 1.0 - u;
  const double b1 = 1.0 - v * v * v, b2 = 3 * u2 - 2 * u3, b3 = u3;
  const double db1 = 3 * v * v, db2 = 6 * u - 6 * u2, db3 = 3 * u2;
  const Eigen::Quaterniond e1 = expRotation(b1 * th1), e2 = expRotation(b2 * th2), e3 = expRotation(b3 * th3);
  out.q = (qa * e1 * e2 * e3).normalized();
  out.w = qa * (db1 * th1 + e1 * (db2 * th2) + (e1 * e2) * (db3 * th3)) / T;
  return out;
}

void followKeyframes(const RigidBody& body, BodyState& s, double t) {
  const PathSample p = samplePath(body.spec.motion.keyframes, t);
  const Eigen::Vector3d arm = p.q * body.origin_offset;  // centre of mass -> body origin, world
  s.q = p.q;
  s.x = p.position - arm;
  s.w = p.w;
  s.v = p.velocity - p.w.cross(arm);
}

TriMesh worldMesh(const RigidBody& body, const BodyState& s) {
  TriMesh m = body.mesh;
  const Eigen::Matrix3f R = s.q.toRotationMatrix().cast<float>();
  const Eigen::Vector3f x = s.x.cast<float>();
  for (auto& p : m.positions) p = x + R * p;
  m.colours.assign(m.positions.size(), body.spec.colour.cast<float>());
  return m;
}

}  // namespace sph::rigid
