/* Viscosity (stage: viscosity) on its own: adds to the acceleration written by the pressure stage.
 * Used when the pressure stage is disabled; with both on, pressure.cl's fused pass computes the
 * same terms in its neighbour loop. The pair terms are in shared/pair_loops.h:
 *   artificial (Monaghan 1992, eq. 4.2 of Monaghan 2005):
 *     a_i += -sum_j m_j Pi_ij grad W_ij,  Pi_ij = -alpha c0 h mu_ij / rho_ij  (approaching pairs only),
 *     mu_ij = (v_ij . x_ij) / (|x_ij|^2 + 0.01 h^2),  rho_ij = (rho_i + rho_j) / 2
 *   laminar (Morris, Fox & Zhu 1997, eq. 8):
 *     a_i += sum_j m_j (mu_i + mu_j) / (rho_i rho_j) (x_ij . grad W_ij) / (|x_ij|^2 + 0.01 h^2) v_ij,
 *     mu = rho nu (dynamic viscosity from the phase's kinematic viscosity nu)
 * Boundaries are free-slip for viscosity (walls exert pressure only). */
__kernel void viscosity_force(const SimParams p, __global const float4* pos, __global const float4* vel,
                              __global const uint* phase, __global const float* density,
                              __global const uint* nbr, __global const uint* nbr_count, __global float4* acc) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const SphPairSums s = sph_pair_sums(&p, i, pos, vel, phase, density, density,
                                      nbr + (size_t)i * p.max_neighbours, nbr_count[i], 0, 1);
  acc[i] += (float4)(s.av, 0.0f);
}
