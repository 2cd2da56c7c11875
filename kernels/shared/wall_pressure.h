/* Wall pressure of a boundary particle (Adami, Hu & Adams 2012, eq. 27), shared by WCSPH's walls
 * (pressure.cl, boundary_pressure) and DFSPH's extrapolated walls (dfsph.cl,
 * dfsph_wall_list_pressure), which must agree bit for bit (test: "dfsph_wall_list_pressure equals
 * boundary_pressure bitwise"): the kernel-weighted mean of the surrounding fluid's pressure,
 * extrapolated to the wall along the hydrostatic gradient,
 *     p_b = (sum_f p_f W_bf + g . sum_f rho_f (x_b - x_f) W_bf) / sum_f W_bf,
 * clamped at 0 when the fluid's pressure is (fluid.clamp_negative_pressure). OpenCL C only. */
#ifndef SPHAPTICS_WALL_PRESSURE_H
#define SPHAPTICS_WALL_PRESSURE_H
#ifdef __OPENCL_VERSION__

/* The three sums of eq. 27 over the fluid within H of x_b, from the neighbour grid's cells in cell
 * order (deterministic): sum_f W_bf (unit: 1/m^3), sum_f p_f W_bf (unit: Pa/m^3) and
 * sum_f rho_f (x_b - x_f) W_bf (unit: kg/m^5). */
inline void sph_wall_sums_from_cells(const SimParams* p, __global const uint* cell_start, const float3 xb,
                                     __global const float4* pos, __global const float* density,
                                     __global const float* pressure, float* sw_out, float* spw_out,
                                     float3* srw_out) {
  const float H = p->support;
  float sw = 0.0f, spw = 0.0f;
  float3 srw = (float3)(0.0f);
  SPH_FOR_NEIGHBOURS(p, cell_start, xb, f) {
    const float3 d = xb - pos[f].xyz;
    const float r2 = dot(d, d);
    if (r2 < H * H) {
      const float w = sph_w(SPH_KERNEL, sqrt(r2), H);
      sw += w;
      spw += pressure[f] * w;
      srw += (density[f] * w) * d;
    }
  }
  SPH_END_NEIGHBOURS
  *sw_out = sw;
  *spw_out = spw;
  *srw_out = srw;
}

/* p_b from the sums (unit: Pa); 0 where no fluid is within H. */
inline float sph_wall_pressure(const SimParams* p, const float sw, const float spw, const float3 srw) {
  const float3 g = (float3)(p->gravity[0], p->gravity[1], p->gravity[2]);
  const float pb = sw > 0.0f ? (spw + dot(g, srw)) / sw : 0.0f;
  return p->clamp_negative_pressure ? fmax(pb, 0.0f) : pb;
}

#endif
#endif
