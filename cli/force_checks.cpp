#include "cli/force_checks.h"

#include "cli/runner.h"
#include "core/model.h"
#include "core/scene_spec.h"
#include "io/scene_loader.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace sph::app {

namespace {

std::string num(double v) {
  std::ostringstream s;
  s.precision(17);
  s << v;
  return s.str();
}

/// A quiet run of `scene` at particle spacing dx that writes nothing: the check's own settings
/// (`own`), then the caller's `sets` (which may override them).
RunOptions checkRun(const std::string& scene, double dx, const std::vector<std::string>& own,
                    const std::vector<std::string>& sets, const std::string& device) {
  RunOptions o;
  o.scene = scene;
  o.device = device;
  o.quiet = true;
  o.write_output = false;
  o.sets = {"fluid.particle_spacing=" + num(dx)};
  o.sets.insert(o.sets.end(), own.begin(), own.end());
  o.sets.insert(o.sets.end(), sets.begin(), sets.end());
  return o;
}

/// One run of a force-check scene: what the checks read of body 0 and of the scene, captured at
/// the end of the first frame, and every step's fluid force on body 0 from then on.
struct BallRun {
  RunResult result;          ///< exit code, message and wall time of the run
  double hold = 0;           ///< rigid_bodies[0].hold_until (unit: s)
  double duration = 0;       ///< simulation.duration (unit: s)
  double rho = 0;            ///< the first phase's rest density (unit: kg/m^3)
  double nu = 0;             ///< its kinematic viscosity (unit: m^2/s)
  double g = 0;              ///< |gravity| (unit: m/s^2)
  double volume = 0;         ///< the body's volume (unit: m^3)
  double mass = 0;           ///< the body's mass (unit: kg)
  double radius = 0;         ///< its radius times its scale (unit: m)
  double box = 0;            ///< the domain's smallest side (unit: m)
  double speed = 0;          ///< |motion.velocity| (unit: m/s)
  double nearest = 0;        ///< the nearest wall or fluid block top from the start centre (unit: m)
  double floor_height = 0;   ///< the start centre's height over the domain floor (unit: m)
  double key_first = 0, key_last = 0;  ///< the first and last keyframe times, if keyframed (unit: s)
  std::vector<StepForce> log;
};

BallRun runBall(const RunOptions& o) {
  BallRun b;
  bool first = true;
  b.result = runScene(o, [&](Simulation& sim, const FrameReport&) {
    if (first) {
      first = false;
      const Model& m = sim.model();
      const auto& body = m.bodies[0];
      b.hold = body.spec.hold_until;
      b.duration = m.spec.simulation.duration;
      b.rho = m.spec.fluid.phases[0].rest_density;
      b.nu = m.spec.fluid.phases[0].viscosity;
      b.g = m.spec.simulation.gravity.norm();
      b.volume = body.volume;
      b.mass = body.mass;
      b.radius = body.spec.radius * body.spec.scale;
      b.box = (m.spec.domain.max - m.spec.domain.min).minCoeff();
      b.speed = body.spec.motion.velocity.norm();
      // The start centre: the first keyframe's (keyframed motion), else the body's position.
      const auto& keys = body.spec.motion.keyframes;
      if (!keys.empty()) {
        b.key_first = keys.front().time;
        b.key_last = keys.back().time;
      }
      const Eigen::Vector3d x = keys.empty() ? body.spec.position : keys.front().position;
      b.nearest = std::min((x - m.spec.domain.min).minCoeff(), (m.spec.domain.max - x).minCoeff());
      for (const BlockSpec& blk : m.spec.fluid.blocks) b.nearest = std::min(b.nearest, blk.max.z() - x.z());
      b.floor_height = x.z() - m.spec.domain.min.z();
      sim.recordStepForces(true);
    }
    for (const StepForce& f : sim.takeStepForces()) b.log.push_back(f);
  });
  return b;
}

/// Copies a run's outcome into a check (exit code, message, wall time); true if it ran.
template <class Check>
bool ran(const BallRun& b, Check& c) {
  c.exit_code = b.result.exit_code;
  c.message = b.result.message;
  c.wall_seconds = b.result.wall_seconds;
  c.radius = b.radius;
  return b.result.exit_code == 0;
}

}  // namespace

ReleaseCheck releasedBall(const std::string& scene, double dx, double rho_b, double window,
                          const std::vector<std::string>& sets, const std::string& device) {
  ReleaseCheck c;
  c.dx = dx;
  const BallRun b = runBall(checkRun(scene, dx, {"rigid_bodies[0].density=" + num(rho_b)}, sets, device));
  if (!ran(b, c)) return c;
  const double hold = b.hold, rho_w = b.rho, g = b.g, volume = b.volume, mass = b.mass;
  const std::vector<StepForce>& log = b.log;
  c.weight = mass * g;
  c.buoyancy = rho_w * g * volume;
  c.a0_expected = (rho_w - rho_b) * g / (rho_b + 0.5 * rho_w);
  c.a0_no_added_mass = (rho_w - rho_b) * g / rho_b;
  // Held: the last 0.1 s of the hold. Free: the window after the release; v_z(t) fitted by least
  // squares (its slope is the mean acceleration over the window).
  double held = 0, freef = 0, st = 0, sv = 0, stt = 0, stv = 0;
  int nh = 0, nf = 0;
  for (const StepForce& f : log) {
    if (f.time >= hold - 0.1 && f.time < hold) {
      held += f.force.z();
      ++nh;
    } else if (f.time >= hold && f.time <= hold + window) {
      freef += f.force.z();
      st += f.time;
      sv += f.v.z();
      stt += f.time * f.time;
      stv += f.time * f.v.z();
      ++nf;
    }
  }
  if (nh < 2 || nf < 3) {
    c.exit_code = 1;
    c.message = "too few steps in the held or free window";
    return c;
  }
  c.held_force = held / nh;
  c.free_force = freef / nf;
  c.a0 = (nf * stv - st * sv) / (nf * stt - st * st);
  return c;
}

double sphereWallAddedMass(double h_over_r) {
  // Lengths in units of R. The k-th doublet inside the sphere (strength m_k relative to the
  // sphere's own m_0, at z_k <= 0 on the axis towards the wall) has its wall image at distance
  // c = 2 h + z_k from the centre; that image's image in the sphere is m_{k+1} = m_k / c^3 at
  // z_{k+1} = -1 / c. The terms fall at least as (1 / (2h - 1))^3 per step: 200 are plenty.
  double m = 1.0, z = 0.0, sum = 0.0;
  for (int k = 0; k < 200; ++k) {
    const double c = 2.0 * h_over_r + z;
    m /= c * c * c;
    z = -1.0 / c;
    sum += m;
  }
  return 0.5 * (1.0 + 3.0 * sum);
}

ReleaseMassCheck releasedBallAddedMass(const std::string& scene, double dx, double rho_b, double window,
                                       const std::vector<std::string>& sets, const std::string& device) {
  ReleaseMassCheck c;
  c.dx = dx;
  // Two runs: free, and held throughout (both log every step's force and velocity of body 0).
  const BallRun free_run = runBall(checkRun(scene, dx, {"rigid_bodies[0].density=" + num(rho_b)}, sets, device));
  if (!ran(free_run, c)) return c;
  RunOptions held_options = checkRun(scene, dx, {"rigid_bodies[0].density=" + num(rho_b)}, sets, device);
  held_options.sets.push_back("rigid_bodies[0].hold_until=1e6");
  const BallRun held_run = runBall(held_options);
  const double free_wall = c.wall_seconds;
  if (!ran(held_run, c)) return c;
  c.wall_seconds += free_wall;
  const double hold = free_run.hold, rho_w = free_run.rho, g = free_run.g, volume = free_run.volume;
  const double mass = free_run.mass, nearest = free_run.nearest, floor_height = free_run.floor_height;
  const std::vector<StepForce>& free_log = free_run.log;
  const std::vector<StepForce>& held_log = held_run.log;
  const double l3 = std::pow(c.radius / nearest, 3);
  c.cm_confined = (1.0 + 2.0 * l3) / (2.0 * (1.0 - l3));
  c.cm_floor = sphereWallAddedMass(floor_height / c.radius);
  c.cm_floor_lo = sphereWallAddedMass((floor_height + 0.5 * dx) / c.radius);
  c.cm_floor_hi = sphereWallAddedMass(std::max(floor_height - 0.5 * dx, c.radius) / c.radius);
  c.a0_still = (rho_w - rho_b) * g / (rho_b + 0.5 * rho_w);
  // The held force at time t, linear between its steps (the two runs' steps may differ after the release).
  auto heldAt = [&](double t) {
    auto it = std::lower_bound(held_log.begin(), held_log.end(), t,
                               [](const StepForce& f, double x) { return f.time < x; });
    if (it == held_log.begin()) return it->force.z();
    if (it == held_log.end()) return held_log.back().force.z();
    const StepForce& b = *it;
    const StepForce& a = *(it - 1);
    return a.force.z() + (b.force.z() - a.force.z()) * (t - a.time) / (b.time - a.time);
  };
  // Momentum over the window: the ball's m v(T) = int (F_free - m g) dt, and the held run's force
  // is what the fluid would give a ball at rest, so int (F_free - F_held) dt = -C_m rho V v(T).
  // (Integrated, not fitted step by step: the first ~R/c0 after the release the fluid has not
  // answered yet, and the ball then oscillates on the liquid's compressibility at a few ms period,
  // where the added-mass picture does not hold; the integral averages over it.)
  double dF_int = 0, held_int = 0, span = 0, v_end = 0;
  for (std::size_t k = 0; k + 1 < free_log.size(); ++k) {
    const StepForce& f = free_log[k];
    if (f.time < hold - 1e-12 || f.time >= hold + window - 1e-12) continue;
    const double dt = free_log[k + 1].time - f.time;
    dF_int += (f.force.z() - heldAt(f.time)) * dt;
    held_int += heldAt(f.time) * dt;
    span += dt;
    v_end = free_log[k + 1].v.z();
  }
  if (!(v_end > 0.0) || span <= 0.0) {
    c.exit_code = 1;
    c.message = "the ball did not rise after the release";
    return c;
  }
  c.cm = -dF_int / (rho_w * volume * v_end);
  c.a0 = v_end / span;
  const double held_mean = held_int / span;
  c.held_over_buoyancy = held_mean / (rho_w * g * volume);
  const double e1 = (held_mean - mass * g) / (mass + 0.75 * 0.5 * rho_w * volume);
  // the upper C_m: the floor's series when the floor is the nearest boundary, else Lamb's sphere
  const double cm_hi = floor_height <= nearest + 1e-12 ? c.cm_floor : c.cm_confined;
  const double e2 = (held_mean - mass * g) / (mass + 1.25 * cm_hi * rho_w * volume);
  c.a0_expected_lo = std::min(e1, e2);
  c.a0_expected_hi = std::max(e1, e2);
  return c;
}

AccelCheck acceleratedBall(const std::string& scene, double dx, const std::vector<std::string>& sets,
                           const std::string& device) {
  AccelCheck c;
  c.dx = dx;
  // The ball's keyframes are in metres, so they do not change with dx.
  const BallRun b = runBall(checkRun(scene, dx, {}, sets, device));
  if (!ran(b, c)) return c;
  const double t0 = b.key_first, t1 = b.key_last, rho = b.rho, volume = b.volume, nearest = b.nearest;
  const std::vector<StepForce>& log = b.log;
  const double l3 = std::pow(c.radius / nearest, 3);
  c.cm_confined = (1.0 + 2.0 * l3) / (2.0 * (1.0 - l3));
  // F_x = -M a - B v at the shaking's frequency: F, a and v projected on cos and sin of the
  // fundamental over the keyframed phase (whole periods), each sample weighted by its step's length,
  // and M, B solved from the two components (the Fourier averages of forced-oscillation experiments,
  // Keulegan & Carpenter 1958). The acceleration of the path from central differences of the logged
  // velocity. A least-squares fit on the per-step a itself read C_m low where the force does not
  // follow the keyframed path's own ripple (the cubic Hermite's acceleration is piecewise linear
  // between keys 5 ms apart: an RMS ~17 % of the shaking's in WCSPH's 0.26 ms steps): the ripple
  // counts in sum a^2 but not in sum F a, an errors-in-variables bias of ~4 % there (docs/forces.md,
  // session 34). The fundamental is the harmonic of the window where |a| is largest.
  struct Sample {
    double t, w, a, v, F;
  };
  std::vector<Sample> s;
  double amax = 0;
  for (std::size_t k = 1; k + 1 < log.size(); ++k) {
    const StepForce& f = log[k];
    if (f.time < t0 || f.time > t1) continue;
    const double a = (log[k + 1].v.x() - log[k - 1].v.x()) / (log[k + 1].time - log[k - 1].time);
    const double w = std::min(log[k + 1].time, t1) - f.time;
    s.push_back({f.time - t0, w, a, f.v.x(), f.force.x()});
    amax = std::max(amax, std::abs(a));
  }
  const double window = t1 - t0;
  struct Component {
    double c = 0, s = 0;
  };
  auto project = [&](double omega, auto field) {
    Component r;
    for (const Sample& q : s) {
      r.c += q.w * field(q) * std::cos(omega * q.t);
      r.s += q.w * field(q) * std::sin(omega * q.t);
    }
    return r;
  };
  auto acc = [](const Sample& q) { return q.a; };
  double omega = 0, best = 0;
  for (int h = 1; h <= 20 && window > 0.0; ++h) {
    const double o = 2.0 * M_PI * h / window;
    const Component a = project(o, acc);
    const double power = a.c * a.c + a.s * a.s;
    if (power > best) {
      best = power;
      omega = o;
    }
  }
  const Component A = project(omega, acc);
  const Component V = project(omega, [](const Sample& q) { return q.v; });
  const Component F = project(omega, [](const Sample& q) { return q.F; });
  // F = -M A - B V, two equations (cos and sin parts) in M and B
  const double det = A.c * V.s - A.s * V.c;
  if (s.size() < 4 || !(std::abs(det) > 0.0)) {
    c.exit_code = 1;
    c.message = "no motion in the keyframed phase";
    return c;
  }
  const double M = -(F.c * V.s - F.s * V.c) / det;
  const double B = -(A.c * F.s - A.s * F.c) / det;
  c.accel = amax;
  c.cm = M / (rho * volume);
  c.damping = B;
  return c;
}

double sphereInSphereWallFactor(double l) {
  return (1.0 - std::pow(l, 5)) / (1.0 - 2.25 * l + 2.5 * std::pow(l, 3) - 2.25 * std::pow(l, 5) + std::pow(l, 6));
}

double stokesEffectiveRadius(double ratio, double radius, double b) {
  // (R_eff / R) K(R_eff / b) grows with R_eff: bisection.
  double lo = 0.25 * radius, hi = std::min(1.75 * radius, 0.99 * b);
  for (int k = 0; k < 60; ++k) {
    const double mid = 0.5 * (lo + hi);
    if (mid / radius * sphereInSphereWallFactor(mid / b) < ratio) lo = mid;
    else hi = mid;
  }
  return 0.5 * (lo + hi);
}

void stokesBand(double radius, double dx, double box, double& lo, double& hi) {
  // The box's two bracketing containers (towedBall) with the no-slip surface dx/2 inside or
  // outside R (the resolution's uncertainty).
  const double r_lo = radius - 0.5 * dx, r_hi = radius + 0.5 * dx;
  lo = r_lo / radius * sphereInSphereWallFactor(r_lo / (box * std::cbrt(3.0 / (4.0 * M_PI))));
  hi = r_hi / radius * sphereInSphereWallFactor(r_hi / (0.5 * box));
}

TowCheck towedBall(const std::string& scene, double dx, const std::vector<std::string>& sets, const std::string& device) {
  TowCheck c;
  c.dx = dx;
  const BallRun b = runBall(checkRun(scene, dx, {}, sets, device));
  if (!ran(b, c)) return c;
  const double duration = b.duration, nu = b.nu, rho = b.rho, box = b.box;
  const std::vector<StepForce>& log = b.log;
  c.box = box;
  c.mu = rho * nu;
  // Wall factor of the cubic box (side L) bracketed by two spherical containers: the inscribed
  // one (b = L/2, less liquid than the box: K too high) and the one of the box's volume
  // (b = L (3 / 4 pi)^(1/3), the corners counted as near as the faces: K too low).
  c.wall_factor_hi = sphereInSphereWallFactor(c.radius / (0.5 * box));
  c.wall_factor_lo = sphereInSphereWallFactor(c.radius / (box * std::cbrt(3.0 / (4.0 * M_PI))));
  stokesBand(c.radius, dx, box, c.expected_lo, c.expected_hi);
  // The second half of the run: the viscous set-up time over the gap to the walls has passed.
  std::vector<const StepForce*> win;
  for (const StepForce& f : log)
    if (f.time >= 0.5 * duration) win.push_back(&f);
  if (win.size() < 12) {
    c.exit_code = 1;
    c.message = "too few steps in the window";
    return c;
  }
  // U: the constant motion's speed, or for a keyframed tow the mean speed over the window.
  c.speed = b.speed;
  if (c.speed == 0.0) {
    for (const StepForce* f : win) c.speed += f->v.norm();
    c.speed /= static_cast<double>(win.size());
  }
  c.reynolds = 2.0 * c.radius * c.speed / nu;
  c.stokes = 6.0 * M_PI * c.mu * c.radius * c.speed;
  double fx = 0;
  Eigen::Vector2d side = Eigen::Vector2d::Zero();
  for (const StepForce* f : win) {
    fx += f->force.x();
    side += Eigen::Vector2d(f->force.y(), f->force.z());
  }
  const double n = static_cast<double>(win.size());
  c.drag = -fx / n;
  side /= n;
  c.side = side.cwiseAbs().maxCoeff();
  c.side_y = std::abs(side.x());
  // Noise of the sideways mean: the spread of 6 block means (blocks longer than the force's
  // correlation time), standard error = sd / sqrt(6).
  const int blocks = 6;
  double noise = 0;
  for (int a = 0; a < 3; ++a) {
    std::vector<double> means(blocks, 0.0);
    std::vector<int> counts(blocks, 0);
    for (std::size_t k = 0; k < win.size(); ++k) {
      const int b = static_cast<int>(k * blocks / win.size());
      means[b] += win[k]->force[(a + 1) % 3];
      ++counts[b];
    }
    double mean = 0, var = 0;
    for (int b = 0; b < blocks; ++b) mean += (means[b] /= counts[b]) / blocks;
    for (int b = 0; b < blocks; ++b) var += (means[b] - mean) * (means[b] - mean) / (blocks - 1);
    if (a == 2) c.drag_noise = std::sqrt(var / blocks);  // (the drag, axis x)
    else noise = std::max(noise, std::sqrt(var / blocks));
  }
  c.side_noise = noise;
  return c;
}

double schillerNaumann(double re) { return 1.0 + 0.15 * std::pow(re, 0.687); }

double diFeliceWallFactor(double lambda, double re) {
  // Di Felice (1996): U_t / U_inf = ((1 - lambda) / (1 - 0.33 lambda))^alpha at the same force,
  // alpha = (3.3 + 0.085 Re) / (1 + 0.1 Re).
  const double alpha = (3.3 + 0.085 * re) / (1.0 + 0.1 * re);
  const double f = std::pow((1.0 - lambda) / (1.0 - 0.33 * lambda), alpha);
  // The same as a drag factor at the same speed: F_inf(U_inf) = K F_inf(U_t), with F_inf ~ U^n
  // locally, n = dln F / dln U of Schiller-Naumann's F = 6 pi mu R U (1 + 0.15 Re^0.687).
  const double sn = schillerNaumann(re), n = 1.0 + 0.687 * (sn - 1.0) / sn;
  return std::pow(f, -n);
}

void moderateReBand(double radius, double dx, double side, double speed, double nu, double& lo, double& hi) {
  // The no-slip surface within R -+ dx/2 (as stokesBand); the square duct between the circular
  // tube of the same cross-section (D = 2 side / sqrt(pi): the corners counted as near as the
  // faces, the smaller factor) and the inscribed one (D = side, the larger).
  auto value = [&](double r, double tube) {
    const double re = 2.0 * r * speed / nu;
    return r / radius * schillerNaumann(re) * diFeliceWallFactor(2.0 * r / tube, re);
  };
  lo = value(radius - 0.5 * dx, 2.0 * side / std::sqrt(M_PI));
  hi = value(radius + 0.5 * dx, side);
}

double sinkingDragBound(double radius, double dx, double tank) {
  const double resolution = std::pow(1.0 + 0.5 * dx / radius, 2);
  const double wall = 1.0 / std::pow(1.0 - std::pow(2.0 * radius / tank, 1.5), 2);
  return 0.5 * resolution * wall;
}

double sinkingSpeed(double t, double m, double V, double R, double rho, double g, double cm, double cd) {
  // Net weight over the mass with added mass: the first acceleration a0.
  const double net = (m - rho * V) * g, a0 = net / (m + cm * rho * V);
  if (cd <= 0.0) return a0 * t;
  // Terminal speed where the quadratic drag 1/2 rho C_d pi R^2 v^2 carries the net weight.
  const double vt = std::sqrt(2.0 * net / (rho * cd * M_PI * R * R));
  return vt * std::tanh(a0 * t / vt);
}

namespace {

/// sinkingBall's check of one run `b` at spacing dx.
SinkCheck sinkFromRun(const BallRun& b, double dx, double skip, double until, double cm_lo, double cm_hi, double cd_lo,
                      double cd_hi) {
  SinkCheck c;
  c.dx = dx;
  if (!ran(b, c)) return c;
  const double hold = b.hold, end = b.duration, rho = b.rho, g = b.g, volume = b.volume, mass = b.mass, nu = b.nu;
  const std::vector<StepForce>& log = b.log;
  c.density = mass / volume;
  c.window = end - hold;
  // The ringing: over the last 0.1 s of the hold, the swing of int (F - mean F) dt over m + C_m rho V.
  double held = 0, span = 0;
  for (std::size_t k = 0; k + 1 < log.size(); ++k)
    if (log[k].time >= hold - 0.1 && log[k].time < hold) {
      held += log[k].force.z() * (log[k + 1].time - log[k].time);
      span += log[k + 1].time - log[k].time;
    }
  if (!(span > 0.0)) {
    c.exit_code = 1;
    c.message = "too few steps in the hold";
    return c;
  }
  held /= span;
  double integral = 0, imin = 0, imax = 0;
  for (std::size_t k = 0; k + 1 < log.size(); ++k)
    if (log[k].time >= hold - 0.1 && log[k].time < hold) {
      integral += (log[k].force.z() - held) * (log[k + 1].time - log[k].time);
      imin = std::min(imin, integral);
      imax = std::max(imax, integral);
    }
  c.ringing = (imax - imin) / (mass + cm_lo * rho * volume);
  // Every logged step from `skip` after the release: the downward speed against the envelope;
  // and the momentum balance for the mean drag (C_m = 1/2).
  double v2_int = 0, v_T = 0, T = 0;
  for (std::size_t k = 0; k < log.size(); ++k) {
    const StepForce& s = log[k];
    const double t = s.time - hold;
    if (t >= 0.0 && k + 1 < log.size()) {
      v2_int += s.v.z() * s.v.z() * (log[k + 1].time - s.time);
      v_T = -log[k + 1].v.z();
      T = log[k + 1].time - hold;
    }
    if (t < skip - 1e-12) continue;
    const double v = -s.v.z();
    const double lo = sinkingSpeed(t, mass, volume, c.radius, rho, g, cm_hi, cd_hi);
    const double hi = sinkingSpeed(t, mass, volume, c.radius, rho, g, cm_lo, cd_lo);
    c.above = std::max(c.above, v - hi - c.ringing);
    const double out = t <= until + 1e-12 ? std::max({lo - c.ringing - v, v - hi - c.ringing, 0.0}) : 0.0;
    if (out > c.worst) {
      c.worst = out;
      c.worst_time = t;
    }
    c.t.push_back(t);
    c.v.push_back(v);
    c.lo.push_back(lo);
    c.hi.push_back(hi);
  }
  c.held_over_buoyancy = held / (rho * g * volume);
  if (v2_int > 0.0) {
    c.cd_effective = ((mass - rho * volume) * g * T - (mass + 0.5 * rho * volume) * v_T) /
                     (0.5 * rho * M_PI * c.radius * c.radius * v2_int);
    c.cd_ringing = (mass + 0.5 * rho * volume) * c.ringing / (0.5 * rho * M_PI * c.radius * c.radius * v2_int);
  }
  if (c.t.size() < 3) {
    c.exit_code = 1;
    c.message = "too few steps after the release";
    return c;
  }
  c.v_end = c.v.back();
  c.v_lo = c.lo.back();
  c.v_hi = c.hi.back();
  c.reynolds = 2.0 * c.radius * c.v_end / nu;
  return c;
}

}  // namespace

SinkCheck sinkingBall(const std::string& scene, double dx, double skip, double until, double cm_lo, double cm_hi,
                      double cd_lo, double cd_hi, const std::vector<std::string>& sets, const std::string& device) {
  return sinkFromRun(runBall(checkRun(scene, dx, {}, sets, device)), dx, skip, until, cm_lo, cm_hi, cd_lo, cd_hi);
}

SinkCheck sinkingBallHeldDrag(const std::string& scene, double dx, double skip, double until, double cm_lo, double cm_hi,
                              double cd_lo, double cd_hi, const std::vector<std::string>& sets, const std::string& device) {
  // The free run, checked as sinkingBall, and the same ball held throughout.
  const BallRun f = runBall(checkRun(scene, dx, {}, sets, device));
  SinkCheck c = sinkFromRun(f, dx, skip, until, cm_lo, cm_hi, cd_lo, cd_hi);
  if (c.exit_code != 0) return c;
  RunOptions held_options = checkRun(scene, dx, {}, sets, device);
  held_options.sets.push_back("rigid_bodies[0].hold_until=1e6");
  const BallRun h = runBall(held_options);
  if (h.result.exit_code != 0 || h.log.empty()) {
    c.exit_code = h.result.exit_code != 0 ? h.result.exit_code : 1;
    c.message = h.result.exit_code != 0 ? h.result.message : "no steps logged in the held run";
    return c;
  }
  c.wall_seconds += h.result.wall_seconds;
  // The held force at time t, linear between its steps.
  auto heldAt = [&](double t) {
    auto it = std::lower_bound(h.log.begin(), h.log.end(), t, [](const StepForce& s, double x) { return s.time < x; });
    if (it == h.log.begin()) return it->force.z();
    if (it == h.log.end()) return h.log.back().force.z();
    const StepForce& b = *it;
    const StepForce& a = *(it - 1);
    return a.force.z() + (b.force.z() - a.force.z()) * (t - a.time) / (b.time - a.time);
  };
  // Upward fluid force on the sinking ball = held force + C_m rho V dv/dt + D (v, D: downward
  // speed and upward drag), so int D dt = int (F_free - F_held) dt - C_m rho V v(T).
  // The normal equations of the three-term fit (fit_cm, fit_cd, fit_b) accumulate on the way.
  double impulse = 0, v2_int = 0, v_T = 0, x = 0;
  Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
  const double mass_term = f.rho * f.volume, drag_term = 0.5 * f.rho * M_PI * c.radius * c.radius;
  for (std::size_t k = 0; k + 1 < f.log.size(); ++k) {
    const StepForce& s = f.log[k];
    if (s.time < f.hold - 1e-12) continue;
    const double dt = f.log[k + 1].time - s.time;
    impulse += (s.force.z() - heldAt(s.time)) * dt;
    v2_int += s.v.z() * s.v.z() * dt;
    v_T = -f.log[k + 1].v.z();
    x += v_T * dt;  // symplectic Euler: the position moves with the new velocity
    if (f.log[k + 1].time - f.hold < skip - 1e-12) continue;
    const Eigen::Vector3d col(mass_term * v_T, drag_term * v2_int, x);
    normal += col * col.transpose();
    rhs += col * impulse;
  }
  if (v2_int > 0.0)
    c.cd_held_subtracted = (impulse - 0.5 * f.rho * f.volume * v_T) / (0.5 * f.rho * M_PI * c.radius * c.radius * v2_int);
  if (normal.determinant() != 0.0) {
    const Eigen::Vector3d fit = normal.ldlt().solve(rhs);
    c.fit_cm = fit.x();
    c.fit_cd = fit.y();
    c.fit_b = fit.z();
  }
  return c;
}

FallCheck fallingBall(const std::string& scene, double dx, const std::vector<std::string>& sets,
                      const std::string& device) {
  FallCheck c;
  c.dx = dx;
  const BallRun b = runBall(checkRun(scene, dx, {}, sets, device));
  if (!ran(b, c)) return c;
  const double hold = b.hold, end = b.duration, nu = b.nu, rho = b.rho, box = b.box, g = b.g;
  const double volume = b.volume, mass = b.mass;
  const std::vector<StepForce>& log = b.log;
  // Stokes: 6 pi mu R U = |m - rho V| g, mu = rho nu. A ball lighter than the liquid rises: its speed
  // is then taken upward.
  const double down = mass >= rho * volume ? 1.0 : -1.0;
  c.speed_stokes = std::abs(mass - rho * volume) * g / (6.0 * M_PI * rho * nu * c.radius);
  stokesBand(c.radius, dx, box, c.expected_lo, c.expected_hi);
  // The second half of the free time: the flow has set up over the gap to the walls.
  const double from = hold + 0.5 * (end - hold);
  double vz = 0, vx = 0, vy = 0;
  int n = 0;
  for (const StepForce& f : log) {
    if (f.time < from) continue;
    vz += -down * f.v.z();
    vx += f.v.x();
    vy += f.v.y();
    ++n;
  }
  if (n < 12 || !(vz > 0.0)) {
    c.exit_code = 1;
    c.message = "too few steps in the window, or the ball did not move with its net weight";
    return c;
  }
  c.speed = vz / n;
  c.side = std::max(std::abs(vx), std::abs(vy)) / n;
  // The held ball's mean force over the last 0.05 s of the hold: the sampled buoyancy.
  double held = 0;
  int nh = 0;
  for (const StepForce& f : log)
    if (f.time >= hold - 0.05 && f.time < hold) held += f.force.z(), ++nh;
  if (nh > 0) {
    held /= nh;
    c.held_over_buoyancy = held / (rho * g * volume);
    c.ratio_held = down * (mass * g - held) / (6.0 * M_PI * rho * nu * c.radius * c.speed);
  }
  c.reynolds = 2.0 * c.radius * c.speed / nu;
  c.ratio = c.speed_stokes / c.speed;
  return c;
}

FloatCheck risingBlock(const std::string& scene, double dx, const std::vector<std::string>& sets,
                       const std::string& device) {
  FloatCheck c;
  c.dx = dx;
  // Every frame: the fluid count and the box's height; its scene height and size once.
  double z_sum = 0, placed = 0, start = -1, mass = 0, area = 0, rho = 0, from = 0;
  std::size_t particles = 0;
  int n = 0;
  const RunResult r = runScene(checkRun(scene, dx, {}, sets, device), [&](Simulation& sim, const FrameReport&) {
    const Model& m = sim.model();
    const auto& body = m.bodies[0];
    if (start < 0) {
      start = body.spec.position.z();
      placed = body.spec.position.z();
      mass = body.mass;
      c.height = body.spec.size.z();
      rho = m.spec.fluid.phases[0].rest_density;
      const Eigen::Vector3d side = m.spec.domain.max - m.spec.domain.min;
      area = side.x() * side.y();
      from = m.spec.simulation.duration - 0.3;
      c.expected = c.height * mass / (body.volume * rho);
    }
    particles = sim.numFluid();
    if (sim.time() < from - 1e-9) return;
    z_sum += sim.bodies()[0].x.z();
    ++n;
  });
  c.wall_seconds = r.wall_seconds;
  if (r.exit_code != 0 || n == 0) {
    c.exit_code = r.exit_code != 0 ? r.exit_code : 1;
    c.message = r.exit_code != 0 ? r.message : "no frames in the last 0.3 s";
    return c;
  }
  // The scene's own height, before compile's lift: read back from the file's spec.
  const SceneSpec spec = io::loadScene(scene, std::vector<std::string>{"fluid.particle_spacing=" + num(dx)});
  c.lift = placed - spec.rigid_bodies.at(0).position.z();
  const double level = (particles * dx * dx * dx + mass / rho) / area;
  c.draft = level - (z_sum / n - 0.5 * c.height);
  return c;
}

HeaveCheck floatingBallHeave(const std::string& scene, double dx, double duration,
                             const std::vector<std::string>& sets, const std::string& device) {
  HeaveCheck c;
  c.dx = dx;
  // Every frame after the release: (t, z) of the ball; the fluid count and the ball's data once.
  std::vector<std::pair<double, double>> z;
  std::size_t particles = 0;
  double mass = 0, hold = 0, rho = 0, g = 0, area = 0;
  const std::vector<std::string> own = {"rigid_bodies[0].density=500", "simulation.duration=" + num(duration)};
  const RunResult r = runScene(checkRun(scene, dx, own, sets, device), [&](Simulation& sim, const FrameReport&) {
    const Model& m = sim.model();
    particles = sim.numFluid();
    mass = m.bodies[0].mass;
    hold = m.bodies[0].spec.hold_until;
    c.radius = m.bodies[0].spec.radius * m.bodies[0].spec.scale;
    rho = m.spec.fluid.phases[0].rest_density;
    g = m.spec.simulation.gravity.norm();
    const Eigen::Vector3d side = m.spec.domain.max - m.spec.domain.min;
    area = side.x() * side.y();
    if (sim.time() >= hold - 1e-9) z.emplace_back(sim.time(), sim.bodies()[0].x.z());
  });
  c.exit_code = r.exit_code;
  c.message = r.message;
  c.wall_seconds = r.wall_seconds;
  if (r.exit_code != 0) return c;
  // Archimedes: the level of the fluid plus the displaced volume; the mean over the last 0.2 s.
  c.level = (particles * dx * dx * dx + mass / rho) / area;
  int n = 0;
  for (const auto& [t, h] : z)
    if (t >= duration - 0.2 - 1e-9) c.mean += h, ++n;
  if (n < 5) {
    c.exit_code = 1;
    c.message = "fewer than 5 frames in the last 0.2 s";
    return c;
  }
  c.mean /= n;
  c.offset = c.mean - c.level;
  // Crests: local maxima of z above the mean after the release.
  std::vector<std::pair<double, double>> crests;
  for (std::size_t k = 1; k + 1 < z.size(); ++k)
    if (z[k].second > z[k - 1].second && z[k].second >= z[k + 1].second && z[k].second > c.mean)
      crests.push_back(z[k]);
  c.crests = static_cast<int>(crests.size());
  // The heave's closed form: stiffness rho g pi R^2 (the waterplane), mass m + a33.
  const double k = rho * g * M_PI * c.radius * c.radius;
  const double half = 0.5 * rho * 4.0 / 3.0 * M_PI * std::pow(c.radius, 3);
  c.period_lo = 2 * M_PI * std::sqrt((mass + 0.38 * half) / k);
  c.period_hi = 2 * M_PI * std::sqrt((mass + 0.83 * half) / k);
  if (crests.size() < 2) return c;
  // The first two crests: period, logarithmic decrement, damping ratio, undamped period.
  c.crest1 = crests[0].second - c.mean;
  c.crest2 = crests[1].second - c.mean;
  c.period = crests[1].first - crests[0].first;
  const double delta = std::log(c.crest1 / c.crest2);
  c.zeta = delta / std::sqrt(4 * M_PI * M_PI + delta * delta);
  c.period_undamped = c.period * std::sqrt(1 - c.zeta * c.zeta);
  return c;
}

}  // namespace sph::app
