/* DFSPH two-level solve: a coarse-grid correction of the pressures (stages: divergence_solve,
 * density_solve; solver dfsph with fluid.dfsph.coarse_interval > 0; host side core/dfsph.cpp,
 * DfsphSolver::coarseCorrection).
 *
 * Why: the Jacobi iteration of dfsph.cl (r = s - A p, p += omega r alpha / (dt^2 V0)) removes an
 * error of wavelength L only in ~(L / dx)^2 iterations, and the solve stops on the average error
 * eta; a pressure error smooth over a column of depth H changes the density over a step by only
 * dt^2 dp (pi / 2H)^2 / rho0, so up to dp_eta = rho0 eta (2H / pi)^2 / dt^2 passes unseen and the
 * column rings within it (README "DFSPH"). A two-level method (Briggs, Henson & McCormick 2000,
 * "A Multigrid Tutorial", ch. 3 and 5: smoothing plus coarse-grid correction; Vanek, Mandel &
 * Brezina 1996: aggregation) solves the smooth part on aggregates instead:
 *
 *   aggregates: the fluid particles in one cell of size H (the kernel support) of cells aligned
 *   with the domain box, only the particles in the active set of the complementarity problem
 *   (p_i > 0 or r_i > 0; the divergence solve's free-surface particles with too few neighbours
 *   are out; the host drops aggregates of fewer than 4 particles);
 *   prolongation P: piecewise constant, (P e)_i = e_c(i) (unit: Pa);
 *   Galerkin coarse operator K = -P^T A P, from the same pair terms as the Jacobi pass:
 *       K_dc = dt^2 V0 sum_i F_i(c) . R_i(d),
 *       F_i(c) = (1/m_i) [ sum_j ([i in c] / delta_i^2 + [j in c] / delta_j^2) gradW_ij
 *                          + w [i in c] / delta_i^2 G_b,i ]     (minus the acceleration of i from
 *                                                              a unit pressure on aggregate c),
 *       R_i(d) = sum_j ([i in d] + [j in d]) gradW_ij + [i in d] G_b,i
 *       (sum_{k in d} (D a)_k = sum_i a_i . R_i(d) for D a the density change of dfsph_jacobi,
 *       by the antisymmetry of gradW_ij), G_b,i the factor pass's wall sum (gwall); w = 2 with
 *       extrapolated walls: the extrapolated wall pressure of a smooth field is that of the fluid
 *       next to it (p_b = p_i, mirrored), w = 1 with single walls (p_b = 0);
 *   correction: K e = P^T r (r_i of the current pressures), q = P e scaled by the line search
 *   theta = -<q, r> / <q, dr> (dr: the residual change q makes with the walls' own operator,
 *   dfsph_coarse_trial), p_i <- max(p_i + theta q_i, 0) for the active particles (the projection
 *   of dfsph_jacobi).
 * Each particle's F and R are written per aggregate of its 3 x 3 x 3 cell neighbourhood (a
 * neighbour within H lies at most one cell away); the host sums K in particle order and solves
 * it: deterministic. Reads neighbours, writes only particle i. */

/* Aggregate cell of a position: floor((x - domain_min) / H) (cells aligned with the domain box, so
 * that a particle lattice filling the box, dx = H / 2, gives whole aggregates of 2 x 2 x 2). */
inline int4 dfsph_coarse_cell(const SimParams* p, const float3 x) {
  const float H = p->support;
  return (int4)((int)floor((x.x - p->domain_min[0]) / H), (int)floor((x.y - p->domain_min[1]) / H),
                (int)floor((x.z - p->domain_min[2]) / H), 0);
}

/* The residual of the current pressures r_i = s_i + dt^2 V0 (sum_j (a_i - a_j) . gradW_ij + a_i . G_b)
 * (dfsph_jacobi's, for accel = a^p(p) from dfsph_pressure_accel), signed, and whether particle i is
 * in the active set (cell.w = 1): p_i > 0 or r_i > 0, and (divergence solve) enough neighbours. */
__kernel void dfsph_coarse_residual(const SimParams p, __global const float4* pos, __global const float4* accel,
                                    __global const float* source, __global const uint* nbr,
                                    __global const uint* nbr_count, __global const uint* bnbr_count,
                                    const uint min_neighbours, __global const float* pressure,
                                    __global const float4* gwall, const int trial, __global float* res,
                                    __global int4* cell) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const uint K = p.max_neighbours;
  const float H = p.support;
  const float3 xi = pos[i].xyz, ai = accel[i].xyz;
  const uint nf = nbr_count[i];
  __global const uint* list = nbr + (size_t)i * K;
  float Ap = 0.0f;
  for (uint k = 0; k < nf; ++k) {
    const uint j = list[k];
    const float3 d = xi - pos[j].xyz;
    Ap += sph_grad_factor(SPH_KERNEL, length(d), H) * dot(ai - accel[j].xyz, d);
  }
  Ap += dot(ai, gwall[i].xyz);
  const float r = source[i] + p.dt * p.dt * p.rest_volume * Ap;
  /* trial (the line search's): the residual alone, unmasked, no cells */
  if (trial) {
    res[i] = r;
    return;
  }
  const int active = (nf + bnbr_count[i] >= min_neighbours) && (pressure[i] > 0.0f || r > 0.0f);
  res[i] = active ? r : 0.0f;
  int4 c = dfsph_coarse_cell(&p, xi);
  c.w = active;
  cell[i] = c;
}

/* Per particle i and per aggregate of its 3 x 3 x 3 cell neighbourhood (slot (ox+1)*9 + (oy+1)*3 +
 * (oz+1), o the aggregate's cell offset): F_i(c) (unit: m^2/kg) and R_i(d) (unit: 1/m^4) of the top
 * of this file, fr[(i * 27 + slot) * 2] = F, fr[... + 1] = R. Needs dfsph_coarse_residual's cells. */
__kernel void dfsph_coarse_pairs(const SimParams p, __global const float4* pos, __global const uint* phase,
                                 __global const float* density, __global const uint* nbr,
                                 __global const uint* nbr_count, __global const float4* gwall,
                                 __global const int4* cell, const float wall, __global float4* fr) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const uint K = p.max_neighbours;
  const float H = p.support;
  const float3 xi = pos[i].xyz;
  const float mi = p.phase_mass[phase[i]];
  const float di = density[i] / mi;
  const int4 ci = cell[i];
  float3 F[27], R[27];
  for (int s = 0; s < 27; ++s) F[s] = R[s] = (float3)(0.0f);
  /* i's own aggregate (slot 13): the terms with [i in c], when i is active */
  const uint nf = nbr_count[i];
  __global const uint* list = nbr + (size_t)i * K;
  float3 gsum = (float3)(0.0f);
  for (uint k = 0; k < nf; ++k) {
    const uint j = list[k];
    const float3 d = xi - pos[j].xyz;
    const float3 g = sph_grad_factor(SPH_KERNEL, length(d), H) * d;
    gsum += g;
    /* the neighbour's aggregate: the terms with [j in c], when j is active */
    const int4 cj = cell[j];
    if (!cj.w) continue;
    const int ox = cj.x - ci.x, oy = cj.y - ci.y, oz = cj.z - ci.z;
    if (abs(ox) > 1 || abs(oy) > 1 || abs(oz) > 1) continue; /* within H: cannot happen */
    const int s = (ox + 1) * 9 + (oy + 1) * 3 + (oz + 1);
    const float dj = density[j] / p.phase_mass[phase[j]];
    F[s] += g / (dj * dj);
    R[s] += g;
  }
  if (ci.w) {
    const float3 gb = gwall[i].xyz;
    F[13] += (gsum + wall * gb) / (di * di);
    R[13] += gsum + gb;
  }
  __global float4* out = fr + (size_t)i * 54;
  for (int s = 0; s < 27; ++s) {
    out[2 * s] = (float4)(F[s] / mi, 0.0f);
    out[2 * s + 1] = (float4)(R[s], 0.0f);
  }
}

/* The correction: p_i <- max(p_i + dp_i, 0) (dp_i = e_c(i) for the active particles, 0 for the
 * others, written by the host), and the packed p / delta^2 the next pressure-force pass gathers. */
__kernel void dfsph_coarse_apply(const SimParams p, __global const float4* pos, __global const uint* phase,
                                 __global const float* density, __global const float* dp,
                                 __global float* pressure, __global float4* xt) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const float p1 = fmax(pressure[i] + dp[i], 0.0f);
  pressure[i] = p1;
  const float di = density[i] / p.phase_mass[phase[i]];
  xt[i] = (float4)(pos[i].xyz, p1 / (di * di));
}

/* The line search's trial pressures max(p_i + dp_i, 0) into `trial`, and their packed position and
 * p / delta^2 for dfsph_force. */
__kernel void dfsph_coarse_trial(const SimParams p, __global const float4* pos, __global const uint* phase,
                                 __global const float* density, __global const float* dp,
                                 __global const float* pressure, __global float* trial, __global float4* xt) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const float p1 = fmax(pressure[i] + dp[i], 0.0f);
  trial[i] = p1;
  const float di = density[i] / p.phase_mass[phase[i]];
  xt[i] = (float4)(pos[i].xyz, p1 / (di * di));
}
