/* Viscosity (stage: viscosity) on its own: adds to the acceleration written by the pressure stage.
 * Used when the pressure stage is disabled; with both on, pressure.cl's fused pass computes the
 * same terms in its neighbour loop. The pair terms are in shared/pair_loops.h:
 *   artificial (Monaghan 1992, eq. 4.2 of Monaghan 2005):
 *     a_i += -sum_j m_j Pi_ij grad W_ij,  Pi_ij = -alpha c0 h mu_ij / rho_ij  (approaching pairs only),
 *     mu_ij = (v_ij . x_ij) / (|x_ij|^2 + 0.01 h^2),  rho_ij = (rho_i + rho_j) / 2
 *   laminar (Morris, Fox & Zhu 1997, eq. 8):
 *     a_i += sum_j m_j (mu_i + mu_j) / (rho_i rho_j) (x_ij . grad W_ij) / (|x_ij|^2 + 0.01 h^2) v_ij,
 *     mu = rho nu (dynamic viscosity from the phase's kinematic viscosity nu)
 * Boundary particles take part with their velocity (shared/pair_loops.h, sph_boundary_viscosity). */
__kernel void viscosity_force(const SimParams p, __global const float4* pos, __global const float4* vel,
                              __global const uint* phase, __global const float* density,
                              __global const uint* nbr, __global const uint* nbr_count,
                              __global const float4* bpos, __global const float4* bvel,
                              __global const uint* bnbr, __global const uint* bnbr_count, __global float4* acc) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const uint K = p.max_neighbours;
  const SphPairSums s = sph_pair_sums(&p, i, pos, vel, phase, density, density, nbr + (size_t)i * K, nbr_count[i], 0, 1);
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
