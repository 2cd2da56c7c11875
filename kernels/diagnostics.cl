/* Diagnostics (once per frame). Each work-item scans one contiguous chunk of particles and writes
 * its counts; the host sums the few partial results in a fixed order (deterministic).
 * out[g] = (non-finite count, outside-domain count, CFL-violation count, 0,
 *           max speed as float bits, index of the first bad particle or 0xffffffff, 0, 0) */
__kernel void diagnostics(const SimParams p, const uint chunk, __global const float4* pos,
                          __global const float4* vel, __global const float* density,
                          __global uint8* out) {
  const uint g = get_global_id(0);
  const uint begin = g * chunk;
  const uint end = min(begin + chunk, p.n_fluid);
  uint nonfinite = 0, outside = 0, cfl = 0, first_bad = 0xffffffffu;
  float vmax = 0.0f;
  const float3 lo = (float3)(p.domain_min[0], p.domain_min[1], p.domain_min[2]);
  const float3 hi = (float3)(p.domain_max[0], p.domain_max[1], p.domain_max[2]);
  for (uint i = begin; i < end; ++i) {
    const float3 x = pos[i].xyz, v = vel[i].xyz;
    const float speed = length(v);
    if (!isfinite(x.x) || !isfinite(x.y) || !isfinite(x.z) || !isfinite(speed) || !isfinite(density[i])) {
      ++nonfinite;
      if (first_bad == 0xffffffffu) first_bad = i;
      continue;
    }
    if (any(x < lo) || any(x > hi)) { ++outside; if (first_bad == 0xffffffffu) first_bad = i; }
    if (speed * p.dt > p.h) ++cfl; /* moved more than a smoothing length in one step */
    vmax = fmax(vmax, speed);
  }
  out[g] = (uint8)(nonfinite, outside, cfl, 0u, as_uint(vmax), first_bad, 0u, 0u);
}
