/* Viscosity (stage: viscosity) on its own: adds to the acceleration written by the pressure stage.
 * Used when the pressure stage is disabled; with both on, pressure.cl's fused pass computes the
 * same terms in its neighbour loop. The pair term is in shared/viscosity_term.h.
 * Boundaries are free-slip for viscosity (walls exert pressure only). */
__kernel void viscosity_force(const SimParams p, __global const float4* pos, __global const float4* vel,
                              __global const uint* phase, __global const float* density,
                              __global const uint* nbr, __global const uint* nbr_count, __global float4* acc) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const float3 xi = pos[i].xyz;
  const float3 vi = vel[i].xyz;
  const float H = p.support;
  const float rhoi = density[i];
  const float mui = rhoi * p.phase_viscosity[phase[i]];

  float3 a = (float3)(0.0f);
  const uint nn = nbr_count[i];
  for (uint k = 0; k < nn; ++k) {
    const uint j = nbr[(size_t)i * p.max_neighbours + k];
    const float3 d = xi - pos[j].xyz;
    const float r2 = dot(d, d);
    const float F = sph_grad_factor(SPH_KERNEL, sqrt(r2), H); /* zero beyond H */
    a += sph_viscosity_pair(&p, d, r2, F, vi - vel[j].xyz, rhoi, mui, density[j], phase[j]);
  }
  acc[i] += (float4)(a, 0.0f);
}
