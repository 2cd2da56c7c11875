/* Probes (stage probes; only when the scene has a `probes` section): the fluid sampled at fixed
 * points, as a pressure gauge or a wave gauge in an experiment would read it. One work-item per
 * sample point gathers the particles within H (fluid and boundary) through the cell tables and
 * writes eight sums, in grid order (deterministic); the host normalises them (core/probes.cpp):
 *
 *   out[0] = S     = sum_j V_j W(x - x_j)          V_j = m_j / rho_j, fluid particles j
 *   out[1]         = sum_j V_j W p_j               -> pressure  = out[1] / S   (Shepard 1968)
 *   out[2]         = sum_j V_j W rho_j             -> density   = out[2] / S
 *   out[3..5]      = sum_j V_j W v_j               -> velocity  = out[3..5] / S
 *   out[6] = F     = sum_j V0 W                    the isosurface's fill field (1 in the bulk)
 *   out[7] = B     = sum_b V_b W                   the walls' and bodies' share of the kernel
 *
 * The Shepard normalisation makes the interpolation exact for a constant field and, on a
 * symmetric neighbourhood, for a linear one; near a wall it uses the fluid side alone. F / (1 - B)
 * is how full of fluid the kernel's non-wall part is: 1 inside the fluid, also against a wall,
 * 1/2 at a free surface. */
__kernel void probe_sample(const SimParams p, const uint num_points, const float reach,
                           __global const float4* points, __global const float4* pos, __global const float4* vel,
                           __global const uint* phase, __global const float* density, __global const float* pressure,
                           __global const uint* cell_start, __global const float4* bpos,
                           __global const uint* bcell_start, __global float* out) {
  const uint n = get_global_id(0);
  if (n >= num_points) return;
  const float3 x = points[n].xyz;
  const float H = p.support, H2 = H * H;
  float S = 0.0f, P = 0.0f, R = 0.0f, F = 0.0f, B = 0.0f;
  float3 V = (float3)(0.0f);
  FOR_PARTICLES_NEAR(&p, cell_start, x, reach, j) {
    const float3 d = x - pos[j].xyz;
    const float r2 = dot(d, d);
    if (r2 < H2) {
      const float w = sph_w(SPH_KERNEL, sqrt(r2), H);
      const float rho = density[j];
      const float vw = p.phase_mass[min(phase[j], (uint)(SPH_MAX_PHASES - 1))] / rho * w;
      S += vw;
      P += vw * pressure[j];
      R += vw * rho;
      V += vw * vel[j].xyz;
      F += p.rest_volume * w;
    }
  }
  END_PARTICLES_NEAR
  FOR_PARTICLES_NEAR(&p, bcell_start, x, reach, b) {
    const float3 d = x - bpos[b].xyz;
    const float r2 = dot(d, d);
    if (r2 < H2) B += bpos[b].w * p.rest_volume * sph_w(SPH_KERNEL, sqrt(r2), H);  /* w = V_b / V0 */
  }
  END_PARTICLES_NEAR
  __global float* o = out + 8 * (size_t)n;
  o[0] = S; o[1] = P; o[2] = R; o[3] = V.x; o[4] = V.y; o[5] = V.z; o[6] = F; o[7] = B;
}
