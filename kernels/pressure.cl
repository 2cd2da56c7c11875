/* Pressure force and gravity (stage: pressure). Writes the acceleration; later force stages add.
 *
 * Symmetric multi-fluid pressure force, Solenthaler & Pajarola 2008 eq. 6:
 *     a_i = -(1/m_i) sum_j (p_i / delta_i^2 + p_j / delta_j^2) grad W_ij
 * with delta = rho / m the number density. Boundary particles take the particle's own pressure
 * (Akinci et al. 2012 eq. 9, written in number densities):
 *     a_i += -(1/m_i) sum_b (V_b / V0) (p_i / delta_i^2) grad W_ib
 * (The fully mirrored term, 2 p_i / delta_i^2, made the wall stiffer than the fluid and drove a
 * slow instability in the hydrostatic tank; Akinci's single term is stable.)
 * Boundary contact: a fluid particle at rest sits one spacing dx from the nearest boundary
 * particle, where pressure alone holds it. A splash particle with too few neighbours has p = 0
 * (negative pressures are clamped) and would reach the wall unopposed, so a short-range linear
 * repulsion acts inside r0 = dx (in the spirit of Monaghan & Kajtar 2009's boundary forces):
 *     a_i += sum_b (V_b / V0) k_c c0^2 / dx (1 - r/r0) x_ib / r,   k_c = 5
 * r0 = dx covers the gaps of the boundary lattice (a point on the wall plane is at most 0.87 dx
 * from a boundary particle); the force is zero at the rest spacing; the barrier it builds before
 * the wall plane stops particles up to ~0.3 c0 (3x the speed c0 is chosen for); its stiffness
 * k_c c0^2 / dx^2 keeps dt^2 k < 1 at the CFL step (symplectic Euler needs < 4).
 * The force between fluid particles i and j is equal and opposite, so momentum is conserved. */
/* Pressure (and, fused, viscosity) of particle i: the fluid pairs (shared/pair_loops.h), then
 * the boundary particles. The sums are kept apart and added in the order of the separate passes
 * (pressure and gravity, then viscosity), so the fused pass gives what pressure_force followed
 * by viscosity_force gives. */
inline float4 sph_forces(const SimParams* p, const uint i, __global const float4* pos, __global const float4* vel,
                         __global const uint* phase, __global const float* density, __global const float* pterm,
                         __global const uint* nbr, __global const uint* nbr_count, __global const float4* bpos,
                         __global const uint* bnbr, __global const uint* bnbr_count, const int viscous) {
  const uint K = p->max_neighbours;
  const SphPairSums s =
      sph_pair_sums(p, i, pos, vel, phase, density, pterm, nbr + (size_t)i * K, nbr_count[i], 1, viscous);

  const float3 xi = pos[i].xyz;
  const float H = p->support;
  const float pi_term = pterm[i]; /* p_i / delta_i^2, from the density pass */
  const float dx = cbrt(p->rest_volume);
  float3 f = s.f;                  /* pressure force (unit: N) */
  float3 contact = (float3)(0.0f); /* boundary contact acceleration (unit: m/s^2) */
  const uint nb = bnbr_count[i];
  for (uint k = 0; k < nb; ++k) {
    const float4 bb = bpos[bnbr[(size_t)i * K + k]];
    const float3 d = xi - bb.xyz;
    const float r = sqrt(dot(d, d));
    f -= bb.w * pi_term * sph_grad_factor(SPH_KERNEL, r, H) * d;
    if (r < dx && r > 1e-6f * dx) contact += bb.w * (5.0f * p->c0 * p->c0 / dx) * (1.0f - r / dx) / r * d;
  }

  const float3 g = (float3)(p->gravity[0], p->gravity[1], p->gravity[2]);
  const float mi = p->phase_mass[phase[i]];
  return (float4)(f / mi + contact + g, 0.0f) + (float4)(s.av, 0.0f);
}

__kernel void pressure_force(const SimParams p, __global const float4* pos, __global const uint* phase,
                             __global const float* pterm,
                             __global const uint* nbr, __global const uint* nbr_count,
                             __global const float4* bpos, __global const uint* bnbr,
                             __global const uint* bnbr_count, __global float4* acc) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  acc[i] = sph_forces(&p, i, pos, pos, phase, pterm, pterm, nbr, nbr_count, bpos, bnbr, bnbr_count, 0);
}

/* Pressure and viscosity in one pass (stages pressure and viscosity both on). */
__kernel void pressure_viscosity_force(const SimParams p, __global const float4* pos, __global const float4* vel,
                                       __global const uint* phase, __global const float* density,
                                       __global const float* pterm, __global const uint* nbr,
                                       __global const uint* nbr_count, __global const float4* bpos,
                                       __global const uint* bnbr, __global const uint* bnbr_count,
                                       __global float4* acc) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  acc[i] = sph_forces(&p, i, pos, vel, phase, density, pterm, nbr, nbr_count, bpos, bnbr, bnbr_count, 1);
}

/* Gravity alone, used when the pressure stage is disabled. */
__kernel void gravity_only(const SimParams p, __global float4* acc) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  acc[i] = (float4)(p.gravity[0], p.gravity[1], p.gravity[2], 0.0f);
}
