/* Two-way coupling of moving (dynamic and kinematic) rigid bodies with the fluid (stage: rigid_coupling).
 *
 * Design: a moving body is a set of boundary particles like a wall (Akinci et al. 2012), so the
 * fluid kernels need no change. The boundary buffer holds the static particles, then the moving
 * ones; the source copy `bsrc` is in that order, the copy the fluid reads (`bpos`) is sorted by
 * grid cell with the cell table `bcell_start`:
 *
 *   bsrc: [ static (fixed) ........ | body 0 | body 1 | ... ]   <- rigid_transform, every step
 *            \ counting sort by cell at each neighbour-list rebuild (grid.cl kernels) /
 *   bpos: [ cell 0 | cell 1 | ... ]  slot[k] = where bsrc[k] went   <- rigid_transform too
 *
 * Each step: (1) rigid_transform places the moving particles from their body's pose;
 * (2) after the fluid's pressure pass, rigid_fluid_forces gathers on each moving particle the
 * reaction to the force it exerts on its fluid neighbours (equal and opposite, so momentum is
 * exchanged exactly up to rounding); (3) rigid_reduce sums force and torque per body in particle
 * order (a fixed order: deterministic), and only those 6 numbers per body go to the host. */

/* Rotates v by the unit quaternion q = (x, y, z, w). */
inline float3 sph_rotate(const float4 q, const float3 v) {
  const float3 u = q.xyz;
  const float3 t = 2.0f * cross(u, v);
  return v + q.w * t + cross(u, t);
}

/* (1) World positions and velocities of the moving particles k (0..n-1): pose[4b] = centre of
 * mass, pose[4b+1] = orientation (x, y, z, w), pose[4b+2] = velocity of the centre, pose[4b+3] =
 * angular velocity (world) of body b = body[k]; body_local[k] = body-frame position and volume
 * ratio (w). Written to bsrc[n_static + k] and to its sorted slot in bpos and bvel. */
__kernel void rigid_transform(const uint n, const uint n_static, __global const float4* body_local,
                              __global const uint* body, __global const float4* pose, __global const uint* slot,
                              __global float4* bsrc, __global float4* bpos, __global float4* bvel) {
  const uint k = get_global_id(0);
  if (k >= n) return;
  const uint b = body[k];
  const float4 l = body_local[k];
  const float3 r = sph_rotate(pose[4 * b + 1], l.xyz);
  const float4 out = (float4)(pose[4 * b].xyz + r, l.w);
  const uint s = slot[n_static + k];
  bsrc[n_static + k] = out;
  bpos[s] = out;
  bvel[s] = (float4)(pose[4 * b + 2].xyz + cross(pose[4 * b + 3].xyz, r), 1.0f); /* w = 1: a body particle */
}

/* Gathers the boundary particles into cell order after a counting sort (grid.cl) of bsrc, and
 * records where each one went. The velocities go into the new order too: zero for static
 * particles, the rigid motion for the n_moving body particles (as rigid_transform writes it);
 * cloth nodes (after those) are rewritten by cloth_to_boundary right after the sort. (Before
 * issue 15 bvel kept the old order until the next step's rigid_transform: for one step after each
 * sort the fluid saw body particles at rest and wall particles moving.) */
__kernel void rigid_boundary_reorder(const uint n, const uint n_static, const uint n_moving,
                                     __global const uint* sorted, __global const float4* bsrc,
                                     __global const float4* body_local, __global const uint* body,
                                     __global const float4* pose, __global float4* bpos,
                                     __global float4* bvel, __global uint* slot) {
  const uint s = get_global_id(0);
  if (s >= n) return;
  const uint k = sorted[s];
  bpos[s] = bsrc[k];
  slot[k] = s;
  float4 v = (float4)(0.0f);
  if (k >= n_static && k < n_static + n_moving) {
    const uint b = body[k - n_static];
    const float3 r = sph_rotate(pose[4 * b + 1], body_local[k - n_static].xyz);
    v = (float4)(pose[4 * b + 2].xyz + cross(pose[4 * b + 3].xyz, r), 1.0f);
  }
  bvel[s] = v;
}

/* A per-particle float4 of the static boundary particles (source order, src[k], k < n_static) into
 * the sorted order of rigid_boundary_reorder; zero on the moving particles and cloth nodes. Used for
 * the static bodies' surface normals (Model::boundary_normal). */
__kernel void boundary_reorder_static(const uint n, const uint n_static, __global const uint* sorted,
                                      __global const float4* src, __global float4* out) {
  const uint s = get_global_id(0);
  if (s >= n) return;
  const uint k = sorted[s];
  out[s] = k < n_static ? src[k] : (float4)(0.0f);
}

/* (2) Force of the fluid on each moving particle: the opposite of the boundary terms of
 * pressure.cl (with `mirror`, of dfsph.cl: 2 psi_b p_i / delta_i^2 gradW, no contact term) that
 * this particle b contributes to each fluid neighbour i within H:
 *     pressure (p_b: boundary_pressure):     F_b = + (V_b/V0) (p_i + p_b) / delta_i^2 gradW-factor (x_i - x_b)
 *     contact  (pair_loops.h):               F_b = - m_i (V_b/V0) k_c c0^2/dx (1 - r/r0) (x_i - x_b) / r,
 *                                            r0 = dx/2 on a body's particle, dx on a cloth node
 *     viscosity (pair_loops.h):              F_b = - m_i a_visc(i from b)
 *     DFSPH's wall contact, on a cloth node (`contact` = dt^2 k_w / dx > 0: extrapolated walls;
 *     dfsph.cl, dfsph_wall_contact_accel): F_b = - m_i (V_b/V0) k_w (1 - r/r0) (x_i - x_b) / r,
 *                                            k_w = contact dx / dt^2, r0 = `range` dx
 * Fluid neighbours come from the fluid grid of the last list rebuild: its cells are H + skin
 * wide and no particle has moved skin/2 since, so the 27 cells hold every neighbour within H.
 * With `ambient` > 0 (fluid.body_ambient_pressure subtract, WCSPH or DFSPH's extrapolated walls; the
 * weight dt / tau of a running mean) it also writes geo[k] = (g_k, pbar_k): g_k the pressure force per pascal added to every p_i
 * and p_b (the particle's share of the sampled surface's closure, sum_k g_k, zero for a closed surface
 * in a continuum), and pbar_k the running mean of p_b, kept in pmean, or -1 where no fluid is within H
 * (a dry particle). */
__kernel void rigid_fluid_forces(const SimParams p, const uint n, const uint n_static, __global const float4* bsrc,
                                 __global const uint* slot, __global const float4* bvel,
                                 __global const float* bpressure, __global const float4* pos,
                                 __global const float4* vel, __global const uint* phase,
                                 __global const float* density, __global const float* pterm,
                                 __global const uint* cell_start, const int viscous, const int mirror,
                                 const float contact, const float range, __global float4* force,
                                 const float ambient, __global float4* geo, __global float* pmean) {
  const uint k = get_global_id(0);
  if (k >= n) return;
  const float4 bb = bsrc[n_static + k];
  const uint s = slot[n_static + k];
  const float pb = bpressure[s];
  const float4 vb4 = bvel[s]; /* w = 1 on a rigid body's particle, 0 on a cloth node */
  const float3 vb = vb4.xyz;
  const float3 xb = bb.xyz;
  const float H = p.support;
  const float H2 = H * H;
  /* DFSPH's wall contact acts on the fluid from walls and cloth nodes, not from bodies' particles */
  const float dx = cbrt(p.rest_volume);
  const float kw = vb4.w > 0.5f ? 0.0f : contact * dx / (p.dt * p.dt), r0 = range * dx;
  float3 f = (float3)(0.0f), g = (float3)(0.0f); /* g: the pressure force per pascal added to p_i and p_b */
  int wet = 0;
  SPH_FOR_NEIGHBOURS(&p, cell_start, xb, i) {
    const float3 d = pos[i].xyz - xb;
    const float r2 = dot(d, d);
    if (r2 < H2) {
      const float r = sqrt(r2);
      if (kw > 0.0f && r < r0 && r > 1e-6f * dx) f -= p.phase_mass[phase[i]] * (bb.w * kw * (1.0f - r / r0) / r) * d;
      const float mi = p.phase_mass[phase[i]];
      const float inv_delta = mi / density[i];
      const float F = sph_grad_factor(SPH_KERNEL, r, H);
      if (mirror > 0) { /* DFSPH (dfsph.cl): pterm = both solves' p / delta^2, weighed `mirror` = 2 (p_b = p_i)
                         * or 1 (single wall term); no contact term */
        f += bb.w * (float)mirror * pterm[i] * F * d;
      } else { /* WCSPH (mirror 0) and DFSPH's extrapolated walls (-1: both solves' p_b, no contact) */
        f += bb.w * (pterm[i] + pb * inv_delta * inv_delta) * F * d;
        if (ambient > 0.0f) { /* Model::body_ambient_subtract: WCSPH, DFSPH's extrapolated walls */
          g += bb.w * 2.0f * inv_delta * inv_delta * F * d;
          wet = 1;
        }
        if (mirror == 0) f -= mi * sph_boundary_contact(&p, d, r, bb.w, vb4.w > 0.5f); /* r0 = dx/2 on bodies */
      }
      if (viscous)
        f -= mi * sph_boundary_viscosity(&p, mi, density[i], p.phase_viscosity[phase[i]], vel[i].xyz - vb, d, r2, F, bb.w, vb4);
    }
  }
  SPH_END_NEIGHBOURS
  force[k] = (float4)(f, 0.0f);
  if (ambient > 0.0f) { /* the running mean of p_b; w = -1 marks a dry particle (rigid_reduce) */
    const float e = pmean[k] + ambient * (pb - pmean[k]);
    pmean[k] = e;
    geo[k] = (float4)(g, wet ? e : -1.0f);
  }
}

/* (3) Per body b: particles range[2b] .. range[2b] + range[2b+1] - 1, summed in order.
 * out[2b] = force (unit: N), out[2b+1] = torque about the centre of mass (unit: N m).
 * With `ambient` (fluid.body_ambient_pressure subtract) each particle's force first loses
 * p_ref g_k (geo: rigid_fluid_forces), and force[k] keeps what is summed. A constant pressure on a
 * wholly wetted closed surface exerts no force, but the pair sum's closure sum_k g_k is not zero
 * where the fluid crowds in front of a moving body and thins behind it, so the ambient pressure
 * times it was a drag: ~1.5x the whole drag a sphere should feel, for a 6 cm ball sinking 8 cm
 * deep at R / dx = 3, and more deeper (docs/forces.md, session 32). The fluid keeps its full
 * boundary terms (they hold it off the body), so the body's force and its reaction on the fluid
 * differ by p_ref sum_k g_k. g_rho = (g, rho0): gravity and the first phase's rest density. */
__kernel void rigid_reduce(const uint n_bodies, const uint n_static, __global const uint* range,
                           __global const float4* pose, __global const float4* bsrc,
                           __global float4* force, const int ambient, __global const float4* geo,
                           const float4 g_rho, __global float4* out) {
  const uint b = get_global_id(0);
  if (b >= n_bodies) return;
  const float3 c = pose[4 * b].xyz;
  float3 F = (float3)(0.0f), T = (float3)(0.0f);
  const uint begin = range[2 * b], end = begin + range[2 * b + 1];
  /* The reference pressure (fluid.body_ambient_pressure subtract): 0 if a particle is dry; else the least
   * running mean brought to the centre's depth, p~_k = pbar_k - rho0 g.(x_k - c), at most twice the least
   * running mean itself (so it goes to 0 with the pressure at the body's top near a free surface). */
  float pref = 0.0f;
  if (ambient && end > begin) {
    float low = INFINITY, level = INFINITY;
    for (uint k = begin; k < end; ++k) {
      low = fmin(low, geo[k].w);
      level = fmin(level, geo[k].w - g_rho.w * dot(g_rho.xyz, bsrc[n_static + k].xyz - c));
    }
    pref = low < 0.0f ? 0.0f : fmax(fmin(level, 2.0f * low), 0.0f);
  }
  for (uint k = begin; k < end; ++k) {
    float3 f = force[k].xyz;
    if (ambient) { /* less pref x the particle's share of the closure error; kept per particle (readBodyParticles) */
      f -= pref * geo[k].xyz;
      force[k] = (float4)(f, 0.0f);
    }
    F += f;
    T += cross(bsrc[n_static + k].xyz - c, f);
  }
  out[2 * b] = (float4)(F, 0.0f);
  out[2 * b + 1] = (float4)(T, 0.0f);
}

/* (4) DFSPH's fictitious body mass (Baek & Karniadakis 2012, J. Comput. Phys. 231, 629, eq. 9;
 * Simulation::addedMassReaction). A dynamic body with the fictitious mass M feels, besides the
 * gathered fluid force, M (a_{n-1} - a_n): the added-mass reaction that the lagged solve has not
 * answered yet. Its opposite, -J = -M (a_{n-1} - a_n) dt, goes to the fluid near the body, spread
 * in proportion to psi_b W(x_i - x_b) over the pairs (fluid i, body particle b) within H:
 *     dv_i = sum_b psi_b W_ib share_body(b),   share = -J / S,   S = sum_b psi_b sum_i m_i W_ib,
 * so sum_i m_i dv_i = -J exactly (up to rounding): the total momentum is conserved. Gathers only:
 * (4a) each body particle sums its own s_b, (4b) each body sums its particles in order, (4c)
 * each fluid particle sums its own dv_i. (4a) reads the fluid grid, (4c) this step's boundary
 * lists: both hold every pair within H at the step's start, and W is continuous at H (0), so
 * they weigh the same pairs. */

/* (4a) s_k = psi_b sum_i m_i W(|x_i - x_b|) over the fluid within H of moving particle k
 * (unit: kg/m^3). */
__kernel void rigid_wet_weight(const SimParams p, const uint n, const uint n_static, __global const float4* bsrc,
                               __global const float4* pos, __global const uint* phase,
                               __global const uint* cell_start, __global float* weight) {
  const uint k = get_global_id(0);
  if (k >= n) return;
  const float4 bb = bsrc[n_static + k];
  const float3 xb = bb.xyz;
  const float H = p.support;
  const float H2 = H * H;
  float s = 0.0f;
  SPH_FOR_NEIGHBOURS(&p, cell_start, xb, i) {
    const float3 d = pos[i].xyz - xb;
    const float r2 = dot(d, d);
    if (r2 < H2) s += p.phase_mass[phase[i]] * sph_w(SPH_KERNEL, sqrt(r2), H);
  }
  SPH_END_NEIGHBOURS
  weight[k] = bb.w * s;
}

/* (4b) Per body b: S_b = sum of s_k over its particles range[2b] .. range[2b] + range[2b+1] - 1,
 * in order (unit: kg/m^3). */
__kernel void rigid_reduce_weight(const uint n_bodies, __global const uint* range, __global const float* weight,
                                  __global float* out) {
  const uint b = get_global_id(0);
  if (b >= n_bodies) return;
  float S = 0.0f;
  const uint begin = range[2 * b], end = begin + range[2 * b + 1];
  for (uint k = begin; k < end; ++k) S += weight[k];
  out[b] = S;
}

/* (4c) Each fluid particle i: v_i += sum over this step's boundary neighbours b within H that
 * belong to a moving body: psi_b W_ib share[body] (share: -J / S, unit: m^4/s). Slot s of bpos
 * holds boundary particle sorted[s]; n_static <= it < n_static + n_moving: a moving body's. */
__kernel void rigid_added_mass_reaction(const SimParams p, const uint n_static, const uint n_moving,
                                        __global const float4* pos, __global const float4* bpos,
                                        __global const uint* sbnbr, __global const uint* sbnbr_count,
                                        __global const uint* sorted, __global const uint* body,
                                        __global const float4* share, __global float4* vel) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const float3 dv = sph_boundary_share_dv(&p, i, pos, bpos, sbnbr, sbnbr_count, sorted, n_static, n_moving, body, share);
  const uint nb = sbnbr_count[i];
  if (nb > 0) vel[i] = (float4)(vel[i].xyz + dv, vel[i].w);
}
