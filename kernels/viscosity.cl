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

/* ---- Cloth and soft-body nodes as unknowns of the implicit viscosity (issue 14, session 38) ------
 * A node k (a boundary particle at slot s, volume ratio psi_k) takes the viscous reaction of its fluid
 * neighbours, F_k = sum_i m_i k_ik (x_i - y_k) (k_ik as k_ib above, with the node's psi; rigid.cl's
 * rigid_fluid_forces gathers the same sum from the solved velocities). Held at its step-start velocity
 * w_k while the fluid is solved, a node lighter than the fluid it drags overshoots at long steps
 * (docs/dfsph.md, session 37). As an unknown it moves in the solve as its own step will move it under
 * that force, backward Euler for both sides:
 *     M_k (y_k - w_k) = dt sum_i m_i k_ik (x_i - y_k),
 * M_k the node's own mass, with its added mass where it has one (the w of cloth_node_response's first
 * row; its springs are not in it: with their other ends held they made a taut sheet's nodes ~10^4 x
 * heavier and a hammock blew up, docs/dfsph.md, session 38), divided by g where the fluid sees the node's
 * mirrored velocity (viscosity_cg_body_* below). Its rows join the fluid's M A:
 *     node row:   (M_k + dt K_k) y_k - dt sum_i m_i k_ik x_i = M_k w_k,    K_k = sum_i m_i k_ik,
 *     fluid row:  ... - dt sum_k m_i k_ik y_k (the boundary's k_ik stays in diag_i),
 * the same coupling -dt m_i k_ik both ways, so the system stays symmetric and positive definite and
 * conjugate gradients still apply. The node rows are preconditioned with the inverse of their 3 x 3
 * diagonal block. Anchored nodes (1/m = 0) stay held: no row, their velocity in the fluid's right-hand
 * side as before. Each node gathers its fluid within H over the cell grid (as rigid_fluid_forces);
 * each fluid particle its nodes from its boundary list: the same pairs, the same k from the same
 * float distances, so the two couplings are equal to rounding. */

/* The free nodes' slots marked in vflag (cleared to 0 by the host): the slots whose velocity is an unknown */
__kernel void viscosity_cg_node_slots(const uint n, const uint offset, __global const float4* nodes,
                                      __global const uint* slot, __global uint* vflag) {
  const uint k = get_global_id(0);
  if (k >= n || nodes[k].w == 0.0f) return;
  vflag[slot[offset + k]] = 1u;
}

/* The inverse of a symmetric 3 x 3 matrix given by its rows (the first three components), by its adjugate. */
inline void viscosity_sym3_inverse(const float3 r0, const float3 r1, const float3 r2, float3* i0, float3* i1,
                                   float3* i2) {
  const float a00 = r0.x, a01 = r0.y, a02 = r0.z, a11 = r1.y, a12 = r1.z, a22 = r2.z;
  const float c00 = a11 * a22 - a12 * a12, c01 = a02 * a12 - a01 * a22, c02 = a01 * a12 - a02 * a11;
  const float c11 = a00 * a22 - a02 * a02, c12 = a01 * a02 - a00 * a12, c22 = a00 * a11 - a01 * a01;
  const float inv = 1.0f / (a00 * c00 + a01 * c01 + a02 * c02);
  *i0 = (float3)(c00, c01, c02) * inv;
  *i1 = (float3)(c01, c11, c12) * inv;
  *i2 = (float3)(c02, c12, c22) * inv;
}

/* k_ik of fluid particle i and the node at xb (volume ratio psi), times m_i; 0 beyond H. */
inline float viscosity_cg_node_k(const SimParams* p, const float3 xb, const float psi, const uint i,
                                 __global const float4* pos, __global const uint* phase,
                                 __global const float* density) {
  const float3 d = pos[i].xyz - xb;
  const float r2 = dot(d, d);
  if (!(r2 < p->support * p->support)) return 0.0f;
  const uint phi = phase[i];
  const float mi = p->phase_mass[phi];
  return -mi * sph_boundary_laminar(p, mi, density[i], p->phase_viscosity[phi], r2,
                                    sph_grad_factor(SPH_KERNEL, sqrt(r2), p->support), psi);
}

/* The node rows' start, after viscosity_cg_setup (which set x = the fluid's w): y = w_k (the node's
 * velocity as the fluid sees it, bvisc), r = dt F_k(x, w), the block A_k = M_k + dt K_k I (3 float4)
 * and its inverse P_k, z = P_k r, d = z, r . z. A free node with no fluid within H has r = 0. Anchored:
 * zeros (no row). */
__kernel void viscosity_cg_node_setup(const SimParams p, const uint n, const uint offset, const float inv_g,
                                      __global const float4* nodes, __global const float4* response,
                                      __global const uint* slot, __global const float4* bpos,
                                      __global const float4* bvisc, __global const float4* pos,
                                      __global const float4* vel, __global const uint* phase,
                                      __global const float* density, __global const uint* cell_start,
                                      __global float4* A, __global float4* P, __global float4* y,
                                      __global float4* r, __global float4* z, __global float4* d,
                                      __global float* rz) {
  const uint k = get_global_id(0);
  if (k >= n) return;
  const uint s = slot[offset + k];
  const float3 wk = bvisc[s].xyz;
  y[k] = (float4)(wk, 0.0f);
  if (nodes[k].w == 0.0f) {
    A[3 * k] = A[3 * k + 1] = A[3 * k + 2] = P[3 * k] = P[3 * k + 1] = P[3 * k + 2] = (float4)(0.0f);
    r[k] = z[k] = d[k] = (float4)(0.0f);
    rz[k] = 0.0f;
    return;
  }
  const float4 xb4 = bpos[s];
  const float3 xb = xb4.xyz;
  float K = 0.0f;
  float3 f = (float3)(0.0f);
  SPH_FOR_NEIGHBOURS(&p, cell_start, xb, i) {
    const float mk = viscosity_cg_node_k(&p, xb, xb4.w, i, pos, phase, density);
    K += mk;
    f += mk * (vel[i].xyz - wk);
  }
  SPH_END_NEIGHBOURS
  /* M_k = m_k I (m + M with a fictitious added mass: the w of cloth_node_response's first row) */
  const float inv_m = response[3 * k].w > 0.0f ? response[3 * k].w : nodes[k].w;
  const float mg = inv_g / inv_m; /* m / g (the node's unknown is g y - (g - 1) v~ where it is mirrored) */
  const float3 m0 = (float3)(mg, 0.0f, 0.0f), m1 = (float3)(0.0f, mg, 0.0f), m2 = (float3)(0.0f, 0.0f, mg);
  const float dK = p.dt * K;
  const float3 a0 = m0 + (float3)(dK, 0.0f, 0.0f), a1 = m1 + (float3)(0.0f, dK, 0.0f), a2 = m2 + (float3)(0.0f, 0.0f, dK);
  float3 p0, p1, p2;
  viscosity_sym3_inverse(a0, a1, a2, &p0, &p1, &p2);
  A[3 * k] = (float4)(a0, 0.0f);
  A[3 * k + 1] = (float4)(a1, 0.0f);
  A[3 * k + 2] = (float4)(a2, 0.0f);
  P[3 * k] = (float4)(p0, 0.0f);
  P[3 * k + 1] = (float4)(p1, 0.0f);
  P[3 * k + 2] = (float4)(p2, 0.0f);
  const float3 rk = p.dt * f;
  const float3 zk = (float3)(dot(p0, rk), dot(p1, rk), dot(p2, rk));
  r[k] = (float4)(rk, 0.0f);
  z[k] = (float4)(zk, 0.0f);
  d[k] = (float4)(zk, 0.0f);
  rz[k] = dot(rk, zk);
}

/* The fluid rows' coupling to the nodes and bodies, after viscosity_cg_apply: q_i -= dt sum_b m_i k_ib
 * u_b over the boundary particles in i's list whose velocity is an unknown (vflag), u_b their direction
 * in bdir (a node's d_k, a body particle's G_b d_U), and d . q again. */
__kernel void viscosity_cg_apply_nodes(const SimParams p, __global const float4* pos, __global const uint* phase,
                                       __global const float* density, __global const float4* bpos,
                                       __global const uint* bnbr, __global const uint* bnbr_count,
                                       __global const uint* vflag, __global const float4* bdir,
                                       __global const float4* d, __global float4* q, __global float* dq) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const uint K = p.max_neighbours;
  float3 s = (float3)(0.0f);
  int any = 0;
  for (uint c = 0; c < bnbr_count[i]; ++c) {
    const uint b = bnbr[(size_t)i * K + c];
    if (!vflag[b]) continue;
    const float4 xb = bpos[b];
    s += viscosity_cg_node_k(&p, xb.xyz, xb.w, i, pos, phase, density) * bdir[b].xyz;
    any = 1;
  }
  if (!any) return;
  const float3 qi = q[i].xyz - p.dt * s;
  q[i] = (float4)(qi, 0.0f);
  dq[i] = dot(d[i].xyz, qi);
}

/* The node rows of q = M A d: q_k = A_k d_k - dt sum_i m_i k_ik d_i, and d . q. */
__kernel void viscosity_cg_node_apply(const SimParams p, const uint n, const uint offset,
                                      __global const float4* nodes, __global const uint* slot,
                                      __global const float4* bpos, __global const float4* pos,
                                      __global const uint* phase, __global const float* density,
                                      __global const uint* cell_start, __global const float4* A,
                                      __global const float4* fd, __global const float4* d,
                                      __global float4* q, __global float* dq) {
  const uint k = get_global_id(0);
  if (k >= n) return;
  if (nodes[k].w == 0.0f) {
    q[k] = (float4)(0.0f);
    dq[k] = 0.0f;
    return;
  }
  const float4 xb4 = bpos[slot[offset + k]];
  float3 s = (float3)(0.0f);
  SPH_FOR_NEIGHBOURS(&p, cell_start, xb4.xyz, i) {
    s += viscosity_cg_node_k(&p, xb4.xyz, xb4.w, i, pos, phase, density) * fd[i].xyz;
  }
  SPH_END_NEIGHBOURS
  const float3 dk = d[k].xyz;
  const float3 qk = (float3)(dot(A[3 * k].xyz, dk), dot(A[3 * k + 1].xyz, dk), dot(A[3 * k + 2].xyz, dk)) - p.dt * s;
  q[k] = (float4)(qk, 0.0f);
  dq[k] = dot(dk, qk);
}

/* Node rows: y += alpha d, r -= alpha q, z = P r, r . z. */
__kernel void viscosity_cg_node_update(const uint n, const float alpha, __global const float4* P,
                                       __global const float4* d, __global const float4* q, __global float4* y,
                                       __global float4* r, __global float4* z, __global float* rz) {
  const uint k = get_global_id(0);
  if (k >= n) return;
  y[k] = (float4)(y[k].xyz + alpha * d[k].xyz, 0.0f);
  const float3 rk = r[k].xyz - alpha * q[k].xyz;
  const float3 zk = (float3)(dot(P[3 * k].xyz, rk), dot(P[3 * k + 1].xyz, rk), dot(P[3 * k + 2].xyz, rk));
  r[k] = (float4)(rk, 0.0f);
  z[k] = (float4)(zk, 0.0f);
  rz[k] = dot(rk, zk);
}

/* Node rows: d = z + beta d. */
__kernel void viscosity_cg_node_direction(const uint n, const float beta, __global const float4* z,
                                          __global float4* d) {
  const uint k = get_global_id(0);
  if (k >= n) return;
  d[k] = (float4)(z[k].xyz + beta * d[k].xyz, 0.0f);
}

/* After the solve: the boundary velocities the reaction is gathered with (bout, a copy of bvisc) take
 * the free nodes' solved velocities y_k, and dv_k = (y_k - w_k) / g is what the viscous force does to the
 * node in the step (the density solve sees the node move by it: dfsph_node_dry). */
__kernel void viscosity_cg_node_finish(const uint n, const uint offset, const float inv_g, __global const float4* nodes,
                                       __global const uint* slot, __global const float4* bvisc,
                                       __global const float4* y, __global float4* bout, __global float4* dv) {
  const uint k = get_global_id(0);
  if (k >= n) return;
  const uint s = slot[offset + k];
  if (nodes[k].w == 0.0f) {
    dv[k] = (float4)(0.0f);
    return;
  }
  bout[s] = (float4)(y[k].xyz, bvisc[s].w);
  dv[k] = (float4)(inv_g * (y[k].xyz - bvisc[s].xyz), 0.0f);
}

/* ---- Rigid bodies as unknowns of the implicit viscosity (issue 14, session 38) ---------------------
 * A free body B (body_data's free flag; held and kinematic bodies stay held) moves rigidly: its particle b
 * at r_b = x_b - c_B has the velocity G_b Y = V + Omega x r_b. Held at its step-start velocity during the
 * solve and given the reaction afterwards, a body lighter than about twice the liquid it drags overshoots
 * at long steps (a 2000 kg/m^3 ball released in 0.05 m^2/s syrup at 5 ms steps jumped to +0.38 m/s
 * where it falls at 0.019; 300 kg/m^3 blew up). As an unknown its rows are
 *     (N^-1 / g) (U - U0) = dt sum_b G_b^T sum_i m_i k_ib (x_i - u_b),   u_b = G_b U - (g - 1) v~_b,
 * N the body's mobility over the step (body_response.h), g = 2 where the fluid sees the body's no-slip
 * ghost velocity u_b = 2 v_b - v~_b (v~_b the Shepard fluid velocity at b, held) and U = 2 Y, g = 1 where
 * it sees v_b itself: in both cases the coupling is -dt m_i k_ib G_b in the fluid's row and its transpose in
 * the body's, and the system stays symmetric (cloth nodes take the same g). The host keeps the six
 * unknowns per body (core/dfsph.cpp, viscositySolve); the device gathers, per body particle, the sums the
 * body's rows need, and writes the bodies' directions into the boundary slots for the fluid's rows. */

/* Per moving particle k (slot s): f_k = sum_i m_i k_ik (v_i - u_s) and K_k = sum_i m_i k_ik over the fluid
 * within H (v: fluid vectors, u: per-slot vectors), and r_k = x_k - c_B; zeros for a body not free. */
__kernel void viscosity_cg_body_gather(const SimParams p, const uint n_moving, const uint n_static,
                                       __global const uint* slot, __global const uint* body_of,
                                       __global const float4* body_data, __global const float4* bpos,
                                       __global const float4* pos, __global const uint* phase,
                                       __global const float* density, __global const uint* cell_start,
                                       __global const float4* v, __global const float4* u, __global float4* fk,
                                       __global float4* rk) {
  const uint k = get_global_id(0);
  if (k >= n_moving) return;
  const uint B = body_of[k];
  const float4 c = body_data[(size_t)B * DFSPH_BODY_STRIDE];
  const uint s = slot[n_static + k];
  const float4 xb4 = bpos[s];
  rk[k] = (float4)(xb4.xyz - c.xyz, 0.0f);
  if (!(c.w > 0.5f)) {
    fk[k] = (float4)(0.0f);
    return;
  }
  const float3 us = u[s].xyz;
  float K = 0.0f;
  float3 f = (float3)(0.0f);
  SPH_FOR_NEIGHBOURS(&p, cell_start, xb4.xyz, i) {
    const float mk = viscosity_cg_node_k(&p, xb4.xyz, xb4.w, i, pos, phase, density);
    K += mk;
    f += mk * (v[i].xyz - us);
  }
  SPH_END_NEIGHBOURS
  fk[k] = (float4)(f, K);
}

/* Per moving particle k of a free body: out[s] = base[s] (or 0 without base) + dV + dOmega x r_k, from
 * the body's pair (dV, dOmega) in dir[2B], dir[2B + 1]; a body not free: out[s] = base[s] (or 0). The w
 * component is base's (or 0). Also marks the slot in vflag (1 for a free body's particle). */
__kernel void viscosity_cg_body_dir(const uint n_moving, const uint n_static, __global const uint* slot,
                                    __global const uint* body_of, __global const float4* body_data,
                                    __global const float4* bpos, __global const float4* dir, const int with_base,
                                    __global const float4* base, __global float4* out, __global uint* vflag) {
  const uint k = get_global_id(0);
  if (k >= n_moving) return;
  const uint B = body_of[k];
  const float4 c = body_data[(size_t)B * DFSPH_BODY_STRIDE];
  const uint s = slot[n_static + k];
  const float4 b0 = with_base ? base[s] : (float4)(0.0f);
  if (!(c.w > 0.5f)) {
    out[s] = b0;
    return;
  }
  const float3 r = bpos[s].xyz - c.xyz;
  out[s] = (float4)(b0.xyz + dir[2 * B].xyz + cross(dir[2 * B + 1].xyz, r), b0.w);
  vflag[s] = 1u;
}

/* Before the density solve: each free body's particle's acceleration gains the viscous change of its
 * velocity, (dV + dOmega x r) / (g dt), from the solve's dU (dir, per body pair). */
__kernel void viscosity_cg_body_accel(const uint n_moving, const uint n_static, const float inv_g_dt,
                                      __global const uint* slot, __global const uint* body_of,
                                      __global const float4* body_data, __global const float4* bpos,
                                      __global const float4* dir, __global float4* bacc) {
  const uint k = get_global_id(0);
  if (k >= n_moving) return;
  const uint B = body_of[k];
  const float4 c = body_data[(size_t)B * DFSPH_BODY_STRIDE];
  if (!(c.w > 0.5f)) return;
  const uint s = slot[n_static + k];
  const float3 r = bpos[s].xyz - c.xyz;
  bacc[s] = (float4)(bacc[s].xyz + inv_g_dt * (dir[2 * B].xyz + cross(dir[2 * B + 1].xyz, r)), bacc[s].w);
}

/* Node directions into their slots (for viscosity_cg_apply_nodes): out[s] = d_k, vflag[s] = 1. */
__kernel void viscosity_cg_node_dir(const uint n, const uint offset, __global const float4* nodes,
                                    __global const uint* slot, __global const float4* d, __global float4* out) {
  const uint k = get_global_id(0);
  if (k >= n || nodes[k].w == 0.0f) return;
  out[slot[offset + k]] = d[k];
}
