/* Viscosity (stage: viscosity) on its own: adds to the acceleration written by the pressure stage.
 * Used when the pressure stage is disabled; with both on, pressure.cl's fused pass computes the
 * same terms in its neighbour loop. The pair terms are in shared/pair_loops.h:
 *   artificial (Monaghan 1992, eq. 4.2 of Monaghan 2005):
 *     a_i += -sum_j m_j Pi_ij grad W_ij,  Pi_ij = -alpha c0 h mu_ij / rho_ij  (approaching pairs only),
 *     mu_ij = (v_ij . x_ij) / (|x_ij|^2 + 0.01 h^2),  rho_ij = (rho_i + rho_j) / 2
 *   laminar (Morris, Fox & Zhu 1997, eq. 8):
 *     a_i += sum_j m_j (mu_i + mu_j) / (rho_i rho_j) (x_ij . grad W_ij) / (|x_ij|^2 + 0.01 h^2) v_ij,
 *     mu = rho nu (dynamic viscosity from the phase's kinematic viscosity nu)
 * Boundary particles take part with their velocity (shared/pair_loops.h, sph_boundary_viscosity): the
 * wall's own, or the no-slip ghost velocity of boundary_ghost_velocity below (fluid.boundary_velocity). */
__kernel void viscosity_force(const SimParams p, __global const float4* pos, __global const float4* vel,
                              __global const uint* phase, __global const float* density,
                              __global const uint* nbr, __global const uint* nbr_count,
                              __global const float4* bpos, __global const float4* bvel,
                              __global const uint* bnbr, __global const uint* bnbr_count, __global float4* acc) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const uint K = p.max_neighbours;
  const SphPairSums s = sph_pair_sums(&p, i, pos, vel, phase, density, density, nbr, nbr_count[i], 0, 1);
  const float3 xi = pos[i].xyz, vi = vel[i].xyz;
  const float mi = p.phase_mass[phase[i]], rhoi = density[i], nu = p.phase_viscosity[phase[i]];
  float3 av = (float3)(0.0f);
  for (uint k = 0; k < bnbr_count[i]; ++k) {
    const uint b = bnbr[(size_t)i * K + k];
    const float3 d = xi - bpos[b].xyz;
    const float r2 = dot(d, d);
    av += sph_boundary_viscosity(&p, mi, rhoi, nu, vi - bvel[b].xyz, d, r2, sph_grad_factor(SPH_KERNEL, sqrt(r2), p.support), bpos[b].w, bvel[b]);
  }
  acc[i] += (float4)(s.av + av, 0.0f);
}

/* No-slip ghost velocity of boundary particle b (Adami, Hu & Adams 2012, eq. 22-23):
 *     v~_b = sum_f v_f W_bf / sum_f W_bf        (Shepard interpolation of the fluid velocity at b)
 *     v_ghost,b = 2 v_b - v~_b                  (v_b: the wall's or body's own velocity)
 * The fluid then sees, across the wall, a velocity mirrored about the wall's: the viscous term
 * between a fluid particle and the boundary shears over the distance to the wall, not to the far
 * side of the boundary particle, so the wall stress is that of a no-slip wall. (With v_b itself,
 * the boundary particles dx/2 behind the wall moving at the wall's speed, the fluid-boundary term
 * sees about half the shear: the Stokes drag of a towed ball came out 0.9 x 6 pi mu R U where the
 * box's wall factor asks for 2.0-2.6; docs/forces.md.)
 * Used only in the viscous term (pressure.cl's fused pass, viscosity_force, rigid.cl's reaction);
 * the rigid motion in bvel is unchanged. `mode`: 1 = every boundary particle, 2 = only moving
 * bodies' particles (bvel.w = 1; the laminar body term of body_viscosity physical); the others
 * keep their own velocity. Only boundary particles that some fluid particle saw within H this step
 * (marked by the density pass with `stamp`) are computed: the others are never read. The w
 * component is bvel's (the body flag). The fluid comes from the grid of the last list rebuild
 * (cells H + skin wide, no particle moved more than skin / 2 since), in cell order: deterministic. */
__kernel void boundary_ghost_velocity(const SimParams p, const uint n_boundary, const uint stamp, const uint mode,
                                      __global const float4* bpos, __global const float4* bvel,
                                      __global const uint* bmark, __global const float4* pos,
                                      __global const float4* vel, __global const uint* cell_start,
                                      __global float4* bghost) {
  const uint b = get_global_id(0);
  if (b >= n_boundary) return;
  const float4 vb = bvel[b];
  /* Not seen by the fluid this step, or not a particle this mode mirrors: its own velocity. */
  if (bmark[b] != stamp || (mode == 2u && !(vb.w > 0.5f))) {
    bghost[b] = vb;
    return;
  }
  const float3 xb = bpos[b].xyz;
  const float H = p.support;
  float sw = 0.0f;
  float3 svw = (float3)(0.0f);
  /* Shepard sums over the fluid within H, in cell order */
  SPH_FOR_NEIGHBOURS(&p, cell_start, xb, f) {
    const float3 d = xb - pos[f].xyz;
    const float r2 = dot(d, d);
    if (r2 < H * H) {
      const float w = sph_w(SPH_KERNEL, sqrt(r2), H);
      sw += w;
      svw += w * vel[f].xyz;
    }
  }
  SPH_END_NEIGHBOURS
  /* 2 v_b - v~_b (eq. 23); with no fluid within H, the wall's own velocity */
  bghost[b] = sw > 0.0f ? (float4)(2.0f * vb.xyz - svw / sw, vb.w) : vb;
}

/* ---- Implicit laminar viscosity (fluid.dfsph.viscosity_solve: implicit) ------------------------
 * Morris et al. 1997's viscous acceleration (shared/pair_loops.h, laminar) is linear in the
 * velocities:
 *     a_i = -sum_j k_ij (v_i - v_j) - sum_b k_ib (v_i - v_b),
 *     k_ij = -m_j (mu_i + mu_j) F_ij r^2 / (rho_i rho_j (r^2 + 0.01 h^2)) >= 0   (F_ij < 0; sph_laminar_coefficient),
 *     k_ib = -2 psi_b m_i nu_i / rho_i F_ib r^2 / (r^2 + 0.01 h^2) >= 0          (sph_boundary_laminar),
 * v_b the boundary's no-slip (ghost) or own velocity of this step, held fixed. Backward Euler for it,
 * v' = v + dt a(v'), is the linear system A v' = v + dt sum_b k_ib v_b with
 *     (A x)_i = (1 + dt sum_j k_ij + dt sum_b k_ib) x_i - dt sum_j k_ij x_j.
 * m_i k_ij = m_j k_ji, so M A (M the particle masses) is symmetric, and positive definite (diagonally
 * dominant with a positive diagonal): it is solved by conjugate gradients preconditioned with its
 * diagonal, one gather pass per iteration (viscosity_cg_apply), the dot products as chunk sums in a
 * fixed order (dfsph_reduce, then the host in double): bitwise deterministic. The three velocity
 * components share the matrix and are solved as one vector (the dot products add the components).
 * Weiler, Koschier, Brand & Bender 2018 ("A physically consistent implicit viscosity solver for SPH
 * fluids") solve viscosity implicitly with CG the same way, with their own operator; this one is the
 * explicit term the solver already has, so the implicit and explicit steps agree as dt -> 0. */
/* k_ij of fluid neighbour j of particle i (at xi, with mu_i and rho_i): minus the explicit term's
 * coefficient (shared/pair_loops.h, sph_laminar_coefficient) at their distance. */
inline float viscosity_cg_k(const SimParams* p, const float3 xi, const float mui, const float rhoi, const uint j,
                            __global const float4* pos, __global const uint* phase, __global const float* density) {
  const float3 dij = xi - pos[j].xyz;
  const float r2 = dot(dij, dij);
  const uint phj = phase[j];
  const float rhoj = density[j];
  return -sph_laminar_coefficient(p->phase_mass[phj], mui, rhoj * p->phase_viscosity[phj], rhoi, rhoj,
                                  sph_grad_factor(SPH_KERNEL, sqrt(r2), p->support), r2, 0.01f * p->h * p->h);
}

/* The step's start: x = v, r = M (b - A v) = M dt a(v) (the explicit viscous increment), z = r / (M diag),
 * the direction d = z, and r . z per particle for the reduction. */
__kernel void viscosity_cg_setup(const SimParams p, __global const float4* pos, __global const float4* vel,
                                 __global const uint* phase, __global const float* density,
                                 __global const uint* nbr, __global const uint* nbr_count,
                                 __global const float4* bpos, __global const float4* bvel,
                                 __global const uint* bnbr, __global const uint* bnbr_count, __global float* diag,
                                 __global float4* x, __global float4* r, __global float4* z, __global float4* d,
                                 __global float* rz) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const uint K = p.max_neighbours;
  const float H = p.support;
  const float3 xi = pos[i].xyz, vi = vel[i].xyz;
  const uint phi = phase[i];
  const float mi = p.phase_mass[phi], rhoi = density[i], nui = p.phase_viscosity[phi], mui = rhoi * nui;
  float ksum = 0.0f;
  float3 a = (float3)(0.0f);
  const SphList l = sph_list(&p, nbr, i);
  for (uint k = 0; k < nbr_count[i]; ++k) {
    const uint j = sph_list1(l, k);
    const float kij = viscosity_cg_k(&p, xi, mui, rhoi, j, pos, phase, density);
    ksum += kij;
    a -= kij * (vi - vel[j].xyz);
  }
  for (uint k = 0; k < bnbr_count[i]; ++k) {
    const uint b = bnbr[(size_t)i * K + k];
    const float3 dib = xi - bpos[b].xyz;
    const float r2 = dot(dib, dib);
    const float F = sph_grad_factor(SPH_KERNEL, sqrt(r2), H);
    const float kib = -sph_boundary_laminar(&p, mi, rhoi, nui, r2, F, bpos[b].w);
    ksum += kib;
    a -= kib * (vi - bvel[b].xyz);
  }
  const float dg = 1.0f + p.dt * ksum;
  diag[i] = dg;
  const float3 ri = mi * p.dt * a, zi = ri / (mi * dg);
  x[i] = (float4)(vi, 0.0f);
  r[i] = (float4)(ri, 0.0f);
  z[i] = (float4)(zi, 0.0f);
  d[i] = (float4)(zi, 0.0f);
  rz[i] = dot(ri, zi);
}

/* q = M A d, and d . q per particle (one gather over the fluid neighbours: the boundary's part of A is in diag). */
__kernel void viscosity_cg_apply(const SimParams p, __global const float4* pos, __global const uint* phase,
                                 __global const float* density, __global const uint* nbr,
                                 __global const uint* nbr_count, __global const float* diag,
                                 __global const float4* d, __global float4* q, __global float* dq) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const float3 xi = pos[i].xyz;
  const uint phi = phase[i];
  const float mi = p.phase_mass[phi], rhoi = density[i], mui = rhoi * p.phase_viscosity[phi];
  float3 s = (float3)(0.0f);
  const SphList l = sph_list(&p, nbr, i);
  for (uint k = 0; k < nbr_count[i]; ++k) {
    const uint j = sph_list1(l, k);
    s += viscosity_cg_k(&p, xi, mui, rhoi, j, pos, phase, density) * d[j].xyz;
  }
  const float3 di = d[i].xyz;
  const float3 qi = mi * (diag[i] * di - p.dt * s);
  q[i] = (float4)(qi, 0.0f);
  dq[i] = dot(di, qi);
}

/* x += alpha d, r -= alpha q, z = r / (M diag), and r . z per particle. */
__kernel void viscosity_cg_update(const SimParams p, const float alpha, __global const uint* phase,
                                  __global const float* diag, __global const float4* d, __global const float4* q,
                                  __global float4* x, __global float4* r, __global float4* z, __global float* rz) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  x[i] = (float4)(x[i].xyz + alpha * d[i].xyz, 0.0f);
  const float3 ri = r[i].xyz - alpha * q[i].xyz;
  const float3 zi = ri / (p.phase_mass[phase[i]] * diag[i]);
  r[i] = (float4)(ri, 0.0f);
  z[i] = (float4)(zi, 0.0f);
  rz[i] = dot(ri, zi);
}

/* d = z + beta d. */
__kernel void viscosity_cg_direction(const SimParams p, const float beta, __global const float4* z, __global float4* d) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  d[i] = (float4)(z[i].xyz + beta * d[i].xyz, 0.0f);
}

/* The incremental splitting's start (core/dfsph.cpp, viscositySolve): each particle's position and
 * p / delta^2 of the given pressure packed as dfsph_apply_pressure reads its neighbours (kernels/dfsph.cl,
 * dfsph_force; the solves' own passes pack their current pressure the same way). */
__kernel void viscosity_cg_pack(const SimParams p, __global const float4* pos, __global const uint* phase,
                                __global const float* density, __global const float* pressure, __global float4* xt) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const float delta = density[i] / p.phase_mass[phase[i]];
  xt[i] = (float4)(pos[i].xyz, pressure[i] / (delta * delta));
}

/* The incremental splitting's start (core/dfsph.cpp, viscositySolve): v += dt a, a the accelerations of
 * the step so far (gravity), after the last density pressure was applied. */
__kernel void viscosity_cg_predict(const SimParams p, __global const float4* acc, __global float4* vel) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  vel[i] = (float4)(vel[i].xyz + p.dt * acc[i].xyz, vel[i].w);
}

/* The solve's velocities as an acceleration: a += (v' - v) / dt. */
__kernel void viscosity_cg_finish(const SimParams p, __global const float4* vel, __global const float4* x,
                                  __global float4* acc) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  acc[i] = (float4)(acc[i].xyz + (x[i].xyz - vel[i].xyz) / p.dt, acc[i].w);
}
