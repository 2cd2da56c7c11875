// DFSPH: divergence-free SPH on the device (Bender & Koschier 2017, Alg. 1-3; kernels/dfsph.cl).
//
// The solver owns its per-particle buffers (factors, accumulated pressures of both solves, the
// Jacobi increments and the per-particle errors); the particle fields and neighbour lists it reads
// belong to the Simulation and come in a DfsphFields view. Per step, in Simulation::step():
//
//   density pass (density.cl) ─► factors alpha ─► divergence solve: v made divergence-free
//        ─► gravity, viscosity into acc ─► v* = v + dt a ─► density solve: v* keeps delta = delta0
//        ─► finish: pressure for output, p / delta^2 for the rigid coupling ─► integrate (x += dt v)
//
// Each solve computes its source from the velocities once, then iterates relaxed Jacobi passes on
// the pressures (accelerations of the pressures; pressures from the residual, projected to p >= 0)
// until the average error is below its bound (and the least iterations are done) or the most
// iterations are reached; then the velocities take the pressures. The average is summed in fixed chunks on the device and the
// chunks in order on the host: bitwise deterministic. With walls: extrapolated each iteration first
// extrapolates the wall particles' pressure from the fluid's (Adami et al. 2012 eq. 27, pressure.cl
// boundary_pressure); finish() hands both solves' wall pressure to the rigid coupling.
#pragma once

#include "core/cl_context.h"
#include "core/scene_spec.h"
#include "kernels/shared/sim_params.h"

#include <Eigen/Core>

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

namespace sph {

/// The Simulation's buffers the solver reads and writes (current halves of the double buffers).
struct DfsphFields {
  const cl::Buffer* pos = nullptr;        ///< (n x float4) (unit: m)
  cl::Buffer* vel = nullptr;              ///< (n x float4), updated by the solves (unit: m/s)
  cl::Buffer* acc = nullptr;              ///< (n x float4) non-pressure acceleration; cleared by the prediction (unit: m/s^2)
  const cl::Buffer* phase = nullptr;      ///< (n) phase index
  const cl::Buffer* density = nullptr;    ///< (n) mass density rho (unit: kg/m^3)
  const cl::Buffer* snbr = nullptr;       ///< this step's fluid neighbours within H (n x max_neighbours)
  const cl::Buffer* snbr_count = nullptr;
  const cl::Buffer* bpos = nullptr;       ///< boundary particles: xyz (unit: m), w = V_b / V0
  const cl::Buffer* bvel = nullptr;       ///< boundary particles' velocities (unit: m/s)
  const cl::Buffer* bnormal = nullptr;    ///< boundary particles: a static body's outward normal, w = 1; else 0 (Model::boundary_normal)
  uint32_t n_sampled = 0;                 ///< static boundary particles on a body's sampled layer (bnormal.w = 1)
  const cl::Buffer* sbnbr = nullptr;      ///< this step's boundary neighbours within H
  const cl::Buffer* sbnbr_count = nullptr;
  cl::Buffer* pressure = nullptr;         ///< (n) written by finish: density-solve pressure (unit: Pa)
  cl::Buffer* pterm = nullptr;            ///< (n) written by finish: p / delta^2 of both solves (unit: Pa m^6)
  // Extrapolated walls (Adami et al. 2012 eq. 27, pressure.cl boundary_pressure):
  uint32_t n_boundary = 0;                ///< boundary particles (walls, bodies, cloth nodes)
  uint32_t stamp = 0;                     ///< this step's mark of the boundary particles near fluid
  const cl::Buffer* bmark = nullptr;      ///< (n_boundary) the step each was last seen by fluid
  const cl::Buffer* cell_start = nullptr; ///< the fluid grid's cells
  cl::Buffer* bpressure = nullptr;        ///< (n_boundary) written by finish: both solves' wall pressure (unit: Pa)
  cl::Buffer* max_pressure = nullptr;     ///< (1 uint) finish raises it to the step's largest p_i / rho_i, float bits (unit: m^2/s^2)
  double max_speed = 0.0;                 ///< the last step's largest particle speed, fluid and bodies (unit: m/s)
  // Cloth nodes that move inside the solves (kernels/dfsph.cl, dfsph_node_accel; none: n_nodes = 0).
  uint32_t n_nodes = 0;                   ///< cloth and soft-body nodes
  uint32_t node_offset = 0;               ///< boundary index of the first node
  const cl::Buffer* nodes = nullptr;      ///< (n_nodes x float4) positions, w = 1 / m (0 anchored) (unit: m, 1/kg)
  const cl::Buffer* response = nullptr;   ///< (n_nodes x 3 float4) each node's M^-1 this step (cloth.cl, cloth_node_response) (unit: 1/kg)
  const cl::Buffer* bslot = nullptr;      ///< (n_boundary) each boundary particle's slot in bpos
  /// (n_nodes x float4) each node's velocity change over this step without the fluid (gravity,
  /// springs, balls: ClothSim::dryVelocityChange) (unit: m/s); null: none counted
  const cl::Buffer* node_dv = nullptr;
  /// the cloth's spring table (core/cloth.h, ClothModel: row_start, spring, other, prm, broken)
  const cl::Buffer *row_start = nullptr, *spring = nullptr, *other = nullptr, *prm = nullptr, *broken = nullptr;
  // Rigid bodies that move inside the solves (fluid.dfsph.body_coupling: strong; kernels/dfsph.cl,
  // dfsph_body_accel; none: n_bodies = 0). bslot (above) too.
  uint32_t n_bodies = 0;                  ///< moving bodies (dynamic and kinematic)
  uint32_t n_moving = 0;                  ///< their particles, after the n_static walls' in bsrc
  uint32_t n_static = 0;                  ///< boundary index of the first moving particle
  const cl::Buffer* bsrc = nullptr;       ///< boundary particles in source order (n_boundary x float4) (unit: m)
  const cl::Buffer* body_of = nullptr;    ///< (n_moving) each moving particle's body
  const cl::Buffer* body_range = nullptr; ///< (2 n_bodies) each body's first particle and count
  const cl::Buffer* body_data = nullptr;  ///< (DFSPH_BODY_STRIDE n_bodies x float4) the bodies' centres, mobilities and dry accelerations (kernels/shared/body_response.h)
  cl::Buffer* body_force = nullptr;       ///< (n_moving x float4) scratch for the particles' forces (unit: N)
};

/// How one solve ended.
struct DfsphSolveResult {
  int iterations = 0;     ///< relaxed Jacobi iterations on the pressures (unit: 1)
  double error = 0.0;     ///< average error reached (unit: 1, relative to rho0)
  bool converged = true;  ///< error <= bound when it stopped
  int corrections = 0;    ///< coarse-grid corrections of the two-level solve (unit: 1)
  bool corrections_stopped = false;  ///< a correction did not lower the error, so the solve made no more
  int reused = 0;         ///< of the corrections, those with a reused coarse operator (fluid.dfsph.coarse_reuse) (unit: 1)
  /// body_coupling strong: the largest body error of the last iteration read, |F / m - a| + R |I^-1 T -
  /// alpha| (dfsph_body_accel; 0 without bodies in the solve) (unit: m/s^2)
  double body_error = 0.0;
};

/// The implicit viscosity solve of one step (fluid.dfsph.viscosity_solve: implicit).
struct ViscositySolveResult {
  int iterations = 0;       ///< conjugate-gradient iterations (unit: 1)
  double residual = 0.0;    ///< sqrt(r.z / r0.z0) reached, the preconditioned residual against the first (unit: 1)
  bool converged = true;    ///< residual <= fluid.dfsph.viscosity_tolerance when it stopped
};

class DfsphSolver {
 public:
  /// `one_mass`: every fluid phase has the same particle mass (the factor pass then reads no
  /// neighbour's phase). `extent`: the domain box's size, for the two-level solve's aggregate
  /// cells (unit: m).
  DfsphSolver(ClContext& cl, KernelSet& kernels, std::size_t capacity, std::size_t boundary, const DfsphSpec& spec,
              double dx, double support, bool one_mass, const Eigen::Vector3d& extent);
  /// The two-level solve's box of aggregate cells (size H from the domain's lower corner): cells
  /// per axis and their product (kernels/dfsph_coarse.cl).
  static std::array<int32_t, 4> coarseBox(const Eigen::Vector3d& extent, double support);
  ~DfsphSolver();
  /// Device memory of the solver's buffers (unit: bytes).
  std::size_t bytes() const { return bytes_; }

  /// The accumulated pressures follow the particles when the grid stage reorders them.
  void reorder(std::size_t n, const cl::Buffer& sorted);
  /// Factors alpha (B&K 2017 eq. 9); every step, after the density pass. `divergence_next`: a
  /// divergence solve follows on the current velocities (its density rate is summed here too).
  /// `with_density`: the same pass is the step's density pass (kernels/dfsph.cl, dfsph_factor: f's
  /// density, pressure, pterm and boundary marks, bitwise compute_density's); only where f's lists are
  /// this step's, and with no cloth nodes inside the solves (whose slots and velocities are set first).
  void factors(const SimParams& p, const DfsphFields& f, bool divergence_next, bool with_density = false);
  /// Divergence solve (B&K 2017 Alg. 2) on the current velocities.
  DfsphSolveResult divergenceSolve(const SimParams& p, const DfsphFields& f);
  /// v* = v + dt a (acc cleared), then the density solve (B&K 2017 Alg. 3).
  DfsphSolveResult densitySolve(const SimParams& p, const DfsphFields& f);
  /// The pressure to export and p / delta^2 for the rigid coupling (kernels/dfsph.cl, dfsph_finish).
  void finish(const SimParams& p, const DfsphFields& f);
  /// The pressure of the last step, both solves' (as dfsph_finish exports it), following their
  /// particles; computed into a scratch buffer, valid until the next solve or reorder (n) (unit: Pa).
  const cl::Buffer& stepPressure(std::size_t n);
  /// The velocities before this step's density solve: what the viscous forces saw, so that the
  /// rigid coupling's viscous reaction matches them (n x float4) (unit: m/s).
  const cl::Buffer& viscousVelocities() const { return vel_before_; }
  /// Implicit laminar viscosity (kernels/viscosity.cl, viscosity_cg_*): solves backward Euler's
  /// (I - dt L) v' = w by preconditioned conjugate gradients from w, w = v with the last density pressure
  /// and f.acc (gravity) applied (the incremental splitting, viscositySolve's comment), adds (v' - w) / dt
  /// to f.acc, and keeps v' as the velocities the viscous forces saw (viscousVelocities(), for the bodies'
  /// reaction: the densitySolve that follows keeps them). bvisc: the boundary velocities of the viscous term.
  /// Cloth and soft-body nodes (f.n_nodes) and the free rigid bodies (f.n_bodies, the strong coupling's)
  /// are unknowns of the solve too (kernels/viscosity.cl, viscosity_cg_node_*, viscosity_cg_body_*).
  /// ghost_mode: Model::ghost_velocity_mode, which boundary particles bvisc mirrors.
  ViscositySolveResult viscositySolve(const SimParams& p, const DfsphFields& f, const cl::Buffer& bvisc,
                                      uint32_t ghost_mode);
  /// With cloth or soft-body nodes or free bodies in the last implicit viscosity solve (its unknowns too):
  /// bvisc with their solved velocities, for their reaction (rigid.cl, rigid_fluid_forces) (n_boundary x
  /// float4) (unit: m/s); else null. Valid until the next step's solve.
  const cl::Buffer* nodeViscousVelocities() const { return nodes_solved_ ? &bvisc_nodes_ : nullptr; }
  /// Extrapolated walls' contact (kernels/dfsph.cl, dfsph_wall_contact_accel; from cloth nodes too):
  /// its stiffness dt^2 k_w / dx (0 where it does not act: other walls) and its range r0 / dx (unit:
  /// 1); the cloth nodes take its reaction (rigid.cl, rigid_fluid_forces).
  float wallContactStiffness() const;
  static float wallContactRange();

 private:
  enum class Kind { Divergence, Density };
  bool mirrored() const { return spec_.walls == DfsphWalls::Mirrored; }
  bool extrapolated() const { return spec_.walls == DfsphWalls::Extrapolated; }
  /// Extrapolated walls: the wall pressure p_b of `pressure` (Adami et al. 2012 eq. 27; with the
  /// hydrostatic term g . sum rho r W in the density solve only: the divergence solve's pressure
  /// acts on a flow without gravity).
  void boundaryPressure(Kind kind, const SimParams& p, const DfsphFields& f, const cl::Buffer& pressure);
  /// The running solve's wall pressures (extrapolated walls; else unused).
  cl::Buffer& wallPressure(Kind kind) { return kind == Kind::Divergence ? bp_div_ : bp_dens_; }
  /// Weight of a wall's pressure term: 2 mirrors p_i (p_b = p_i), 1 is Akinci's single term.
  float wallFactor() const { return mirrored() ? 2.0f : 1.0f; }
  DfsphSolveResult solve(Kind kind, const SimParams& p, const DfsphFields& f);
  /// The solve's source from the current velocities and its starting pressure (warm start).
  void source(Kind kind, const SimParams& p, const DfsphFields& f, cl::Buffer& pressure, bool at_rest);
  /// The density solve's warm start is averaged over two steps in some steps (warm_average,
  /// warm_average_rest): the last pressure is kept.
  bool averaging() const { return spec_.warm_start && (spec_.warm_average > 0.0 || spec_.warm_average_rest > 0.0); }
  /// One relaxed Jacobi iteration: pressure accelerations, then the pressures and their errors.
  void iterate(Kind kind, const SimParams& p, const DfsphFields& f, cl::Buffer& pressure);
  /// v += dt a^p of the pressures found.
  void apply(Kind kind, const SimParams& p, const DfsphFields& f, const cl::Buffer& pressure);
  /// Mirrored walls: the first version's solve (increments from the velocities, each >= 0, applied
  /// every iteration; half the last pressure as warm start).
  DfsphSolveResult solveMirrored(Kind kind, const SimParams& p, const DfsphFields& f);
  void sourceIncrements(Kind kind, const SimParams& p, const DfsphFields& f, bool warm);
  void applyIncrements(const SimParams& p, const DfsphFields& f, cl::Buffer& pacc);
  /// The average error of the last iteration; with `f` and `body_error`, also the bodies' largest
  /// error (bodyError), read in the same wait for the device.
  double averageError(std::size_t n, const DfsphFields* f = nullptr, double* body_error = nullptr);
  // the sum of err_'s first n values, chunk sums in a fixed order (averageError is it over n)
  double errorSum(std::size_t n, const DfsphFields* f = nullptr, double* body_error = nullptr);
  cl::Buffer makeBuffer(std::size_t bytes);
  /// Two-level solve (kernels/dfsph_coarse.cl, core/dfsph_coarse.cpp): the Galerkin coarse-grid
  /// correction of `pressure` on aggregates of one support H, projected to p >= 0.
  /// ... true when it reused an assembled operator (fluid.dfsph.coarse_reuse).
  bool coarseCorrection(Kind kind, const SimParams& p, const DfsphFields& f, cl::Buffer& pressure);
  bool coarse() const { return spec_.coarse_interval > 0 && !mirrored(); }
  /// The free bodies (body_coupling strong) take part in the coarse corrections (fluid.dfsph.body_coarse).
  bool bodyCoarse() const { return bodies_ && coarse() && spec_.body_coarse; }

  ClContext& cl_;
  KernelSet& kernels_;
  DfsphSpec spec_;
  bool one_mass_ = false;        // every phase's particle mass is the same (kernels/dfsph.cl, dfsph_factor)
  double dx_ = 0.0;              // the lattice spacing (unit: m)
  uint32_t min_neighbours_ = 0;  // divergence solve: fewer neighbours = free surface, left alone
  std::size_t bytes_ = 0;
  static constexpr uint32_t kChunks = 64;  // chunks of the error reduction
  // Share of the previous step's pressure a solve starts from (the reference implementation's 0.5).
  cl::Buffer alpha_, err_, partial_;
  cl::Buffer source_;                      // s_i of the running solve (unit: 1); mirrored: the increments (unit: Pa)
  cl::Buffer accel_;                       // pressure accelerations of the current pressures (n x float4) (unit: m/s^2)
  // Packed for the pressure-force passes (kernels/dfsph.cl, dfsph_force): position (unit: m) and
  // p / delta^2 of the running solve's pressure (mirrored: of the increments) (unit: Pa m^6), (n x float4).
  cl::Buffer xt_;
  // Per particle, from the factor pass: the wall sums (G_b = sum_b psi_b gradW_ib (unit: 1/m^4),
  // sum_b psi_b v_b . gradW_ib (unit: 1/(m^3 s))) the solves use instead of wall loops (n x float4).
  cl::Buffer gwall_;
  // Boundary particles that move inside the solves (factors(): nodes_ this step; cloth nodes, and
  // bodies with body_coupling strong), per boundary slot: M_b^-1 (3 float4; 0 for walls, bodies,
  // anchored nodes) and the particle's pressure acceleration of the current pressures.
  cl::Buffer bminv_, bacc_;
  bool nodes_ = false;   // any of them this step: cloth nodes (cloth_) or bodies (bodies_)
  bool cloth_ = false;
  // ... and per node, each solve's last sweep of the nodes' accelerations (kept from step to step:
  // the warm start of the nodes' block-Jacobi sweeps) and a scratch half (unit: m/s^2).
  cl::Buffer nacc_div_, nacc_dens_, nacc_tmp_;
  void nodeAccel(Kind kind, const SimParams& p, const DfsphFields& f);
  // Rigid bodies inside the solves (factors(): bodies_ this step): per body, each solve's relaxed
  // (a, alpha) (2 float4; kept from step to step) (unit: m/s^2, 1/s^2); the divergence solve's final
  // one is ready for the density solve's rate (body_div_ready_).
  cl::Buffer bbacc_div_, bbacc_dens_;
  cl::Buffer berr_;  // per body, the last iteration's error (dfsph_body_accel) (unit: m/s^2)
  double bodyError(const DfsphFields& f);
  bool bodies_ = false, body_div_ready_ = false;
  /// The bodies' accelerations under the current pressures (relaxed by `relax`), into their slots of
  /// bacc_ when `slots`.
  void bodyAccel(Kind kind, const SimParams& p, const DfsphFields& f, float relax, bool slots);
  cl::Buffer pdiv_, pdens_;                // the solves' pressures (unit: Pa), kept for the warm start
  bool divergence_ran_ = false;            // the divergence solve runs (its wall pressure counts)
  bool rate_in_source_ = false;            // source_ holds the divergence solve's density rate (factors())
  bool accel_ready_ = false;               // accel_ holds the first iteration's accelerations (source())
  double prev_dt_div_ = 0.0, prev_dt_dens_ = 0.0;  // step of the last solve of each kind (unit: s)
  // Chebyshev semi-iteration (spec chebyshev): on in this solve (a moving step), the iterations of its
  // sequence so far, the last weight, and the iterate before the last
  bool cheb_on_ = false;
  int cheb_k_ = 0;
  double cheb_w_ = 1.0;
  cl::Buffer cheb_;
  cl::Buffer vel_before_;                  // velocities before the density solve, or the implicit viscosity's v' (unit: m/s)
  bool viscous_kept_ = false;              // vel_before_ holds this step's implicit viscosity solution
  cl::Buffer vdiag_, vr_, vz_, vd_, vq_;   // implicit viscosity: the diagonal of A, residual, preconditioned residual, direction, M A d
  cl::Buffer vkeep_;                       // implicit viscosity: the velocities before the last pressure was applied
  // Implicit viscosity with cloth and soft-body nodes as unknowns (kernels/viscosity.cl, viscosity_cg_node_*):
  // the unknown slots' flags (n_boundary), each node's 3 x 3 block and its inverse (3 float4), solution, residual,
  // preconditioned residual, direction, M A d (float4), r . z (float), the boundary velocities with the
  // solved nodes' (n_boundary x float4), and each node's viscous velocity change (float4).
  cl::Buffer vnode_, nA_, nP_, ny_, nr_, nz_, nd_, nq_, nerr_, bvisc_nodes_, ndv_;
  // and free bodies (viscosity_cg_body_*): each unknown slot's direction (n_boundary x float4), per moving
  // particle the gathered sums (f, K) and its arm r (float4), per body the pair (dV, dOmega) (2 float4)
  cl::Buffer bdir_, bfk_, brk_, bdirs_;
  cl::Buffer bvisc_start_;                 // the boundary velocities of the solve's start (the bodies' incremental start)
  std::size_t vnode_cap_ = 0, nodes_cap_ = 0, bodies_cap_ = 0, bodies_dir_cap_ = 0, bvisc_start_cap_ = 0;
  bool body_dv_pending_ = false;           // bdirs_ holds this step's bodies' viscous change dU, for the density solve
  float body_inv_g_ = 1.0f;                // 1 / g of the bodies' unknowns (viscositySolve)
  bool nodes_solved_ = false;              // the last viscosity solve had nodes (nodeViscousVelocities)
  bool node_dv_pending_ = false;           // ndv_ holds this step's nodes' viscous change, for the density solve
  /// The sum of nerr_'s first n values, chunk sums in a fixed order (as errorSum).
  double nodeErrorSum(std::size_t n);
  cl::Buffer bp_div_, bp_dens_;            // extrapolated walls: each solve's wall pressures (unit: Pa)
  // Extrapolated walls: each wall particle's fluid neighbours within H for the step, in grid order
  // (kernels/dfsph.cl, dfsph_wall_lists; n_boundary x kWallSlots), and their counts (n_boundary).
  // A wall particle in a fluid at rest has ~15-20; one with more than kWallSlots scans the cells.
  static constexpr uint32_t kWallSlots = 32;
  cl::Buffer wall_list_, wall_count_;
  // ... and the step's wall particles with fluid near them (n_boundary; the first n_wall_active_).
  cl::Buffer wall_active_, wall_active_count_;
  // ... each listed pair's W_bf (n_boundary x kWallSlots) and per wall particle the sums that do
  // not depend on the pressures, (sum_f rho_f W_bf x_bf, sum_f W_bf) (n_boundary x float4).
  cl::Buffer wall_weight_, wall_sum_;
  uint32_t n_wall_active_ = 0;
  cl::Buffer scratch_a_, scratch_b_;       // reorder targets (swapped with pdiv_, pdens_); mirrored: a holds the previous pressure in a warm start
  // warm_average > 0: the last step's density pressure before its averaged warm start (n), and its
  // reorder / copy target; set once the first density solve has run.
  cl::Buffer previous_, previous_out_;
  bool have_previous_ = false;
  // Coarse-grid correction (coarse_interval > 0; kernels/dfsph_coarse.cl), all on the device. Per
  // particle (n): its aggregate cell, active flag, residual and the trial's (unit: 1), its
  // aggregate number (-1: none), per aggregate slot F and R (n x 27 x 2 float4) with their
  // non-zero masks (n x uint2), the prolonged correction and trial pressures (unit: Pa). Per
  // aggregate (coarseRows): K's 125-slot rows and their columns (unit: m^3 s^2/kg), and the
  // BiCGStab vectors (b = r0hat, x, r, phat, p, v, shat, t); the aggregate count and the solve's
  // iterations (2 x uint), the line search's chunk sums and its step theta.
  static std::size_t coarseRows(std::size_t n) { return n / 4 + 1; }
  cl::Buffer cagg_, cact_, cres_, ctres_, cmem_, cfr_, cmask_, cdp_, ctrial_;
  cl::Buffer ckval_, ckcol_, cb_, cx_, cr_, cph_, cp_, cv_, csh_, ct_;
  cl::Buffer cmcount_, cpartial_, ctheta_;
  // Per aggregate cell of the box (coarseBox): "is an aggregate", P^T r and the aggregate number;
  // per aggregate its box cell.
  std::array<int32_t, 4> cbox_{};
  cl::Buffer cbok_, cbb_, cbnum_, ccell_;
  uint64_t coarse_cells_step_ = ~uint64_t(0);  // the step cagg_ was computed in
  // Free bodies in the coarse system (bodyCoarse()): each boundary slot's free body (-1: none), computed
  // once per step, and per aggregate and body the terms scale W and V (4 float4; kernels/dfsph_coarse.cl,
  // dfsph_coarse_bodies) for up to cbody_count_ bodies.
  cl::Buffer csbody_, ccwv_;
  std::size_t coarse_rows_ = 0;  // the most aggregates (coarseRows of the capacity)
  uint32_t cbody_count_ = 0;
  // The assembled operator's solve kind (-1: none), step, dt (unit: s) and the travel summed to
  // then; the fastest particle's travel summed over the steps (unit: m) (fluid.dfsph.coarse_reuse).
  int coarse_k_kind_ = -1;
  uint64_t coarse_k_step_ = 0;
  double coarse_k_dt_ = 0.0, coarse_k_travel_ = 0.0, coarse_travel_ = 0.0;

  uint64_t steps_ = 0;           // steps so far (factors() counts them)
};

}  // namespace sph
