// DFSPH two-level solve, host side: enqueues the coarse-grid correction of kernels/dfsph_coarse.cl
// (which derives it). Everything runs on the device: the aggregates (cells of H aligned with the
// domain, their particles found through the neighbour grid of the last list build), their
// numbering, the Galerkin operator K (a 125-point stencil per aggregate, assembled per row in a
// fixed order), its solve (BiCGStab in one work-group), the prolongation and the line
// search; no host transfer and no host solve. Every sum runs in a fixed order: bitwise
// deterministic. With the strong body coupling (fluid.dfsph.body_coarse) each free body's six degrees
// of freedom are in the coarse system too, a rank-6 term per body in the BiCGStab's product (session 25).
//
// Session 9's version summed K on the host in particle order and factorized it by sparse LU: 2.8x
// plain Jacobi's CPU time on the slab dam break and 5.2x at 50k (each correction read back n x 864 B
// of pair terms and factorized ~6,000 aggregates), so the correction stayed off.

#include "core/dfsph.h"

#include "core/errors.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace sph {

namespace {
constexpr std::size_t kLocal = 64;                    // work-group size, as dfsph.cpp's
constexpr std::size_t kGroup = 256;                   // the single-group kernels' (DFSPH_COARSE_WG)
constexpr float kCoarseThetaMax = 2.0f;               // the line search's largest step (unit: 1)
// The coarse solve: BiCGStab (conjugate gradients until session 20) until the residual is 1e-4 of
// P^T r (2-norm), at most kCoarseIterations (a smooth mode over a column of L aggregates needs ~L
// of them). The hydrostatic tank at rest (300 aggregates): 20 BiCGStab iterations per solve against
// 30 CG ones, both to 1e-4; the paper's demo (~4,200): CG stalled at 100 (residual 4e-3), BiCGStab
// reaches 1e-4 (session 21, docs/dfsph.md). With CG, measured on the tank (alpha 0.1, 3.33 ms
// steps), the largest step-to-step change of the deepest probe over 1-2.75 s: 1e-4 calm (< 1 Pa)
// from 1.0 s on; 1e-3 rang until 1.5 s (1.8 kPa at 1.0-1.25 s).
constexpr int kCoarseIterations = 100;                // (unit: 1)
constexpr float kCoarseTolerance = 1e-4f;             // (unit: 1)
// A reused coarse operator (fluid.dfsph.coarse_reuse): reassembled once the fastest particle has
// travelled this many spacings since its assembly (unit: 1; session 24).
constexpr double kCoarseReuseTravel = 0.25;
// ... and once the step differs from the operator's by more than this fraction (unit: 1).
constexpr double kCoarseReuseDt = 0.25;
}  // namespace

DfsphSolver::~DfsphSolver() = default;

bool DfsphSolver::coarseCorrection(Kind kind, const SimParams& p, const DfsphFields& f, cl::Buffer& pressure) {
  const std::size_t n = p.n_fluid;
  if (n == 0 || f.cell_start == nullptr) return false;
  const bool div = kind == Kind::Divergence;
  const uint32_t min_nbr = div ? min_neighbours_ : 0u;
  // Each particle's aggregate cell (once per step: positions do not change within it).
  cl_int4 bd;
  for (int a = 0; a < 4; ++a) bd.s[a] = cbox_[static_cast<std::size_t>(a)];
  // Free bodies in the coarse system (fluid.dfsph.body_coarse; kernels/dfsph_coarse.cl, above
  // dfsph_coarse_slot_body): each boundary slot's free body, once per step.
  const bool bc = bodyCoarse();
  const uint32_t nb = bc ? f.n_bodies : 0u;
  if (bc && (!csbody_() || cbody_count_ < nb)) {
    if (!csbody_()) csbody_ = makeBuffer(std::max<std::size_t>(f.n_boundary, 1) * 4);
    ccwv_ = makeBuffer(coarse_rows_ * nb * 64);
    cbody_count_ = nb;
  }
  if (coarse_cells_step_ != steps_) {
    kernels_.call("dfsph_coarse_cells", n, kLocal, p, bd, *f.pos, cagg_);
    if (bc) {
      clCall("clearing the slots' bodies",
             [&] { return cl_.queue().enqueueFillBuffer(csbody_, cl_int(-1), 0, std::size_t(f.n_boundary) * 4); });
      kernels_.call("dfsph_coarse_slot_body", f.n_moving, kLocal, f.n_moving, f.n_static, *f.body_of, *f.bslot,
                    *f.body_data, csbody_);
    }
    coarse_cells_step_ = steps_;
  }
  // The pressure accelerations of the current pressures (as iterate()'s first pass), then the
  // residuals and the active set. Free bodies in the coarse system first take the acceleration of
  // the current pressures, unrelaxed (their own equation then holds; the coarse system couples them).
  const int use_bp = extrapolated() ? 1 : 0;
  if (use_bp) boundaryPressure(kind, p, f, pressure);
  if (bc) bodyAccel(kind, p, f, 1.0f, true);
  kernels_.call("dfsph_pressure_accel", n, kLocal, p, xt_, *f.phase, *f.density, pressure, *f.snbr, *f.snbr_count,
                *f.bpos, *f.sbnbr, *f.sbnbr_count, wallFactor(), wallPressure(kind), use_bp, accel_, gwall_);
  // (the slot map and bacc_ stand in for unused arguments without bodies)
  const cl::Buffer& sbody = bc ? csbody_ : cagg_;
  const cl::Buffer& bacc = bc ? bacc_ : accel_;
  kernels_.call("dfsph_coarse_residual", n, kLocal, p, *f.pos, accel_, source_, *f.snbr, *f.snbr_count,
                *f.sbnbr_count, min_nbr, pressure, gwall_, 0, cres_, cact_, bc ? 1 : 0, sbody, *f.bpos, *f.sbnbr, bacc);
  // The aggregates (cells with at least 4 active particles) with P^T r, numbered in box order;
  // each particle's aggregate number.
  const uint32_t rows = static_cast<uint32_t>(coarseRows(n));
  // Reuse (fluid.dfsph.coarse_reuse n >= 1): an operator assembled in step s serves this solve's
  // corrections up to step s + n - 1 while the fastest particle has travelled less than
  // kCoarseReuseTravel dx since (the travel summed per step from its largest speed): K keeps its
  // aggregates (numbered then), its pair terms and its dt (K ~ dt^2: the correction e of K(dt0) is
  // scaled by (dt0 / dt)^2). The right-hand side and the members are those of now.
  const int reuse_steps = spec_.coarse_reuse;
  const bool reuse = reuse_steps > 0 && coarse_k_kind_ == static_cast<int>(kind) && steps_ - coarse_k_step_ < uint64_t(reuse_steps) &&
                     coarse_travel_ - coarse_k_travel_ <= kCoarseReuseTravel * dx_ &&
                     std::abs(p.dt / coarse_k_dt_ - 1.0) <= kCoarseReuseDt;
  kernels_.call("dfsph_coarse_aggregate", static_cast<std::size_t>(cbox_[3]), kLocal, p, bd, *f.cell_start, cagg_,
                cact_, cres_, cbok_, cbb_);
  // The right-hand side P^T r: gathered by the reused operator's numbering, or numbered anew.
  if (reuse)
    kernels_.call("dfsph_coarse_rhs", rows, kLocal, cmcount_, ccell_, cbb_, cb_);
  else
    kernels_.call("dfsph_coarse_number", kGroup, kGroup, bd, rows, cbok_, cbb_, cbnum_, ccell_, cb_, cmcount_);
  kernels_.call("dfsph_coarse_members", n, kLocal, p, cagg_, cact_, cbnum_, cmem_);
  float e_scale = 1.0f;
  if (reuse) {
    const double r = coarse_k_dt_ / p.dt;
    e_scale = static_cast<float>(r * r);
  } else {
    // Per particle and aggregate F and R, then K row by row. Extrapolated
    // walls: a smooth pressure's wall pressure is the fluid's next to it (mirrored, w = 2); single w = 1.
    // Cloth nodes with water on both sides, which the solve moves as free masses (dfsph_node_slots), leave
    // F's wall term (kernels/dfsph_coarse.cl, session 21: 0.67x the paper's demo's time).
    const float wall = extrapolated() ? 2.0f : 1.0f;
    kernels_.call("dfsph_coarse_pairs", n, kLocal, p, bd, *f.pos, *f.phase, *f.density, *f.snbr, *f.snbr_count, gwall_,
                  cagg_, cmem_, wall, cfr_, cmask_, *f.bpos, *f.sbnbr, *f.sbnbr_count, nodes_ ? 1 : 0,
                  nodes_ ? bminv_ : gwall_);
    const float scale = p.dt * p.dt * p.rest_volume;
    kernels_.call("dfsph_coarse_assemble", rows, kLocal, p, bd, *f.cell_start, cagg_, cmcount_, ccell_, cbnum_, cfr_,
                  cmask_, scale, ckval_, ckcol_);
    coarse_k_kind_ = static_cast<int>(kind);
    coarse_k_step_ = steps_;
    coarse_k_dt_ = p.dt;
    coarse_k_travel_ = coarse_travel_;
  }
  // The free bodies' terms per aggregate (every correction: the bodies move), at the operator's dt.
  if (bc) {
    const double dtk = reuse ? coarse_k_dt_ : p.dt;
    const float wall = extrapolated() ? 2.0f : 1.0f;
    kernels_.call("dfsph_coarse_bodies", rows, kLocal, p, bd, *f.cell_start, cmcount_, ccell_, cmem_, *f.pos, *f.phase,
                  *f.density, *f.bpos, *f.sbnbr, *f.sbnbr_count, csbody_, *f.body_data, nb, wall,
                  static_cast<float>(dtk * dtk * p.rest_volume), ccwv_);
  }
  // K e = P^T r by BiCGStab (one work-group), prolonged: q = P e.
  const cl::Buffer& cwv = bc ? ccwv_ : cb_;
  const cl::Buffer& bdata = bc ? *f.body_data : cb_;
  kernels_.call("dfsph_coarse_bicgstab", kGroup, kGroup, cmcount_, ckval_, ckcol_, cb_, cx_, cr_, cph_, cp_, cv_, csh_, ct_,
                kCoarseIterations, kCoarseTolerance, nb, cwv, bdata);
  kernels_.call("dfsph_coarse_prolong", n, kLocal, p, cmem_, cx_, e_scale, cdp_);
  // Line search: the step theta along q that makes the correction Galerkin-exact for the walls'
  // own operator (K's mirrored wall term is an approximation, and the wall pressure is projected
  // to >= 0): with dr the change of the residual that q actually makes (the trial pressures
  // max(p + q, 0), their extrapolated wall pressure, accelerations and residual),
  // theta = -<q, r> / <q, dr> over the members, within [0, kCoarseThetaMax].
  kernels_.call("dfsph_coarse_trial", n, kLocal, p, *f.pos, *f.phase, *f.density, cdp_, pressure, ctrial_, xt_);
  // (free bodies in the coarse system move with the trial pressures: the residual change counts it)
  if (use_bp) boundaryPressure(kind, p, f, ctrial_);
  if (bc) bodyAccel(kind, p, f, 1.0f, true);
  kernels_.call("dfsph_pressure_accel", n, kLocal, p, xt_, *f.phase, *f.density, ctrial_, *f.snbr, *f.snbr_count,
                *f.bpos, *f.sbnbr, *f.sbnbr_count, wallFactor(), wallPressure(kind), use_bp, accel_, gwall_);
  kernels_.call("dfsph_coarse_residual", n, kLocal, p, *f.pos, accel_, source_, *f.snbr, *f.snbr_count,
                *f.sbnbr_count, min_nbr, ctrial_, gwall_, 1, ctres_, cact_, bc ? 1 : 0, sbody, *f.bpos, *f.sbnbr, bacc);
  const uint32_t chunk = static_cast<uint32_t>((n + kChunks - 1) / kChunks);
  kernels_.call("dfsph_coarse_dots", kChunks, 0, static_cast<uint32_t>(n), chunk, kChunks, cmem_, cdp_, cres_, ctres_,
                cpartial_);
  kernels_.call("dfsph_coarse_theta", 1, 0, kChunks, cpartial_, kCoarseThetaMax, ctheta_);
  // p <- max(p + theta q, 0), and the packed p / delta^2 for the next pass.
  kernels_.call("dfsph_coarse_apply", n, kLocal, p, *f.pos, *f.phase, *f.density, cdp_, ctheta_, pressure, xt_);
  // Free bodies in the coarse system: the acceleration of the corrected pressures (unrelaxed).
  if (bc) {
    if (use_bp) boundaryPressure(kind, p, f, pressure);
    bodyAccel(kind, p, f, 1.0f, true);
  }
  return reuse;
}

}  // namespace sph
