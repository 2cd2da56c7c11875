/* Pressure force and gravity (stage: pressure). Writes the acceleration; later force stages add.
 *
 * Symmetric multi-fluid pressure force, Solenthaler & Pajarola 2008 eq. 6:
 *     a_i = -(1/m_i) sum_j (p_i / delta_i^2 + p_j / delta_j^2) grad W_ij
 * with delta = rho / m the number density. Boundary particles b (Akinci et al. 2012 volumes V_b)
 * enter the same symmetric sum with a wall pressure p_b extrapolated from the fluid around them
 * (Adami, Hu & Adams 2012, eq. 27; boundary_pressure below) and the particle's number density:
 *     a_i += -(1/m_i) sum_b (V_b / V0) (p_i + p_b) / delta_i^2 grad W_ib
 * so a wall holds a column of water at the spacing the fluid has inside it. (Session 2 used
 * Akinci's single term p_i / delta_i^2, i.e. p_b = 0: the first layer then sat 0.34 dx above the
 * floor at +60 % pressure. Mirroring p_b = p_i per pair, with or without a hydrostatic correction,
 * set the layer right but let the near-wall fluid churn at up to 0.6 m/s in the hydrostatic tank:
 * the wall then answers each particle's own pressure noise at twice its weight. Adami's p_b is a
 * kernel average over the fluid, so it is smooth.)
 * Bodies take part like walls. Their single sampled layer has Akinci volumes scaled so that a
 * flat face weighs what the domain wall's complete lattice weighs for fluid at rest next to it
 * (model.cpp, bodyVolumeScale): unscaled, a Poisson-sampled face weighed 1.41x the wall, in the
 * density and in the pressure gradient alike, and a half-density block floated dx/3 high.
 * Viscosity acts between fluid and boundary too (Akinci et al. 2012 eq. 11, with the fluid's own
 * model and coefficient; boundary mass m_b = rho0 V_b, so m_b = m_i V_b / V0), with the boundary
 * particle's velocity: zero on walls, the body's rigid motion on bodies. This damps motion at walls
 * and is the viscous (friction) coupling of rigid bodies; with the laminar model walls are no-slip.
 * Boundary contact: a fluid particle at rest sits one spacing dx from the nearest boundary
 * particle, where pressure alone holds it. A splash particle with too few neighbours has p = 0
 * (negative pressures are clamped) and would reach the wall unopposed, so a short-range linear
 * repulsion acts inside r0 = dx (in the spirit of Monaghan & Kajtar 2009's boundary forces):
 *     a_i += sum_b (V_b / V0) k_c c0^2 / dx (1 - r/r0) x_ib / r,   k_c = 5
 * (shared/pair_loops.h, sph_boundary_contact; r0 = dx/2 at a moving body's particles, issue 15:
 * with dx it was most of a moving body's drag). At walls r0 = dx covers the gaps of the boundary
 * lattice (a point on the wall plane is at most 0.87 dx from a boundary particle); the force is
 * zero at the rest spacing; the barrier it builds before
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
                         __global const float4* bvel, __global const float* bpressure,
                         __global const uint* bnbr, __global const uint* bnbr_count, const int viscous) {
  const uint K = p->max_neighbours;
  const SphPairSums s =
      sph_pair_sums(p, i, pos, vel, phase, density, pterm, nbr, nbr_count[i], 1, viscous);

  const float3 xi = pos[i].xyz;
  const float H = p->support;
  const float pi_term = pterm[i]; /* p_i / delta_i^2, from the density pass */
  const float mi = p->phase_mass[phase[i]];
  const float rhoi = density[i];
  const float inv_delta2 = (mi / rhoi) * (mi / rhoi); /* 1 / delta_i^2 */
  const float3 vi = vel[i].xyz;
  float3 f = s.f;                  /* pressure force (unit: N) */
  float3 contact = (float3)(0.0f); /* boundary contact acceleration (unit: m/s^2) */
  float3 av = (float3)(0.0f);      /* boundary viscosity acceleration (unit: m/s^2) */
  const uint nb = bnbr_count[i];
  for (uint k = 0; k < nb; ++k) {
    const uint b = bnbr[(size_t)i * K + k];
    const float4 bb = bpos[b];
    const float3 d = xi - bb.xyz;
    const float r2 = dot(d, d);
    const float r = sqrt(r2);
    const float F = sph_grad_factor(SPH_KERNEL, r, H);
    f -= bb.w * (pi_term + bpressure[b] * inv_delta2) * F * d;
    contact += sph_boundary_contact(p, d, r, bb.w, bvel[b].w > 0.5f); /* r0 = dx/2 at bodies (pair_loops.h) */
    if (viscous) av += sph_boundary_viscosity(p, mi, rhoi, p->phase_viscosity[phase[i]], vi - bvel[b].xyz, d, r2, F, bb.w, bvel[b]);
  }

  const float3 g = (float3)(p->gravity[0], p->gravity[1], p->gravity[2]);
  return (float4)(f / mi + contact + g, 0.0f) + (float4)(s.av + av, 0.0f);
}

/* (bvel: only its w, the body flag, is read here: the contact range.) */
__kernel void pressure_force(const SimParams p, __global const float4* pos, __global const uint* phase,
                             __global const float* density, __global const float* pterm,
                             __global const uint* nbr, __global const uint* nbr_count,
                             __global const float4* bpos, __global const float4* bvel, __global const float* bpressure,
                             __global const uint* bnbr, __global const uint* bnbr_count, __global float4* acc) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  acc[i] = sph_forces(&p, i, pos, pos, phase, density, pterm, nbr, nbr_count, bpos, bvel, bpressure, bnbr,
                      bnbr_count, 0);
}

/* Pressure and viscosity in one pass (stages pressure and viscosity both on). */
__kernel void pressure_viscosity_force(const SimParams p, __global const float4* pos, __global const float4* vel,
                                       __global const uint* phase, __global const float* density,
                                       __global const float* pterm, __global const uint* nbr,
                                       __global const uint* nbr_count, __global const float4* bpos,
                                       __global const float4* bvel, __global const float* bpressure,
                                       __global const uint* bnbr, __global const uint* bnbr_count,
                                       __global float4* acc) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  acc[i] = sph_forces(&p, i, pos, vel, phase, density, pterm, nbr, nbr_count, bpos, bvel, bpressure, bnbr,
                      bnbr_count, 1);
}

/* Wall pressure of boundary particle b (Adami, Hu & Adams 2012, eq. 27; shared/wall_pressure.h):
 * the kernel-weighted mean of the surrounding fluid's pressure, extrapolated to the wall along the
 * hydrostatic gradient, clamped at 0 when the fluid's pressure is (fluid.clamp_negative_pressure:
 * a wall kept at p >= 0 under a fluid allowed to pull lost half the suction behind a towed ball,
 * issue 15). The wall's own acceleration, Adami's a_w, is left out: it is zero on walls and small
 * against g for bodies that float or are moved slowly. Only boundary particles that some fluid
 * particle saw within H this step (marked by the density pass with `stamp`) are computed: the
 * others are never read. The fluid comes from the grid of the last list rebuild (cells H + skin
 * wide, no particle moved more than skin / 2 since), in cell order: deterministic. */
__kernel void boundary_pressure(const SimParams p, const uint n_boundary, const uint stamp,
                                __global const float4* bpos, __global const uint* bmark,
                                __global const float4* pos, __global const float* density,
                                __global const float* pressure, __global const uint* cell_start,
                                __global float* bpressure) {
  const uint b = get_global_id(0);
  if (b >= n_boundary) return;
  if (bmark[b] != stamp) {
    bpressure[b] = 0.0f;
    return;
  }
  float sw, spw;
  float3 srw;
  sph_wall_sums_from_cells(&p, cell_start, bpos[b].xyz, pos, density, pressure, &sw, &spw, &srw);
  bpressure[b] = sph_wall_pressure(&p, sw, spw, srw);
}

/* Gravity alone, used when the pressure stage is disabled. */
__kernel void gravity_only(const SimParams p, __global float4* acc) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  acc[i] = (float4)(p.gravity[0], p.gravity[1], p.gravity[2], 0.0f);
}
