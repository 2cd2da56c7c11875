#include "core/dfsph.h"

#include "core/errors.h"
#include "kernels/shared/body_response.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace sph {

// Work-group size for the per-particle kernels (as the Simulation's).
static constexpr std::size_t kLocal = 64;

// Extrapolated walls' contact (kernels/dfsph.cl, dfsph_wall_contact_accel): range r0 = 0.75 dx, inside
// the rest spacing dx, so that a fluid at rest never touches it (r0 = dx moved the calm tank's
// probes from 3.5 % to 5.5 % off rho0 g (H - z)); stiffness s = dt^2 k_w / dx = 0.3, far from
// symplectic Euler's limit dt^2 k / r0 = s dx / r0 < 4. Between r0 and the wall plane (dx/2 from the
// wall particles) it takes the kinetic energy of a normal speed sqrt(s r0 / dx) (1 - dx / (2 r0))
// dx / dt = 0.16 dx / dt: 2.1 m/s at the 50k dam break's dt ~ 2 ms, more than the thin layers that
// sank slowly through the floor there (p = 0, sliding at ~1 m/s along it). Measured (50k dam break,
// 0.6 s): 89 wall crossings without it, 2 with it. Not enough for a sheet one particle thick that
// lands at 1 m/s on a floor at dt = 4 ms, dx = 1 cm (72 crossings, 31 with it, 32 with s = 2): the
// closed walls' non-penetration contact below (kWallGap) holds those.
static constexpr float kWallContactStiffness = 0.3f;  ///< dt^2 k_w / dx (unit: 1)
static constexpr float kWallContactRange = 0.75f;     ///< r0 / dx (unit: 1)
// Static rigid bodies (session 30). Their surface is one sampled layer of particles, irregular
// (rigid::sampleSurface), with points of the surface up to ~0.75 dx from every particle. With the
// walls' contact (r0 = 0.75 dx) and nothing else, water at rest in scenes/demo_painting.yaml crept
// through such a hole into the tray's wall (a static box 2 cm thick) from t = 0.11 s, 1 cm deep by
// 0.19 s and 9 particles by 0.5 s; the density solve then diverged about them (their factor 20x their
// neighbours'), and the run blew up at 0.544 s (session 29 had blamed the brush's spin-up there). So
// the contact reaches dx at a body's particles, as WCSPH's does at walls and static bodies
// (shared/pair_loops.h), and after the density solve the body's surface is a unilateral contact as
// the closed walls are (dfsph_surface_impulse, the gap below). With the wider contact alone the run
// went on but the stirring still pushed 3 particles through by 1.1 s. The lattice walls keep 0.75 dx
// (a fluid at rest sits dx from them, and dx there moved the calm tank's probes, above).
static constexpr float kSampledContactRange = 1.0f;   ///< r0 / dx at a static body's particles (unit: 1)
static constexpr float kSurfaceGap = 0.25f;           ///< gap / dx from a static body's surface (unit: 1), as kWallGap
// Extrapolated walls' non-penetration (kernels/dfsph.cl, dfsph_wall_impulse): no particle centre
// comes closer than this to a closed domain wall's plane. A quarter spacing: the first layer of a
// fluid at rest sits dx/2 from the plane (its centre dx from the wall particles), so the contact
// never acts on it (the hydrostatic tank is bitwise unchanged), and a landing particle stops where
// the contact above (r0 = 0.75 dx from a wall particle) starts. At dx/2 it acted on the tank's first
// layer, which the column's weight presses a little below dx/2: cutting only its downward
// velocity there lifted it step by step, and the tank's probes read 8.3 % off rho0 g (H - z)
// (limit 5 %; 1.9 % without it). Measured on scenes/tests/dfsph_floor.yaml: 447 wall crossings
// without the contact, 0 with it.
static constexpr float kWallGap = 0.25f;  ///< gap / dx (unit: 1)
// The Chebyshev semi-iteration runs in the solves of steps whose fastest particle moved at least this many spacings
// in the last step (solve(); the two-level solve's default rest test, coarse_rest_travel, but fixed).
static constexpr double kChebyshevTravel = 0.1;  ///< (unit: 1)

float DfsphSolver::wallContactStiffness() const { return extrapolated() ? kWallContactStiffness : 0.0f; }
float DfsphSolver::wallContactRange() { return kWallContactRange; }

cl::Buffer DfsphSolver::makeBuffer(std::size_t bytes) {
  bytes = std::max<std::size_t>(bytes, 16);
  bytes_ += bytes;
  return clCall("allocating a DFSPH buffer", [&] { return cl::Buffer(cl_.context(), CL_MEM_READ_WRITE, bytes); });
}

DfsphSolver::DfsphSolver(ClContext& cl, KernelSet& kernels, std::size_t capacity, std::size_t boundary,
                         const DfsphSpec& spec, double dx, double support, bool one_mass,
                         const Eigen::Vector3d& extent)
    : cl_(cl), kernels_(kernels), spec_(spec), one_mass_(one_mass), dx_(dx) {
  // A particle in the bulk has (4/3) pi (H/dx)^3 neighbours (33 at H = 2 dx); below 60 % of that
  // its support is cut by a free surface (the reference implementation's 20 in 3D at H = 2 dx).
  const double ratio = support / dx;
  min_neighbours_ = static_cast<uint32_t>(0.6 * 4.18879 * ratio * ratio * ratio);
  alpha_ = makeBuffer(capacity * 4);
  source_ = makeBuffer(capacity * 4);
  accel_ = makeBuffer(capacity * 16);
  xt_ = makeBuffer(capacity * 16);
  gwall_ = makeBuffer(capacity * 16);
  err_ = makeBuffer(capacity * 4);
  partial_ = makeBuffer(kChunks * 4);
  const std::size_t nv = spec.viscosity_solve == ViscositySolve::Implicit ? capacity : 0;
  vdiag_ = makeBuffer(nv * 4);
  vr_ = makeBuffer(nv * 16);
  vz_ = makeBuffer(nv * 16);
  vd_ = makeBuffer(nv * 16);
  vq_ = makeBuffer(nv * 16);
  vkeep_ = makeBuffer(nv * 16);
  pdiv_ = makeBuffer(capacity * 4);
  pdens_ = makeBuffer(capacity * 4);
  scratch_a_ = makeBuffer(capacity * 4);
  scratch_b_ = makeBuffer(capacity * 4);
  // The iterate before the last, for the Chebyshev semi-iteration (chebyshev or divergence_chebyshev > 0).
  cheb_ = makeBuffer(spec.chebyshev > 0.0 || spec.divergence_chebyshev > 0.0 ? capacity * 4 : 0);
  // The last density pressure, for a warm start averaged over two steps (warm_average > 0, or
  // warm_average_rest > 0 for the steps at rest).
  const std::size_t np = averaging() ? capacity : 0;
  previous_ = makeBuffer(np * 4);
  previous_out_ = makeBuffer(np * 4);
  vel_before_ = makeBuffer(capacity * 16);
  // Extrapolated walls: each solve's wall pressures (the other variants need none).
  const std::size_t nb = spec.walls == DfsphWalls::Extrapolated ? boundary : 0;
  bp_div_ = makeBuffer(nb * 4);
  bp_dens_ = makeBuffer(nb * 4);
  // ... and each wall particle's fluid neighbours for the step (kernels/dfsph.cl, dfsph_wall_lists).
  wall_list_ = makeBuffer(nb * kWallSlots * 4);
  wall_count_ = makeBuffer(nb * 4);
  wall_active_ = makeBuffer(nb * 4);
  wall_weight_ = makeBuffer(nb * kWallSlots * 4);
  wall_sum_ = makeBuffer(nb * 16);
  wall_active_count_ = makeBuffer(4);
  // Coarse-grid correction: its per-particle and per-aggregate buffers (kernels/dfsph_coarse.cl), when it runs.
  const std::size_t nc = coarse() ? capacity : 0;
  const std::size_t rows = coarse() ? coarseRows(capacity) : 0;
  coarse_rows_ = rows;
  for (cl::Buffer* b : {&cagg_, &cact_, &cres_, &ctres_, &cmem_, &cdp_, &ctrial_}) *b = makeBuffer(nc * 4);
  cbox_ = coarseBox(extent, support);
  const std::size_t box = coarse() ? static_cast<std::size_t>(cbox_[3]) : 0;
  for (cl::Buffer* b : {&cbok_, &cbb_, &cbnum_}) *b = makeBuffer(box * 4);
  ccell_ = makeBuffer(rows * 4);
  cfr_ = makeBuffer(nc * 27 * 2 * 16);
  cmask_ = makeBuffer(nc * 8);
  for (cl::Buffer* b : {&ckval_, &ckcol_}) *b = makeBuffer(rows * 125 * 4);
  for (cl::Buffer* b : {&cb_, &cx_, &cr_, &cph_, &cp_, &cv_, &csh_, &ct_}) *b = makeBuffer(rows * 4);
  cmcount_ = makeBuffer(coarse() ? 8 : 0);
  cpartial_ = makeBuffer(coarse() ? 2 * kChunks * 4 : 0);
  ctheta_ = makeBuffer(coarse() ? 4 : 0);
  // No pressure before the first step (and particles emitted later start from zero: slots past
  // the active count are never written).
  clCall("clearing the DFSPH pressures", [&] {
    auto& q = cl_.queue();
    for (cl::Buffer* b : {&pdiv_, &pdens_, &scratch_a_, &scratch_b_})
      q.enqueueFillBuffer(*b, 0.0f, 0, std::max<std::size_t>(capacity, 4) * 4);
    // warm_average's last pressures too: a particle an inflow emits later averages with 0, not with
    // whatever the buffer held (a bowl filled by an inflow blew up at 0.03 s before this; session 29)
    if (averaging())
      for (cl::Buffer* b : {&previous_, &previous_out_}) q.enqueueFillBuffer(*b, 0.0f, 0, std::max<std::size_t>(capacity, 4) * 4);
    return q.finish();
  });
}

std::array<int32_t, 4> DfsphSolver::coarseBox(const Eigen::Vector3d& extent, double support) {
  // Cells of size H from the domain's lower corner, one more per axis for particles on the upper
  // walls (their floor((x - min) / H) is the count itself when the extent is a multiple of H).
  std::array<int32_t, 4> b{};
  double cells = 1.0;
  for (int a = 0; a < 3; ++a) {
    const double c = std::floor(std::max(0.0, extent[a]) / support) + 1.0;
    b[static_cast<std::size_t>(a)] = static_cast<int32_t>(std::min(c, 1e6));
    cells *= c;
  }
  b[3] = static_cast<int32_t>(std::min(cells, 2e9));
  return b;
}

void DfsphSolver::reorder(std::size_t n, const cl::Buffer& sorted) {
  kernels_.call("dfsph_reorder", n, kLocal, static_cast<uint32_t>(n), sorted, pdiv_, pdens_, scratch_a_, scratch_b_);
  std::swap(pdiv_, scratch_a_);
  std::swap(pdens_, scratch_b_);
  if (have_previous_) {
    kernels_.call("dfsph_reorder_one", n, kLocal, static_cast<uint32_t>(n), sorted, previous_, previous_out_);
    std::swap(previous_, previous_out_);
  }
}

const cl::Buffer& DfsphSolver::stepPressure(std::size_t n) {
  // p_dens + p_div (dfsph_finish says why the sum); scratch_a_ is free between reorder and solve.
  clCall("copying the DFSPH pressure",
         [&] { return cl_.queue().enqueueCopyBuffer(pdens_, scratch_a_, 0, 0, std::max<std::size_t>(n, 1) * 4); });
  if (n > 0) kernels_.call("dfsph_add", n, kLocal, static_cast<uint32_t>(n), scratch_a_, pdiv_);
  return scratch_a_;
}

void DfsphSolver::factors(const SimParams& p, const DfsphFields& f, bool divergence_next, bool with_density) {
  ++steps_;  // one factor pass per step (core/dfsph_coarse.cpp finds the aggregates once per step)
  coarse_travel_ += f.max_speed * p.dt;  // the fastest particle's travel over the steps (coarse_reuse)
  // Before a divergence solve (walls single or extrapolated: dfsph_source), the factor pass also
  // sums its density rate from the same pairs, into source_ (one neighbour pass fewer per step).
  rate_in_source_ = divergence_next && !mirrored();
  // Cloth nodes move inside the solves (kernels/dfsph.cl, dfsph_node_accel; not with mirrored walls,
  // whose iteration has no residual pass): each node's slot gets its response (M_b^-1, 1 / m_b), the
  // rest of the boundary zeros.
  // Rigid bodies too with body_coupling strong (dfsph_body_accel; the same rule for the walls).
  cloth_ = f.n_nodes > 0 && !mirrored();
  bodies_ = f.n_bodies > 0 && !mirrored();
  nodes_ = cloth_ || bodies_;
  if (with_density && cloth_)
    throw std::logic_error("DfsphSolver::factors: the density pass cannot run with the factors while cloth nodes move inside the solves");
  if (nodes_) {
    if (!bminv_()) {
      bminv_ = makeBuffer(std::size_t(f.n_boundary) * 48);
      bacc_ = makeBuffer(std::size_t(f.n_boundary) * 16);
    }
    if (cloth_ && !nacc_div_())
      for (cl::Buffer* b : {&nacc_div_, &nacc_dens_, &nacc_tmp_}) {
        *b = makeBuffer(std::size_t(f.n_nodes) * 16);
        clCall("clearing the node accelerations",
               [&] { return cl_.queue().enqueueFillBuffer(*b, cl_float4{}, 0, std::size_t(f.n_nodes) * 16); });
      }
    if (bodies_ && !bbacc_div_()) {
      for (cl::Buffer* b : {&bbacc_div_, &bbacc_dens_}) {
        *b = makeBuffer(std::size_t(f.n_bodies) * 32);
        clCall("clearing the body accelerations",
               [&] { return cl_.queue().enqueueFillBuffer(*b, cl_float4{}, 0, std::size_t(f.n_bodies) * 32); });
      }
      berr_ = makeBuffer(std::size_t(f.n_bodies) * 4);
    }
    clCall("clearing the node slots", [&] {
      cl_.queue().enqueueFillBuffer(bminv_, cl_float4{}, 0, std::size_t(f.n_boundary) * 48);
      return cl_.queue().enqueueFillBuffer(bacc_, cl_float4{}, 0, std::size_t(f.n_boundary) * 16);
    });
    if (cloth_)
      kernels_.call("dfsph_node_slots", f.n_nodes, kLocal, p, f.n_nodes, f.node_offset, *f.nodes, *f.response, *f.bslot, *f.pos,
                  *f.phase, *f.cell_start, *f.row_start, *f.other, bminv_, bacc_);
  }
  kernels_.call("dfsph_factor", p.n_fluid, kLocal, p, *f.pos, *f.phase, *f.density, *f.snbr, *f.snbr_count, *f.bpos,
                *f.sbnbr, *f.sbnbr_count, wallFactor(), alpha_, *f.bvel, gwall_, rate_in_source_ ? 1 : 0, *f.vel,
                source_, one_mass_ ? 1 : 0, nodes_ ? 1 : 0, nodes_ ? bminv_ : gwall_, with_density ? 1 : 0,
                *f.pressure, *f.pterm, f.stamp, *f.bmark);
  // Extrapolated walls: the fluid near each wall particle, listed once per step for the wall
  // pressure of every iteration (positions do not change during the solves).
  // Only the wall particles with fluid near them (the active ones) take a pressure in the
  // iterations; their count comes to the host once per step, to size those passes.
  n_wall_active_ = 0;
  if (extrapolated() && f.n_boundary > 0) {
    clCall("clearing the active wall count",
           [&] { return cl_.queue().enqueueFillBuffer(wall_active_count_, uint32_t(0), 0, 4); });
    kernels_.call("dfsph_wall_lists", f.n_boundary, kLocal, p, f.n_boundary, f.stamp, *f.bpos, *f.bmark, *f.pos,
                  *f.cell_start, kWallSlots, wall_list_, wall_count_, bp_div_, bp_dens_, wall_active_count_,
                  wall_active_, *f.density, wall_weight_, wall_sum_);
    clCall("reading the active wall count", [&] {
      return cl_.queue().enqueueReadBuffer(wall_active_count_, CL_TRUE, 0, 4, &n_wall_active_);
    });
  }
}

void DfsphSolver::boundaryPressure(Kind kind, const SimParams& p, const DfsphFields& f, const cl::Buffer& pressure) {
  if (n_wall_active_ == 0) return;  // every wall pressure is 0 (dfsph_wall_lists)
  // Adami et al. 2012 eq. 27 (pressure.cl, boundary_pressure): p_b = (sum_f p_f W_bf + g . sum_f
  // rho_f r_bf W_bf) / sum_f W_bf, projected to >= 0; the divergence solve's without gravity.
  SimParams q = p;
  if (kind == Kind::Divergence) q.gravity[0] = q.gravity[1] = q.gravity[2] = 0.0f;
  // The pairs come from this step's lists (dfsph_wall_lists): bitwise boundary_pressure's p_b.
  kernels_.call("dfsph_wall_list_pressure", n_wall_active_, kLocal, q, n_wall_active_, wall_active_, *f.bpos, *f.pos,
                *f.density, pressure, *f.cell_start, kWallSlots, wall_list_, wall_count_, wallPressure(kind),
                wall_weight_, wall_sum_);
}

void DfsphSolver::source(Kind kind, const SimParams& p, const DfsphFields& f, cl::Buffer& pressure, bool at_rest) {
  // The pressure is kept in Pa, not rescaled when dt changes: the hydrostatic pressure that most
  // of it is does not depend on dt (the reference implementation keeps p dt^2, which would scale a
  // resting column's pressure by (dt_prev / dt)^2 after each change of step).
  const bool div = kind == Kind::Divergence;
  // Warm start (B&K 2017 section 4.4): the last step's pressure where the flow now compresses, all
  // of it (the projected iteration can lower a pressure again; half of it, as the reference, left
  // the hydrostatic tank's column sagging each step: 88 iterations per step against 25).
  const double warm = spec_.warm_start ? 1.0 : 0.0;
  // The divergence solve's density rate may be in source_ already (factors(), with the factor pass).
  const int rate_in_source = div && rate_in_source_ ? 1 : 0;
  rate_in_source_ = false;
  // The density solve's warm start averaged over the last two steps (kernels/dfsph.cl,
  // dfsph_warm_average): p <- p + gamma (p_prev - p), and p_prev <- the unaveraged p for the next step.
  // gamma is warm_average, or warm_average_rest where the step is at rest if that is larger: restarted
  // in full, the part of p the last solve added for its own step's error is applied again a step late,
  // a period-2 swing; at rest, where the loose default bound leaves it in place, it decided by rounding
  // whether the 0.2 m tank was calm or rang by 1-2 kPa between steps (docs/dfsph.md, session 47). The
  // last pressure is kept in every step, so the first step at rest averages with the step before it.
  if (!div && averaging() && p.n_fluid > 0) {  // averaging() includes warm_start
    const double gamma = std::max(spec_.warm_average, at_rest ? spec_.warm_average_rest : 0.0);
    const std::size_t bytes = std::size_t(p.n_fluid) * 4;
    clCall("keeping the last density pressure", [&] {
      auto& q = cl_.queue();
      if (!have_previous_) q.enqueueCopyBuffer(pressure, previous_, 0, 0, bytes);  // the first step: p itself
      return q.enqueueCopyBuffer(pressure, previous_out_, 0, 0, bytes);
    });
    have_previous_ = true;
    if (gamma > 0.0)
      kernels_.call("dfsph_warm_average", p.n_fluid, kLocal, static_cast<uint32_t>(p.n_fluid), pressure, previous_,
                    static_cast<float>(gamma));
    std::swap(previous_, previous_out_);
  }
  // The density solve's warm start filtered (kernels/dfsph.cl, dfsph_warm_filter): the last pressure
  // less beta of its particle-scale part. scratch_b_ is free here (a reorder target only).
  if (!div && spec_.warm_start && spec_.warm_smoothing > 0.0 && p.n_fluid > 0) {
    kernels_.call("dfsph_warm_filter", p.n_fluid, kLocal, p, *f.pos, *f.phase, *f.snbr, *f.snbr_count, pressure,
                  static_cast<float>(spec_.warm_smoothing), scratch_b_);
    clCall("copying the filtered warm start", [&] {
      return cl_.queue().enqueueCopyBuffer(scratch_b_, pressure, 0, 0, std::size_t(p.n_fluid) * 4);
    });
  }
  // The density solve with extrapolated walls and nothing moving inside the solves: its warm start does
  // not depend on the source (kernels/dfsph.cl, dfsph_source: warm_all, no neighbour-count rule), so the
  // starting pressure comes first, then its wall pressures, then the source and the first iteration's
  // accelerations in one pass over the neighbours (dfsph_source_accel; the same bits as dfsph_source and
  // iterate()'s first dfsph_pressure_accel; performance: docs/dfsph.md, session 54).
  if (!div && extrapolated() && !nodes_) {
    kernels_.call("dfsph_warm_pack", p.n_fluid, kLocal, p, *f.pos, *f.phase, *f.density, static_cast<float>(warm),
                  pressure, xt_);
    boundaryPressure(kind, p, f, pressure);
    kernels_.call("dfsph_source_accel", p.n_fluid, kLocal, p, xt_, *f.vel, *f.phase, *f.density, pressure, *f.snbr,
                  *f.snbr_count, *f.bpos, *f.sbnbr, *f.sbnbr_count, wallFactor(), wallPressure(kind), 1, accel_,
                  gwall_, source_);
    accel_ready_ = true;
    return;
  }
  kernels_.call("dfsph_source", p.n_fluid, kLocal, p, *f.pos, *f.vel, *f.phase, *f.density, *f.snbr, *f.snbr_count,
                *f.bpos, *f.bvel, *f.sbnbr, *f.sbnbr_count, div ? 0 : 1, div ? min_neighbours_ : 0u,
                static_cast<float>(warm), extrapolated() ? 1 : 0, source_, pressure, xt_, gwall_, rate_in_source);
}

void DfsphSolver::iterate(Kind kind, const SimParams& p, const DfsphFields& f, cl::Buffer& pressure) {
  // Extrapolated walls: the wall pressures of the current pressures first.
  // (unless source() computed them already: accel_ready_)
  const int use_bp = extrapolated() ? 1 : 0;
  if (!accel_ready_) {
    if (use_bp) boundaryPressure(kind, p, f, pressure);
    kernels_.call("dfsph_pressure_accel", p.n_fluid, kLocal, p, xt_, *f.phase, *f.density, pressure, *f.snbr,
                  *f.snbr_count, *f.bpos, *f.sbnbr, *f.sbnbr_count, wallFactor(), wallPressure(kind), use_bp, accel_, gwall_);
  }
  accel_ready_ = false;
  // Cloth nodes and bodies: their accelerations under the same pressures (the residual counts them).
  if (cloth_) nodeAccel(kind, p, f);
  if (bodies_) bodyAccel(kind, p, f, 0.5f, true);
  const uint32_t min_nbr = kind == Kind::Divergence ? min_neighbours_ : 0u;
  // Chebyshev semi-iteration (spec chebyshev, divergence_chebyshev; Golub & Varga 1961, as Wang 2015 uses it
  // for position-based dynamics): the kernel takes x_{k-1} + w (x_jacobi - x_{k-1}) for w != 1 (w = 0: plain
  // Jacobi, no x_{k-1} kept). The sequence starts at each solve and after each coarse correction.
  const double rho = !cheb_on_ ? 0.0 : kind == Kind::Divergence ? spec_.divergence_chebyshev : spec_.chebyshev;
  float cheb = 0.0f;
  if (rho > 0.0) {
    const int k = ++cheb_k_;
    if (k == 1) cheb_w_ = 1.0;
    else if (k == 2) cheb_w_ = 2.0 / (2.0 - rho * rho);
    else cheb_w_ = 4.0 / (4.0 - rho * rho * cheb_w_);
    cheb = static_cast<float>(cheb_w_);
  }
  kernels_.call("dfsph_jacobi", p.n_fluid, kLocal, p, *f.pos, accel_, alpha_, source_, *f.snbr, *f.snbr_count,
                *f.bpos, *f.sbnbr, *f.sbnbr_count, min_nbr, static_cast<float>(spec_.relaxation), extrapolated() ? 1 : 0, pressure, err_,
                *f.phase, *f.density, xt_, gwall_, nodes_ ? 1 : 0, nodes_ ? bacc_ : accel_, cheb, cheb_);
}

void DfsphSolver::nodeAccel(Kind kind, const SimParams& p, const DfsphFields& f) {
  // One block-Jacobi sweep of the nodes' accelerations under the current pressures (kernels/dfsph.cl,
  // dfsph_node_accel), from the solve's last sweep into the scratch half, then swapped.
  cl::Buffer& cur = kind == Kind::Divergence ? nacc_div_ : nacc_dens_;
  kernels_.call("dfsph_node_accel", f.n_nodes, kLocal, p, f.n_nodes, f.node_offset, *f.nodes, bminv_, *f.bslot, *f.bpos, xt_,
                *f.phase, *f.density, *f.cell_start, wallFactor(), wallPressure(kind), extrapolated() ? 1 : 0,
                *f.row_start, *f.spring, *f.other, *f.prm, *f.broken, cur, nacc_tmp_, bacc_);
  std::swap(cur, nacc_tmp_);
}

void DfsphSolver::bodyAccel(Kind kind, const SimParams& p, const DfsphFields& f, float relax, bool slots) {
  // kernels/dfsph.cl (a)-(c): each body particle's force, per body (a, alpha) in particle order, and
  // (while iterating) each particle's slot.
  cl::Buffer& acc = kind == Kind::Divergence ? bbacc_div_ : bbacc_dens_;
  const int use_bp = extrapolated() ? 1 : 0;
  kernels_.call("dfsph_body_force", f.n_moving, kLocal, p, f.n_moving, f.n_static, *f.bsrc, *f.bslot, wallPressure(kind),
                use_bp, xt_, *f.phase, *f.density, *f.cell_start, wallFactor(), *f.body_force);
  kernels_.call("dfsph_body_accel", f.n_bodies, 0, f.n_bodies, f.n_static, *f.body_range, *f.bsrc, *f.body_data,
                *f.body_force, relax, acc, berr_);
  if (slots)
    kernels_.call("dfsph_body_slots", f.n_moving, kLocal, f.n_moving, f.n_static, *f.body_of, *f.bslot, *f.bsrc,
                  *f.body_data, acc, 0, bacc_);
}

void DfsphSolver::apply(Kind kind, const SimParams& p, const DfsphFields& f, const cl::Buffer& pressure) {
  const int use_bp = extrapolated() ? 1 : 0;
  if (use_bp) boundaryPressure(kind, p, f, pressure);
  kernels_.call("dfsph_apply_pressure", p.n_fluid, kLocal, p, xt_, *f.vel, *f.phase, *f.density, pressure, *f.snbr,
                *f.snbr_count, *f.bpos, *f.sbnbr, *f.sbnbr_count, wallFactor(), wallPressure(kind), use_bp, gwall_);
  // Cloth nodes after the divergence solve: their acceleration under its final pressures, for the
  // density solve (densitySolve(), dfsph_node_rate).
  if (cloth_ && kind == Kind::Divergence) nodeAccel(kind, p, f);
  // Bodies after the divergence solve: their acceleration under its final pressures (not relaxed),
  // for the density solve's rate (densitySolve()).
  if (bodies_ && kind == Kind::Divergence) {
    bodyAccel(kind, p, f, 1.0f, false);
    body_div_ready_ = true;
  }
}

// --- Mirrored walls: the first version's iteration (kernels/dfsph.cl) ----------------------

void DfsphSolver::sourceIncrements(Kind kind, const SimParams& p, const DfsphFields& f, bool warm) {
  const int w = warm ? 1 : 0;
  const float omega = static_cast<float>(spec_.relaxation);
  if (kind == Kind::Divergence)
    kernels_.call("dfsph_divergence_source", p.n_fluid, kLocal, p, *f.pos, *f.vel, alpha_, *f.snbr, *f.snbr_count,
                  *f.bpos, *f.bvel, *f.sbnbr, *f.sbnbr_count, min_neighbours_, w, omega, scratch_a_, source_, err_,
                  *f.phase, *f.density, xt_, gwall_);
  else
    kernels_.call("dfsph_density_source", p.n_fluid, kLocal, p, *f.pos, *f.vel, *f.phase, *f.density, alpha_,
                  *f.snbr, *f.snbr_count, *f.bpos, *f.bvel, *f.sbnbr, *f.sbnbr_count, w, omega, scratch_a_, source_, err_, xt_, gwall_);
}

void DfsphSolver::applyIncrements(const SimParams& p, const DfsphFields& f, cl::Buffer& pacc) {
  kernels_.call("dfsph_apply_increments", p.n_fluid, kLocal, p, xt_, *f.vel, *f.phase, *f.density, source_, pacc, *f.snbr,
                *f.snbr_count, *f.bpos, *f.sbnbr, *f.sbnbr_count, gwall_);
}

DfsphSolveResult DfsphSolver::solveMirrored(Kind kind, const SimParams& p, const DfsphFields& f) {
  const bool div = kind == Kind::Divergence;
  cl::Buffer& pacc = div ? pdiv_ : pdens_;
  const std::size_t n = p.n_fluid;
  const double bound = div ? spec_.divergence_error : spec_.density_error;
  const int min_it = div ? spec_.divergence_min_iterations : spec_.min_iterations;
  const int max_it = div ? spec_.divergence_max_iterations : spec_.max_iterations;
  // Warm start (B&K 2017 section 4.4): half the previous step's pressure where the flow now
  // compresses (kernels/dfsph.cl, dfsph_warm) is applied first (scratch_a_ holds the previous
  // pressure meanwhile); without it the solve starts from zero.
  clCall("starting a DFSPH solve", [&] {
    auto& q = cl_.queue();
    if (spec_.warm_start) q.enqueueCopyBuffer(pacc, scratch_a_, 0, 0, std::max<std::size_t>(n, 1) * 4);
    return q.enqueueFillBuffer(pacc, 0.0f, 0, std::max<std::size_t>(n, 1) * 4);
  });
  if (spec_.warm_start) {
    sourceIncrements(kind, p, f, true);
    applyIncrements(p, f, pacc);
  }
  // Jacobi iterations: pressures from the velocities, the error of those velocities, then the
  // velocities from the pressures, until the error is within the bound.
  DfsphSolveResult r;
  sourceIncrements(kind, p, f, false);
  r.error = averageError(n);
  while ((r.iterations < min_it || r.error > bound) && r.iterations < max_it) {
    applyIncrements(p, f, pacc);
    sourceIncrements(kind, p, f, false);
    r.error = averageError(n);
    ++r.iterations;
  }
  r.converged = r.error <= bound;
  return r;
}

namespace {
// The implicit viscosity's free rigid bodies (DfsphSolver::viscositySolve): six unknowns each, the change dU of
// the body's unknown from its start, kept on the host in double. A body's row is A_B dU = r_B with
// A_B = N^-1 / g + dt sum_b K_b G_b^T G_b (N its mobility over the step, body_response.h; G_b maps the body's
// velocity to its particle b's, v_b = V + w x r_b; K_b = sum_i m_i k_ib the particle's viscous sum), and the
// conjugate gradients take A_B^-1 as its preconditioner. The per-particle sums come from
// viscosity_cg_body_gather (f = sum_i m_i k_ib (x_i - u_b), K, and the arm r_b), summed here in particle order.
struct BodyUnknowns {
  using Vector6 = Eigen::Matrix<double, 6, 1>;
  using Matrix6 = Eigen::Matrix<double, 6, 6>;
  struct Row {
    Matrix6 N = Matrix6::Zero();  // the mobility over the step
    Matrix6 Mg = Matrix6::Zero(), A = Matrix6::Zero(), P = Matrix6::Zero();  // N^-1 / g, the block, its inverse
    Vector6 x = Vector6::Zero(), r = Vector6::Zero(), z = Vector6::Zero(), d = Vector6::Zero(), q = Vector6::Zero();
    bool free = false;
  };
  std::vector<Row> rows;
  std::vector<uint32_t> body_of;     // per moving particle
  std::vector<Eigen::Vector4f> arm;  // per moving particle: r_b (the gather's second output)

  /// The rows from the bodies' response blocks (DFSPH_BODY_STRIDE float4 each): which are free, N, N^-1 / g.
  void load(const std::vector<Eigen::Vector4f>& data, uint32_t nbod, double g) {
    rows.assign(nbod, Row());
    for (uint32_t b = 0; b < nbod; ++b) {
      const Eigen::Vector4f* d = &data[std::size_t(b) * DFSPH_BODY_STRIDE];
      rows[b].free = d[0].w() > 0.5f;
      if (!rows[b].free) continue;
      Matrix6 N;
      for (int r = 0; r < 6; ++r) {
        N.block<1, 3>(r, 0) = d[3 + 2 * r].head<3>().cast<double>().transpose();
        N.block<1, 3>(r, 3) = d[4 + 2 * r].head<3>().cast<double>().transpose();
      }
      rows[b].N = N;
      rows[b].Mg = (0.5 * (N + N.transpose())).inverse() / g;
      rows[b].A = rows[b].Mg;
    }
  }
  /// Each body's wrench (sum f, sum r x f) of per-particle forces f at the arms r, in particle order.
  std::vector<Vector6> wrenches(const std::vector<Eigen::Vector4f>& f, const std::vector<Eigen::Vector4f>& r) const {
    std::vector<Vector6> w(rows.size(), Vector6::Zero());
    for (std::size_t k = 0; k < body_of.size(); ++k) {
      if (!rows[body_of[k]].free) continue;
      const Eigen::Vector3d f3 = f[k].head<3>().cast<double>(), r3 = r[k].head<3>().cast<double>();
      w[body_of[k]].head<3>() += f3;
      w[body_of[k]].tail<3>() += r3.cross(f3);
    }
    return w;
  }
  /// The start's gathered sums: the coupling block dt K_b G_b^T G_b into A and dt G_b^T f_b into r, per
  /// particle in order; then z = P r and d = z.
  void start(const std::vector<Eigen::Vector4f>& fk, double dt) {
    for (std::size_t k = 0; k < body_of.size(); ++k) {
      Row& R = rows[body_of[k]];
      if (!R.free) continue;
      const Eigen::Vector3d f3 = fk[k].head<3>().cast<double>(), r3 = arm[k].head<3>().cast<double>();
      Eigen::Matrix3d X;  // [r]x
      X << 0, -r3.z(), r3.y(), r3.z(), 0, -r3.x(), -r3.y(), r3.x(), 0;
      const double dtK = dt * fk[k].w();
      R.A.block<3, 3>(0, 0) += dtK * Eigen::Matrix3d::Identity();
      R.A.block<3, 3>(0, 3) += -dtK * X;
      R.A.block<3, 3>(3, 0) += dtK * X;
      R.A.block<3, 3>(3, 3) += -dtK * X * X;
      R.r.head<3>() += dt * f3;
      R.r.tail<3>() += dt * r3.cross(f3);
    }
    for (Row& R : rows)
      if (R.free) {
        R.P = R.A.inverse();
        R.z = R.P * R.r;
        R.d = R.z;
      }
  }
  /// q_B = (N^-1 / g) d_B - dt sum_b G_b^T sum_i m_i k_ib (d_i - G_b d_B), from the gathered sums fk.
  void apply(const std::vector<Eigen::Vector4f>& fk, double dt) {
    const std::vector<Vector6> w = wrenches(fk, arm);
    for (std::size_t b = 0; b < rows.size(); ++b)
      if (rows[b].free) rows[b].q = rows[b].Mg * rows[b].d - dt * w[b];
  }
  double dot(bool rz) const {  // r . z, or d . q
    double s = 0.0;
    for (const Row& R : rows)
      if (R.free) s += rz ? R.r.dot(R.z) : R.d.dot(R.q);
    return s;
  }
  void update(double alpha) {
    for (Row& R : rows)
      if (R.free) {
        R.x += alpha * R.d;
        R.r -= alpha * R.q;
        R.z = R.P * R.r;
      }
  }
  void direction(double beta) {
    for (Row& R : rows)
      if (R.free) R.d = R.z + beta * R.d;
  }
};
}  // namespace

ViscositySolveResult DfsphSolver::viscositySolve(const SimParams& p, const DfsphFields& f, const cl::Buffer& bvisc_in,
                                                 uint32_t ghost_mode) {
  using Vector6 = BodyUnknowns::Vector6;
  // Preconditioned conjugate gradients on M A x = M w (kernels/viscosity.cl), from x = w. The dot
  // products are chunk sums of per-particle values (dfsph_reduce into err_) added in order in double
  // (errorSum), so the run is bitwise deterministic. x is vel_before_: the viscous forces' velocities.
  ViscositySolveResult res;
  const std::size_t n = p.n_fluid;
  if (n == 0) return res;
  // Incremental (pressure-correction) splitting: the solve starts from w = v + dt (a_p(p_prev) + g),
  // the velocities with the last density solve's pressure (the warm start's) and the step's other
  // forces so far (gravity, in f.acc) applied, and the viscous increment is x - w. A steady Stokes
  // flow, nu L v = grad p / rho - g, is then a fixed point of the step at any dt: (I - dt nu L) v = w
  // gives x = v + dt (a_p + g) = w, and the density solve that follows (from the same warm start)
  // applies p again. Without it (x - v from v), the step's viscosity and pressure act one after the
  // other, and at steps long against dx^2 / nu the towed ball's drag fell with dt (docs/dfsph.md,
  // session 36). g goes in with a_p because at rest they cancel: a_p alone (0.025 m/s up at 2.5 ms in
  // a tank) would meet the walls' and bodies' own velocities in the viscous terms.
  const bool incremental = !mirrored() && spec_.warm_start;
  if (incremental) {
    clCall("keeping the velocities", [&] { return cl_.queue().enqueueCopyBuffer(*f.vel, vkeep_, 0, 0, n * 16); });
    // (dfsph_apply_pressure reads the neighbours' pressures packed in xt_, which holds the divergence
    // solve's: packed again from the density pressure first; the density solve packs its own)
    kernels_.call("viscosity_cg_pack", n, kLocal, p, *f.pos, *f.phase, *f.density, pdens_, xt_);
    apply(Kind::Density, p, f, pdens_);
    kernels_.call("viscosity_cg_predict", n, kLocal, p, *f.acc, *f.vel);
  }
  // Cloth and soft-body nodes and free rigid bodies are unknowns too (kernels/viscosity.cl,
  // viscosity_cg_node_*, viscosity_cg_body_*): their rows follow the fluid's, and every dot product is the
  // fluid's sum plus the nodes' and the bodies'. Where the fluid sees a mirrored (no-slip ghost) velocity
  // 2 v_b - v~_b (ghost_mode: 1 every boundary particle, 2 moving bodies'), the unknown is that velocity's
  // moving part and the mass is halved (g = 2; kernels/viscosity.cl's comment): the system stays symmetric.
  const uint32_t nn = f.n_nodes;
  const bool with_nodes = nn > 0 && f.response && f.nodes && f.bslot && f.cell_start;
  const uint32_t nbod = f.n_bodies, nmov = f.n_moving;
  const bool with_bodies = nbod > 0 && nmov > 0 && f.body_data && f.body_of &&
                           f.bslot && f.bsrc && f.body_force && f.cell_start;
  const float g_node = ghost_mode == 1 ? 2.0f : 1.0f;
  const double g_body = ghost_mode != 0 ? 2.0 : 1.0;
  nodes_solved_ = with_nodes || with_bodies;
  if (nodes_solved_) {
    if (vnode_cap_ < f.n_boundary) {
      vnode_cap_ = f.n_boundary;
      vnode_ = makeBuffer(vnode_cap_ * 4);
      bvisc_nodes_ = makeBuffer(vnode_cap_ * 16);
      bdir_ = makeBuffer(vnode_cap_ * 16);
    }
    clCall("clearing the viscosity's unknown slots",
           [&] { return cl_.queue().enqueueFillBuffer(vnode_, 0u, 0, std::size_t(f.n_boundary) * 4); });
  }
  // The bodies' rows on the host (BodyUnknowns above); x_B is the change dU of the body's unknown.
  BodyUnknowns bodies;
  std::vector<BodyUnknowns::Row>& rows = bodies.rows;
  std::vector<Eigen::Vector4f> fk;  // per moving particle: the gathered sums (f, K)
  // The bodies' directions into their slots (bdir, vflag), from rows[].d.
  auto bodyDirections = [&](bool with_base, const cl::Buffer& base, cl::Buffer& out, bool from_x) {
    std::vector<Eigen::Vector4f> dir(std::size_t(nbod) * 2, Eigen::Vector4f::Zero());
    for (uint32_t b = 0; b < nbod; ++b) {
      const Vector6& v = from_x ? rows[b].x : rows[b].d;
      dir[2 * b].head<3>() = v.head<3>().cast<float>();
      dir[2 * b + 1].head<3>() = v.tail<3>().cast<float>();
    }
    clCall("writing the bodies' directions",
           [&] { return cl_.queue().enqueueWriteBuffer(bdirs_, CL_TRUE, 0, dir.size() * 16, dir.data()); });
    kernels_.call("viscosity_cg_body_dir", nmov, kLocal, nmov, f.n_static, *f.bslot, *f.body_of, *f.body_data,
                  *f.bpos, bdirs_, with_base ? 1 : 0, base, out, vnode_);
  };
  // The start's boundary velocities (bvisc with the nodes' and bodies' incremental starts), copied from
  // bvisc on first use.
  bool start_copied = false;
  auto startBuffer = [&]() -> cl::Buffer& {
    if (!start_copied) {
      if (bvisc_start_cap_ < f.n_boundary) {
        bvisc_start_cap_ = f.n_boundary;
        bvisc_start_ = makeBuffer(bvisc_start_cap_ * 16);
      }
      clCall("copying the viscous boundary velocities", [&] {
        return cl_.queue().enqueueCopyBuffer(bvisc_in, bvisc_start_, 0, 0, std::size_t(f.n_boundary) * 16);
      });
      start_copied = true;
    }
    return bvisc_start_;
  };
  if (with_bodies) {
    if (bodies_cap_ < nmov) {
      bodies_cap_ = nmov;
      bfk_ = makeBuffer(bodies_cap_ * 16);
      brk_ = makeBuffer(bodies_cap_ * 16);
    }
    if (bodies_dir_cap_ < nbod) {
      bodies_dir_cap_ = nbod;
      bdirs_ = makeBuffer(bodies_dir_cap_ * 32);
    }
    std::vector<Eigen::Vector4f> data(std::size_t(nbod) * DFSPH_BODY_STRIDE);
    bodies.body_of.resize(nmov);
    clCall("reading the bodies' responses", [&] {
      cl_.queue().enqueueReadBuffer(*f.body_of, CL_FALSE, 0, std::size_t(nmov) * 4, bodies.body_of.data());
      return cl_.queue().enqueueReadBuffer(*f.body_data, CL_TRUE, 0, data.size() * 16, data.data());
    });
    bodies.load(data, nbod, g_body);
    // The incremental splitting's start for the bodies, as the fluid's w: each free body's unknown starts
    // at U0 + delta, delta = g dt (a_dry + N F_p), a_dry its acceleration without the fluid (gravity,
    // contact, the external wrench: body_response.h) and F_p the last density pressure's force on it
    // (dfsph_body_force on the pressure applied above). Without it a body at its terminal speed met its
    // weight only after the viscous solve, which then slowed it: a 2000 kg/m^3 ball fell 10 % too fast at
    // 1 ms steps in 0.05 m^2/s (docs/dfsph.md, session 38).
    std::vector<Vector6> delta(nbod, Vector6::Zero());
    if (incremental) {
      kernels_.call("dfsph_body_force", nmov, kLocal, p, nmov, f.n_static, *f.bsrc, *f.bslot, wallPressure(Kind::Density),
                    extrapolated() ? 1 : 0, xt_, *f.phase, *f.density, *f.cell_start, wallFactor(), *f.body_force);
      kernels_.call("viscosity_cg_body_gather", nmov, kLocal, p, nmov, f.n_static, *f.bslot, *f.body_of, *f.body_data,
                    *f.bpos, *f.pos, *f.phase, *f.density, *f.cell_start, *f.vel, bvisc_in, bfk_, brk_);  // for r
      std::vector<Eigen::Vector4f> fp(nmov), r0(nmov);
      clCall("reading the bodies' pressure forces", [&] {
        cl_.queue().enqueueReadBuffer(brk_, CL_FALSE, 0, std::size_t(nmov) * 16, r0.data());
        return cl_.queue().enqueueReadBuffer(*f.body_force, CL_TRUE, 0, std::size_t(nmov) * 16, fp.data());
      });
      const std::vector<Vector6> wp = bodies.wrenches(fp, r0);
      for (uint32_t b = 0; b < nbod; ++b)
        if (rows[b].free) {
          const Eigen::Vector4f* d = &data[std::size_t(b) * DFSPH_BODY_STRIDE];
          Vector6 a;
          a << d[1].head<3>().cast<double>(), d[2].head<3>().cast<double>();
          delta[b] = g_body * double(p.dt) * (a + rows[b].N * wp[b]);
        }
    }
    if (incremental) {
      for (uint32_t b = 0; b < nbod; ++b) rows[b].x = delta[b];
      bodyDirections(true, bvisc_in, startBuffer(), true);  // bvisc + G_b delta
      for (uint32_t b = 0; b < nbod; ++b) rows[b].x.setZero();  // x: the change from the start
    }
  }
  // The nodes start at their own velocity. Started as the bodies are, with what the cloth's own forces and the
  // last density pressure do to them in the step, the light hammocks in 0.1 m^2/s blew up (docs/dfsph.md,
  // session 38).
  const cl::Buffer& bvisc = start_copied ? bvisc_start_ : bvisc_in;
  kernels_.call("viscosity_cg_setup", n, kLocal, p, *f.pos, *f.vel, *f.phase, *f.density, *f.snbr, *f.snbr_count,
                *f.bpos, bvisc, *f.sbnbr, *f.sbnbr_count, vdiag_, vel_before_, vr_, vz_, vd_, err_);
  if (with_nodes) {
    if (nodes_cap_ < nn) {
      nodes_cap_ = nn;
      nA_ = makeBuffer(nodes_cap_ * 48);
      nP_ = makeBuffer(nodes_cap_ * 48);
      for (cl::Buffer* b : {&ny_, &nr_, &nz_, &nd_, &nq_, &ndv_}) *b = makeBuffer(nodes_cap_ * 16);
      nerr_ = makeBuffer(nodes_cap_ * 4);
    }
    kernels_.call("viscosity_cg_node_slots", nn, kLocal, nn, f.node_offset, *f.nodes, *f.bslot, vnode_);
    kernels_.call("viscosity_cg_node_setup", nn, kLocal, p, nn, f.node_offset, 1.0f / g_node, *f.nodes, *f.response,
                  *f.bslot, *f.bpos, bvisc, *f.pos, *f.vel, *f.phase, *f.density, *f.cell_start, nA_, nP_, ny_, nr_,
                  nz_, nd_, nerr_);
  }
  if (with_bodies) {
    // the start: the fluid's x0 against the boundary's bvisc
    kernels_.call("viscosity_cg_body_gather", nmov, kLocal, p, nmov, f.n_static, *f.bslot, *f.body_of, *f.body_data,
                  *f.bpos, *f.pos, *f.phase, *f.density, *f.cell_start, *f.vel, bvisc, bfk_, brk_);
    fk.resize(nmov);
    bodies.arm.resize(nmov);
    clCall("reading the bodies' viscous sums", [&] {
      cl_.queue().enqueueReadBuffer(brk_, CL_FALSE, 0, std::size_t(nmov) * 16, bodies.arm.data());
      return cl_.queue().enqueueReadBuffer(bfk_, CL_TRUE, 0, std::size_t(nmov) * 16, fk.data());
    });
    bodies.start(fk, double(p.dt));
  }
  auto dotSum = [&](int which) {  // 0: r . z, 1: d . q
    return errorSum(n) + (with_nodes ? nodeErrorSum(nn) : 0.0) + (with_bodies ? bodies.dot(which == 0) : 0.0);
  };
  double rz = dotSum(0);
  const double rz0 = rz;
  const double tol2 = spec_.viscosity_tolerance * spec_.viscosity_tolerance;
  while (rz > tol2 * rz0 && res.iterations < spec_.viscosity_max_iterations) {
    kernels_.call("viscosity_cg_apply", n, kLocal, p, *f.pos, *f.phase, *f.density, *f.snbr, *f.snbr_count, vdiag_,
                  vd_, vq_, err_);
    if (nodes_solved_) {
      if (with_nodes) kernels_.call("viscosity_cg_node_dir", nn, kLocal, nn, f.node_offset, *f.nodes, *f.bslot, nd_, bdir_);
      if (with_bodies) bodyDirections(false, bdir_, bdir_, false);
      kernels_.call("viscosity_cg_apply_nodes", n, kLocal, p, *f.pos, *f.phase, *f.density, *f.bpos, *f.sbnbr,
                    *f.sbnbr_count, vnode_, bdir_, vd_, vq_, err_);
    }
    if (with_nodes)
      kernels_.call("viscosity_cg_node_apply", nn, kLocal, p, nn, f.node_offset, *f.nodes, *f.bslot, *f.bpos, *f.pos,
                    *f.phase, *f.density, *f.cell_start, nA_, vd_, nd_, nq_, nerr_);
    if (with_bodies) {
      // q_B = (N^-1 / g) d_B - dt sum_b G_b^T sum_i m_i k_ib (d_i - G_b d_B)
      kernels_.call("viscosity_cg_body_gather", nmov, kLocal, p, nmov, f.n_static, *f.bslot, *f.body_of, *f.body_data,
                    *f.bpos, *f.pos, *f.phase, *f.density, *f.cell_start, vd_, bdir_, bfk_, brk_);
      clCall("reading the bodies' viscous sums",
             [&] { return cl_.queue().enqueueReadBuffer(bfk_, CL_TRUE, 0, std::size_t(nmov) * 16, fk.data()); });
      bodies.apply(fk, double(p.dt));
    }
    const double dq = dotSum(1);
    if (!(dq > 0.0)) break;  // d = 0: nothing left to solve
    const float alpha = static_cast<float>(rz / dq);
    kernels_.call("viscosity_cg_update", n, kLocal, p, alpha, *f.phase, vdiag_, vd_, vq_, vel_before_, vr_, vz_, err_);
    if (with_nodes) kernels_.call("viscosity_cg_node_update", nn, kLocal, nn, alpha, nP_, nd_, nq_, ny_, nr_, nz_, nerr_);
    bodies.update(double(alpha));
    const double rz_new = dotSum(0);
    ++res.iterations;
    const float beta = static_cast<float>(rz_new / rz);
    rz = rz_new;
    if (rz <= tol2 * rz0) break;
    kernels_.call("viscosity_cg_direction", n, kLocal, p, beta, vz_, vd_);
    if (with_nodes) kernels_.call("viscosity_cg_node_direction", nn, kLocal, nn, beta, nz_, nd_);
    bodies.direction(double(beta));
  }
  res.residual = rz0 > 0.0 ? std::sqrt(std::max(rz, 0.0) / rz0) : 0.0;
  res.converged = res.residual <= spec_.viscosity_tolerance;
  if (nodes_solved_) {
    // The nodes' and bodies' reaction is gathered with their solved velocities (Simulation::gatherClothForces,
    // gatherBodyForces), and the density solve sees them move by it (densitySolve).
    clCall("copying the viscous boundary velocities", [&] {
      return cl_.queue().enqueueCopyBuffer(bvisc, bvisc_nodes_, 0, 0, std::size_t(f.n_boundary) * 16);
    });
    if (with_nodes)
      kernels_.call("viscosity_cg_node_finish", nn, kLocal, nn, f.node_offset, 1.0f / g_node, *f.nodes, *f.bslot, bvisc,
                    ny_, bvisc_nodes_, ndv_);
    if (with_bodies) bodyDirections(true, bvisc, bvisc_nodes_, true);  // bvisc + G_b dU; bdirs_ keeps dU
  }
  node_dv_pending_ = with_nodes;
  body_dv_pending_ = with_bodies;
  body_inv_g_ = static_cast<float>(1.0 / g_body);
  kernels_.call("viscosity_cg_finish", n, kLocal, p, *f.vel, vel_before_, *f.acc);
  if (incremental)
    clCall("restoring the velocities", [&] { return cl_.queue().enqueueCopyBuffer(vkeep_, *f.vel, 0, 0, n * 16); });
  viscous_kept_ = true;
  return res;
}

double DfsphSolver::averageError(std::size_t n, const DfsphFields* f, double* body_error) {
  const double sum = errorSum(n, f, body_error);
  return n > 0 ? sum / static_cast<double>(n) : 0.0;
}

double DfsphSolver::errorSum(std::size_t n, const DfsphFields* f, double* body_error) {
  // Chunk sums on the device, the chunks added in order here (double): a fixed order.
  const uint32_t chunk = static_cast<uint32_t>((n + kChunks - 1) / kChunks);
  kernels_.call("dfsph_reduce", kChunks, 0, static_cast<uint32_t>(n), chunk, err_, partial_);
  std::vector<float> part(kChunks);
  // With the bodies' errors too, one wait for both: the chunk sums are read without waiting, and the
  // in-order queue has them in place when bodyError's blocking read returns (one host-device round
  // trip per iteration fewer in scenes with free bodies; the values read are the same).
  const bool with_bodies = f && body_error;
  clCall("reading the DFSPH error", [&] {
    return cl_.queue().enqueueReadBuffer(partial_, with_bodies ? CL_FALSE : CL_TRUE, 0, kChunks * 4, part.data());
  });
  if (with_bodies) *body_error = bodyError(*f);
  double sum = 0.0;
  for (float v : part) sum += v;
  return sum;
}

double DfsphSolver::nodeErrorSum(std::size_t n) {
  const uint32_t chunk = static_cast<uint32_t>((n + kChunks - 1) / kChunks);
  kernels_.call("dfsph_reduce", kChunks, 0, static_cast<uint32_t>(n), chunk, nerr_, partial_);
  std::vector<float> part(kChunks);
  clCall("reading the viscosity's node sums",
         [&] { return cl_.queue().enqueueReadBuffer(partial_, CL_TRUE, 0, kChunks * 4, part.data()); });
  double sum = 0.0;
  for (float v : part) sum += v;
  return sum;
}

double DfsphSolver::bodyError(const DfsphFields& f) {
  // The bodies' errors of the last iteration (dfsph_body_accel), the largest.
  const uint32_t n_bodies = f.n_bodies;
  std::vector<float> e(n_bodies);
  clCall("reading the DFSPH body errors",
         [&] { return cl_.queue().enqueueReadBuffer(berr_, CL_TRUE, 0, n_bodies * 4, e.data()); });
  double m = 0.0;
  for (float v : e) m = std::max(m, static_cast<double>(v));
  return m;
}

DfsphSolveResult DfsphSolver::solve(Kind kind, const SimParams& p, const DfsphFields& f) {
  if (mirrored()) return solveMirrored(kind, p, f);
  const bool div = kind == Kind::Divergence;
  cl::Buffer& pressure = div ? pdiv_ : pdens_;
  const std::size_t n = p.n_fluid;
  const double bound = div ? spec_.divergence_error : spec_.density_error;
  const int min_it = std::max(1, div ? spec_.divergence_min_iterations : spec_.min_iterations);
  const int max_it = div ? spec_.divergence_max_iterations : spec_.max_iterations;
  // The source from the velocities the solve starts with, and the starting pressure.
  // A density solve at rest: its step's fastest particle moved less than coarse_rest_travel dx in the
  // last step (the tank at rest: 0.01-0.03 dx per step; a dam break 0.2-0.4 dx).
  const bool rest = !div && f.max_speed * p.dt < spec_.coarse_rest_travel * dx_;
  source(kind, p, f, pressure, rest);
  // Relaxed Jacobi iterations on the pressures (velocities fixed), until the average error of the
  // pressures found is within the bound; at least min_it (at least one), at most max_it. The error
  // is read (a wait for the device) only where it can stop the solve: not before min_it.
  // Two-level (coarse_interval n > 0; kernels/dfsph_coarse.cl says why): a coarse-grid correction
  // where the plain iteration cannot do the work (docs/dfsph.md, session 11, measured):
  // - at rest (the density solve of a step whose fastest particle moved less than coarse_rest_travel
  //   dx in the last step): after the first iteration, every step. There the pressure is a smooth
  //   field the average-error stop cannot see (up to rho0 eta (2H / pi)^2 / dt^2 unseen): plain
  //   Jacobi rings by ~1-3 kPa between steps in the 0.2 m tank, and a correction only in some steps
  //   (the stall rule alone) rings as much, since the steps without it keep the smooth error;
  // - stalled (either solve, moving or not; off by default, coarse_start 0): after iterations k0,
  //   k0 + n, k0 + 2n, ... (k0 = coarse_start) while above the bound. It saves iterations (the slab
  //   dam break: 6.6 per step at k0 12 against 8.5), but in a moving flow it changes which smooth
  //   pressure error the stop leaves, and a body feels that: the sinking ball of tests/test_forces.cpp
  //   at 0.2 s read 0.58 m/s at k0 16 or without the rule, 0.58 - 0.009 below its envelope at k0 12,
  //   0.35 m/s at k0 20 (measured, session 11; session 12 found why: that scene's column still
  //   bounces from its start-up at the release, nearly pressureless with a cavity under the held
  //   ball, and the schedule moves the landing's slam before or after the release; plain Jacobi
  //   converged to 1e-5 reads 0.571 m/s, docs/dfsph.md). Moving flows converge in a few iterations (the dam
  //   breaks: 4-8 per step) and take no correction, whose cost is ~10 iterations.
  // - stalled at rest (the density solve of a step at rest, coarse_rest_start k_rest, default 1):
  //   after iterations k_rest, k_rest + n, ... while above the bound (with k_rest 1: after 1, 5,
  //   9, ...). One correction leaves an error Jacobi removes slowly (the piecewise-constant
  //   prolongation's jumps), so a tight bound needs later ones: at density_error 1e-5 the resting
  //   tank took 35 iterations per step with the rest correction alone (124 of 450 steps at
  //   max_iterations), 71 with plain Jacobi, and takes 7.2 with this rule (docs/dfsph.md, session
  //   12). Moving flows take none: there a correction (~10 iterations' cost) saves too few
  //   iterations (the slab dam break at 1e-5: 56 per step instead of 66, at 3.5x the CPU).
  // Every correction is followed by at least one Jacobi iteration and its error check: a solve never
  // ends on an unchecked correction (session 10's schedule did, after iterations 1, 5, 9, ... of a
  // solve that stopped there: the sinking ball of tests/test_forces.cpp then jumped 0.24 m/s above
  // its closed-form envelope at its release, measured).
  // - a solve's corrections stop once one did not pay: when the error before a correction is not
  //   below the error before the previous one (session 13: a 0.28 m column at dx = 7.5 mm, 37
  //   layers, gravity ramped in, 5 ms steps: from 0.24 s every correction raised the error, 1.5e-3
  //   -> 3.1e-3, 1.6e-3 -> 3.9e-3, ..., the stall rule made 25 of them in the step's 100 iterations,
  //   the error reached 4e-2 and the run ended in NaN at 0.245 s; docs/dfsph.md "Session 13").
  const bool at_rest = coarse() && rest;
  DfsphSolveResult r;
  bool again = false;
  bool error_read = false;
  double error_before_correction = INFINITY;  // the error before the last correction
  bool corrections_pay = true;
  // Free bodies in the coarse corrections (bodyCoarse()): a correction leaves each body at the
  // acceleration of the corrected pressures, so the body error of the next iteration reads 0 whatever
  // the pressures, and the iterates then move little for a few iterations while a smooth error is
  // left: a solve may stop on the body error only from the kBodyStopGap-th iteration after a
  // correction. Measured on the floating block (docs/forces.md, session 25; force SD, density
  // iterations per step at body_error 0.1 / 0.03): from the 2nd 0.098 N, 3.7 / 0.098 N, 5.4; from the
  // 4th 0.069 N, 4.7 / 0.046 N, 6.1; from the 8th 0.034 N, 8.7 / 0.032 N, 9.1.
  constexpr int kBodyStopGap = 4;
  const bool body_coarse = bodyCoarse();
  int last_correction = -2;  // the iteration after which the last correction was made
  bool body_pending = false;  // a body's error is above its bound, or not yet read after a correction
  cheb_k_ = 0;
  // Chebyshev in moving steps only (iterate()): the fastest particle moved at least kChebyshevTravel dx in the last
  // step. At rest it makes the tank ring: the default-settings tank under 24 small changes to its settings was
  // calm from 1 s in 23 (session 48), and with the rest rule off the alpha 0.07 two-level tank rang by 462 Pa.
  cheb_on_ = f.max_speed * p.dt >= kChebyshevTravel * dx_;
  do {
    iterate(kind, p, f, pressure);
    ++r.iterations;
    error_read = r.iterations >= min_it || r.iterations >= max_it;
    if (error_read) {
      r.error = bodies_ ? averageError(n, &f, &r.body_error) : averageError(n);
    }
    body_pending = r.body_error > spec_.body_error || (body_coarse && r.iterations < last_correction + kBodyStopGap);
    const bool within = r.error <= bound && !body_pending;
    const bool stop = (r.iterations >= min_it && within) || r.iterations >= max_it;
    const bool rest_now = at_rest && r.iterations == 1 && r.iterations < max_it;
    // the stall rules: from k0 (coarse_start) in any solve; from k_rest (coarse_rest_start) in a
    // density solve at rest
    auto due = [&](int k0) { return k0 > 0 && r.iterations >= k0 && (r.iterations - k0) % spec_.coarse_interval == 0; };
    // (only while the fluid's own error is above the bound: a correction ignores the bodies that move
    // in the solve, body_coupling strong, and would pull the pressure about a free body back toward a
    // held one's; the iterations a body's error still needs are plain Jacobi: docs/forces.md, session 23)
    // With the bodies in the corrections (body_coarse, session 25) the corrections go on while a body's
    // error is above its bound too.
    const bool fluid_within = r.iterations >= min_it && r.error <= bound;
    const bool needed = !fluid_within || (body_coarse && r.body_error > spec_.body_error);
    const bool stalled = coarse() && !stop && needed && (due(spec_.coarse_start) || (at_rest && due(spec_.coarse_rest_start)));
    again = false;
    if ((rest_now || stalled) && corrections_pay) {
      if (r.corrections > 0) {  // did the last correction pay?
        if (!error_read) r.error = averageError(n);
        corrections_pay = r.error < error_before_correction;
      }
      if (corrections_pay) {
        if (!error_read && r.corrections == 0) r.error = averageError(n);
        error_before_correction = r.error;
        r.reused += coarseCorrection(kind, p, f, pressure) ? 1 : 0;
        cheb_k_ = 0;
        ++r.corrections;
        last_correction = r.iterations;
        again = r.iterations < max_it;
      } else {
        r.corrections_stopped = true;
      }
    }
  } while (again || ((r.iterations < min_it || r.error > bound || body_pending) && r.iterations < max_it));
  r.converged = r.error <= bound && r.body_error <= spec_.body_error;
  // The velocities take the pressures found.
  apply(kind, p, f, pressure);
  (div ? prev_dt_div_ : prev_dt_dens_) = p.dt;
  return r;
}

DfsphSolveResult DfsphSolver::divergenceSolve(const SimParams& p, const DfsphFields& f) {
  divergence_ran_ = true;
  return solve(Kind::Divergence, p, f);
}

DfsphSolveResult DfsphSolver::densitySolve(const SimParams& p, const DfsphFields& f) {
  // Keep the velocities the viscous forces saw (for the rigid coupling; the implicit viscosity's
  // solution is there already), then v* = v + dt a.
  if (!viscous_kept_)
    clCall("keeping the velocities",
           [&] { return cl_.queue().enqueueCopyBuffer(*f.vel, vel_before_, 0, 0, std::max<std::size_t>(p.n_fluid, 1) * 16); });
  viscous_kept_ = false;
  const bool node_dv = node_dv_pending_, body_dv = body_dv_pending_;
  node_dv_pending_ = body_dv_pending_ = false;
  // v* = v + dt a; with extrapolated walls a takes the contact with the walls for the particles
  // the solve leaves without pressure first (kernels/dfsph.cl, dfsph_wall_contact_accel).
  const int contact = extrapolated() && f.n_boundary > 0 ? 1 : 0;
  kernels_.call("dfsph_predict", p.n_fluid, kLocal, p, *f.vel, *f.acc, contact, *f.pos, *f.bpos, *f.bvel, *f.bnormal,
                *f.sbnbr, *f.sbnbr_count, kWallContactStiffness, kWallContactRange, kSampledContactRange,
                f.n_sampled > 0 ? 1 : 0);
  // Cloth nodes: the density solve must see them move as the step will move them, as it sees the
  // fluid at v* (kernels/dfsph.cl, dfsph_node_rate): its density rate takes the walls' part from
  // gwall.w (factors()), which gains dt sum_b psi_b a_b . gradW_ib, a_b the divergence solve's
  // pressure acceleration (without it the two solves disagreed on the nodes' motion every step and a
  // sheet sealed between two layers never came to rest, session 17) plus what the cloth's own forces
  // do in the step (gravity, springs, balls; f.node_dv / dt), as the fluid's v* takes gravity (without
  // it a ball resting on a sheet over sealed water pushed the sheet down unseen every step and sank
  // 3.5 cm deeper than with WCSPH; session 18).
  // Bodies (body_coupling strong) the same way: their slots take the divergence solve's final
  // acceleration (zero without that solve) plus the body's own (gravity, the last step's contact and
  // external forces; dfsph_body_slots, `dry`).
  if (bodies_) {
    if (!body_div_ready_)
      clCall("clearing the body accelerations",
             [&] { return cl_.queue().enqueueFillBuffer(bbacc_div_, cl_float4{}, 0, std::size_t(f.n_bodies) * 32); });
    body_div_ready_ = false;
    kernels_.call("dfsph_body_slots", f.n_moving, kLocal, f.n_moving, f.n_static, *f.body_of, *f.bslot, *f.bsrc,
                  *f.body_data, bbacc_div_, 1, bacc_);
    // and what the implicit viscosity does to them (viscositySolve: they were its unknowns)
    if (body_dv)
      kernels_.call("viscosity_cg_body_accel", f.n_moving, kLocal, f.n_moving, f.n_static, body_inv_g_ / p.dt, *f.bslot,
                    *f.body_of, *f.body_data, *f.bpos, bdirs_, bacc_);
  }
  if (nodes_) {
    if (f.node_dv)
      kernels_.call("dfsph_node_dry", f.n_nodes, kLocal, f.n_nodes, f.node_offset, 1.0f / p.dt, *f.nodes, *f.bslot,
                    *f.node_dv, bacc_);
    // and what the implicit viscosity does to them (viscositySolve: they were its unknowns)
    if (cloth_ && node_dv)
      kernels_.call("dfsph_node_dry", f.n_nodes, kLocal, f.n_nodes, f.node_offset, 1.0f / p.dt, *f.nodes, *f.bslot,
                    ndv_, bacc_);
    kernels_.call("dfsph_node_rate", p.n_fluid, kLocal, p, *f.pos, *f.bpos, *f.sbnbr, *f.sbnbr_count, bacc_, gwall_);
  }
  const DfsphSolveResult r = solve(Kind::Density, p, f);
  // Extrapolated walls: the velocities after the solve move no particle closer than the gap to a
  // closed wall's plane (kernels/dfsph.cl, dfsph_wall_impulse: an inelastic contact).
  if (extrapolated() && p.closed_mask != 0)
    kernels_.call("dfsph_wall_impulse", p.n_fluid, kLocal, p, *f.pos, *f.vel, static_cast<float>(kWallGap * dx_));
  // and no closer than the gap to a static body's surface (dfsph_surface_impulse)
  if (extrapolated() && f.n_sampled > 0)
    kernels_.call("dfsph_surface_impulse", p.n_fluid, kLocal, p, *f.pos, *f.vel, *f.bpos, *f.bnormal, *f.sbnbr,
                  *f.sbnbr_count, static_cast<float>(kSurfaceGap * dx_));
  return r;
}

void DfsphSolver::finish(const SimParams& p, const DfsphFields& f) {
  kernels_.call("dfsph_finish", p.n_fluid, kLocal, p, *f.phase, *f.density, pdiv_, pdens_, *f.pressure, *f.pterm,
                *f.max_pressure);
  // Extrapolated walls: the rigid coupling's wall pressure is that of both solves (the divergence
  // solve's is zero when it is off: its buffer is cleared then).
  if (extrapolated() && f.n_boundary > 0) {
    clCall("copying the wall pressure", [&] {
      return cl_.queue().enqueueCopyBuffer(bp_dens_, *f.bpressure, 0, 0, std::size_t(f.n_boundary) * 4);
    });
    if (divergence_ran_) kernels_.call("dfsph_add", f.n_boundary, kLocal, f.n_boundary, *f.bpressure, bp_div_);
  }
}

}  // namespace sph
