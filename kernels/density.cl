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
 * This pass is the only one that scans the grid (27 cells, ~7x more candidates than neighbours):
 * it also records each particle's neighbours (fluid and boundary, self excluded) in fixed-size
 * lists, which the force stages of the same step then read. A list that overflows keeps its
 * first max_neighbours entries (deterministic) and the largest count is reported to the host,
 * which grows the lists. */
__kernel void compute_density(const SimParams p, __global const float4* pos, __global const uint* phase,
                              __global const uint* cell_start, __global const float4* bpos,
                              __global const uint* bcell_start, __global float* density,
                              __global float* pressure, __global uint* nbr, __global uint* nbr_count,
                              __global uint* bnbr, __global uint* bnbr_count, volatile __global uint* overflow) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const float3 xi = pos[i].xyz;
  const float H = p.support;
  const float H2 = H * H;

  const uint K = p.max_neighbours;
  __global uint* my_nbr = nbr + (size_t)i * K;
  __global uint* my_bnbr = bnbr + (size_t)i * K;

  /* number density from fluid neighbours (self included), recording the neighbours */
  float nd = 0.0f;
  uint count = 0;
  SPH_FOR_NEIGHBOURS(&p, cell_start, xi, j) {
    const float3 d = xi - pos[j].xyz;
    const float r2 = dot(d, d);
    if (r2 < H2) {
      nd += sph_w(SPH_KERNEL, sqrt(r2), H);
      if (j != i) {
        if (count < K) my_nbr[count] = j;
        ++count;
      }
    }
  }
  SPH_END_NEIGHBOURS

  /* and from static boundary particles, weighted by their volume */
  uint bcount = 0;
  SPH_FOR_NEIGHBOURS(&p, bcell_start, xi, b) {
    const float4 bb = bpos[b];
    const float3 d = xi - bb.xyz;
    const float r2 = dot(d, d);
    if (r2 < H2) {
      nd += bb.w * sph_w(SPH_KERNEL, sqrt(r2), H);
      if (bcount < K) my_bnbr[bcount] = b;
      ++bcount;
    }
  }
  SPH_END_NEIGHBOURS
  nbr_count[i] = min(count, K);
  bnbr_count[i] = min(bcount, K);
  if (count > K || bcount > K) atomic_max(overflow, max(count, bcount));

  /* mass density and equation of state */
  const uint ph = phase[i];
  const float rho = p.phase_mass[ph] * nd;
  const float rho0 = p.phase_rest_density[ph];
  float pr;
  if (p.eos == SPH_EOS_TAIT) {
    const float ratio = rho / rho0;
    const float r2 = ratio * ratio;
    pr = p.c0 * p.c0 * rho0 / 7.0f * (r2 * r2 * r2 * ratio - 1.0f);
  } else {
    pr = p.c0 * p.c0 * (rho - rho0);
  }
  if (p.clamp_negative_pressure) pr = fmax(pr, 0.0f);
  density[i] = rho;
  pressure[i] = pr;
}
