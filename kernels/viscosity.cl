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
