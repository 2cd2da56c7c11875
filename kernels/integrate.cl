/* Time integration (stage: always). Semi-implicit (symplectic) Euler, as in the paper:
 *     v <- v + dt a,   x <- x + dt v
 * A particle that crosses a closed wall despite the boundary particles is put back just inside and
 * counted (an integer atomic: the count is deterministic), so a leaking boundary is never silent.
 * The step's largest speed goes to the host (integer atomic max of the float's bits: exact). */
/* One axis of the closed walls' check: xa below the low wall (mask bit lo) is put back just inside and its
 * velocity made non-negative; above the high wall (bit hi) the same, mirrored. Returns the position. */
inline float sph_closed_axis(const uint mask, const int a, const float lo, const float hi, const float eps,
                             float xa, float* va, bool* crossed) {
  if ((mask >> (2 * a)) & 1u && xa < lo) { xa = lo + eps; *va = fmax(*va, 0.0f); *crossed = true; }
  if ((mask >> (2 * a + 1)) & 1u && xa > hi) { xa = hi - eps; *va = fmin(*va, 0.0f); *crossed = true; }
  return xa;
}

__kernel void integrate(const SimParams p, __global float4* pos, __global float4* vel,
                        __global const float4* acc, volatile __global uint* crossings,
                        volatile __global uint* max_speed_bits) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const float3 v0 = vel[i].xyz + p.dt * acc[i].xyz;
  const float3 x0 = pos[i].xyz + p.dt * v0;
  bool crossed = false;
  const float eps = 1e-4f * p.cell_size;
  /* the three axes written out (a loop over them with the struct's arrays indexed by the axis ran ~4x
   * slower on pocl: performance) */
  float vx = v0.x, vy = v0.y, vz = v0.z;
  const float xx = sph_closed_axis(p.closed_mask, 0, p.domain_min[0], p.domain_max[0], eps, x0.x, &vx, &crossed);
  const float xy = sph_closed_axis(p.closed_mask, 1, p.domain_min[1], p.domain_max[1], eps, x0.y, &vy, &crossed);
  const float xz = sph_closed_axis(p.closed_mask, 2, p.domain_min[2], p.domain_max[2], eps, x0.z, &vz, &crossed);
  const float3 v = (float3)(vx, vy, vz);
  vel[i] = (float4)(v, 0.0f);
  pos[i] = (float4)(xx, xy, xz, 0.0f);
  if (crossed) atomic_inc(crossings);
  /* largest speed of the step, for the Verlet-list skin (non-negative floats order as uints) */
  const uint sb = as_uint(length(v));
  if (sb > *max_speed_bits) atomic_max(max_speed_bits, sb); /* read first: few atomics */
}

/* The settle before t = 0 (Simulation::settle): every fluid velocity times `factor` after a step,
 * exp(-dt / settle_damping) while it settles and 0 at its end (the fluid starts at rest). */
__kernel void scale_velocity(const SimParams p, const float factor, __global float4* vel) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  vel[i] = (float4)(factor * vel[i].xyz, 0.0f);
}
