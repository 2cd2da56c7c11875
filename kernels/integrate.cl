/* Time integration (stage: always). Semi-implicit (symplectic) Euler, as in the paper:
 *     v <- v + dt a,   x <- x + dt v
 * A particle that crosses a closed wall despite the boundary particles is put back just inside and
 * counted (an integer atomic: the count is deterministic), so a leaking boundary is never silent.
 * The step's largest speed goes to the host (integer atomic max of the float's bits: exact). */
__kernel void integrate(const SimParams p, __global float4* pos, __global float4* vel,
                        __global const float4* acc, volatile __global uint* crossings,
                        volatile __global uint* max_speed_bits) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  float3 v = vel[i].xyz + p.dt * acc[i].xyz;
  float3 x = pos[i].xyz + p.dt * v;
  bool crossed = false;
  const float eps = 1e-4f * p.cell_size;
  for (int a = 0; a < 3; ++a) {
    const float lo = p.domain_min[a], hi = p.domain_max[a];
    float xa = a == 0 ? x.x : (a == 1 ? x.y : x.z);
    float va = a == 0 ? v.x : (a == 1 ? v.y : v.z);
    if ((p.closed_mask >> (2 * a)) & 1u && xa < lo) { xa = lo + eps; va = fmax(va, 0.0f); crossed = true; }
    if ((p.closed_mask >> (2 * a + 1)) & 1u && xa > hi) { xa = hi - eps; va = fmin(va, 0.0f); crossed = true; }
    if (a == 0) { x.x = xa; v.x = va; } else if (a == 1) { x.y = xa; v.y = va; } else { x.z = xa; v.z = va; }
  }
  vel[i] = (float4)(v, 0.0f);
  pos[i] = (float4)(x, 0.0f);
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
