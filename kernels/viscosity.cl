/* Viscosity (stage: viscosity). Adds to the acceleration written by the pressure stage.
 *
 * artificial (Monaghan 1992, eq. 4.2 of Monaghan 2005):
 *     a_i += -sum_j m_j Pi_ij grad W_ij,  Pi_ij = -alpha c0 h mu_ij / rho_ij  (approaching pairs only),
 *     mu_ij = (v_ij . x_ij) / (|x_ij|^2 + 0.01 h^2),  rho_ij = (rho_i + rho_j) / 2
 * laminar (Morris, Fox & Zhu 1997, eq. 8):
 *     a_i += sum_j m_j (mu_i + mu_j) / (rho_i rho_j) (x_ij . grad W_ij) / (|x_ij|^2 + 0.01 h^2) v_ij,
 *     mu = rho nu (dynamic viscosity from the phase's kinematic viscosity nu)
 * Boundaries are free-slip for viscosity (walls exert pressure only). */
__kernel void viscosity_force(const SimParams p, __global const float4* pos, __global const float4* vel,
                              __global const uint* phase, __global const float* density,
                              __global const uint* nbr, __global const uint* nbr_count, __global float4* acc) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const float3 xi = pos[i].xyz;
  const float3 vi = vel[i].xyz;
  const float H = p.support;
  const float H2 = H * H;
  const float eta2 = 0.01f * p.h * p.h;
  const float rhoi = density[i];
  const float mui = rhoi * p.phase_viscosity[phase[i]];

  float3 a = (float3)(0.0f);
  const uint nn = nbr_count[i];
  for (uint k = 0; k < nn; ++k) {
    const uint j = nbr[(size_t)i * p.max_neighbours + k];
    const float3 d = xi - pos[j].xyz;
    const float r2 = dot(d, d);
    if (r2 < H2) {
      const float3 vij = vi - vel[j].xyz;
      const float mj = p.phase_mass[phase[j]];
      const float rhoj = density[j];
      const float F = sph_grad_factor(SPH_KERNEL, sqrt(r2), H);
#if SPH_LAMINAR
      const float muj = rhoj * p.phase_viscosity[phase[j]];
      a += mj * (mui + muj) / (rhoi * rhoj) * (F * r2) / (r2 + eta2) * vij;
#else
      const float vx = dot(vij, d);
      if (vx < 0.0f) {
        const float mu = p.h * vx / (r2 + eta2);
        const float Pi = -p.alpha * p.c0 * mu / (0.5f * (rhoi + rhoj));
        a -= mj * Pi * F * d;
      }
#endif
    }
  }
  (void)mui;
  acc[i] += (float4)(a, 0.0f);
}
