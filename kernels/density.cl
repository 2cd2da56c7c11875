/* Density and pressure (stage: always when there is fluid).
 *
 * Multi-fluid SPH after Solenthaler & Pajarola 2008: the number density
 *     delta_i = sum_j W_ij + sum_b (V_b / V0) W_ib                       (S&P eq. 3, Akinci 2012 eq. 6)
 * counts neighbours of every phase alike, and the mass density is rho_i = m_i delta_i, so a heavy
 * particle next to a light one is not seen as under-dense: interfaces stay sharp.
 * Static boundary particles b contribute with their Akinci et al. 2012 volume V_b (eq. 4),
 * stored in bpos.w as V_b / V0.
 * Equation of state: linear p = c0^2 (rho - rho0) (the paper's p = k (rho - rho0) with k = c0^2),
 * or Tait p = B ((rho / rho0)^7 - 1), B = c0^2 rho0 / 7 (Monaghan 1994).
 *
 * Neighbours come from the lists built by the grid stage (grid.cl, build_neighbour_lists),
 * which hold every particle within the list radius H + skin; only those within H count here,
 * and they are written to this step's lists (snbr, sbnbr) so that the force stages visit the
 * ~33 true neighbours rather than the ~65 Verlet candidates. The loop is in shared/pair_loops.h.
 * With `step_lists` the lists given are this step's lists already (DFSPH's lists built at H when
 * they would not outlive the step: core/simulation.cpp buildGrid), so nbr == snbr and the pass
 * only sums (performance). */
__kernel void compute_density(const SimParams p, __global const float4* pos, __global const uint* phase,
                              __global const float4* bpos, __global const uint* nbr,
                              __global const uint* nbr_count, __global const uint* bnbr,
                              __global const uint* bnbr_count, __global float* density,
                              __global float* pressure, __global float* pterm, __global uint* snbr,
                              __global uint* snbr_count, __global uint* sbnbr, __global uint* sbnbr_count,
                              const uint stamp, __global uint* bmark, const int step_lists) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const float3 xi = pos[i].xyz;
  const float H = p.support;
  const uint K = p.max_neighbours;

  /* number density: self, fluid neighbours, and static boundary particles weighted by volume;
   * the neighbours actually within H go to this step's lists, which the force stages read */
  uint sn = 0, sb = 0;
  float nd = sph_w(SPH_KERNEL, 0.0f, H);
  /* fluid lists narrow or wide (shared/neighbours.h), snbr alike; boundary lists wide */
  __global short* snarrow = (step_lists || p.wide_lists) ? 0 : (__global short*)snbr + (size_t)i * K;
  __global uint* swide = (step_lists || !p.wide_lists) ? 0 : snbr + (size_t)i * K;
  nd += sph_list_density(xi, nbr, i, K, p.wide_lists, nbr_count[i], pos, 0, H, swide, snarrow, &sn);
  nd += sph_list_density(xi, bnbr, i, K, 1, bnbr_count[i], bpos, 1, H, step_lists ? 0 : sbnbr + (size_t)i * K, 0, &sb);
  if (step_lists) { /* the lists given hold only neighbours within H: all of them count */
    sn = nbr_count[i];
    sb = bnbr_count[i];
  } else {
    snbr_count[i] = sn;
    sbnbr_count[i] = sb;
  }
  /* mark the boundary particles seen, for boundary_pressure (pressure.cl); all writers of one
   * entry write the same value */
  for (uint k = 0; k < sb; ++k) bmark[sbnbr[(size_t)i * K + k]] = stamp;

  /* mass density and equation of state (shared/pair_loops.h) */
  density[i] = sph_density_state(&p, phase[i], nd, pressure, pterm, i);
}
