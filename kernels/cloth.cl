/* Cloth: mass-spring nets whose nodes are particles (stage: cloth; core/cloth.h has the design).
 *
 * Nodes: x (xyz, w = inverse mass, 0 = anchored), v, mass, air drag, anchor (velocity, w = stop
 * time; w < 0: keyframed, track -w - 1), x_rest (placed position). Tracks (keyframed anchors, host
 * evaluated for the end of the step): track[2k] = offset from x_rest, track[2k + 1] = velocity. Springs: the compressed rows row_start / spring / other (each spring in both ends' rows),
 * prm[s] = (rest length L0, stiffness k, dashpot c, tear strain), broken[s].
 * Every kernel gathers: a node reads its row and writes only itself (no atomics, deterministic). */

#define CLOTH_NO_SLOT 0xffffffffu

/* Anchored node: the distance its motion covers in [t, t + dt) (it stops at anchor.w). */
inline float3 cloth_anchor_travel(const float4 a, const float t, const float dt) {
  return a.xyz * clamp(a.w - t, 0.0f, dt);
}
inline float3 cloth_anchor_velocity(const float4 a, const float t) { return t < a.w ? a.xyz : (float3)(0.0f); }

/* Anchored node i at the end of a step of dt from t: constant velocity (travel added to x), or
 * keyframed (anchor.w < 0): placed position + the track's offset, set absolutely so that no
 * rounding accumulates (the path is followed exactly at every step end). */
inline float3 cloth_anchor_x(const uint i, const float3 x, const float t, const float dt, __global const float4* anchor,
                             __global const float4* x_rest, __global const float4* track) {
  const float4 a = anchor[i];
  if (a.w < 0.0f) return x_rest[i].xyz + track[2 * ((uint)(-a.w) - 1)].xyz;
  return x + cloth_anchor_travel(a, t, dt);
}
inline float3 cloth_anchor_v(const uint i, const float t_end, __global const float4* anchor, __global const float4* track) {
  const float4 a = anchor[i];
  if (a.w < 0.0f) return track[2 * ((uint)(-a.w) - 1) + 1].xyz;
  return cloth_anchor_velocity(a, t_end);
}

/* Explicit mass-spring (the paper's): F_i = m_i g + f_ext + sum_j [k (L - L0) + c (v_j - v_i).u] u,
 * u = (x_j - x_i) / L; symplectic Euler (v first, then x with the new v), the drag implicit so it
 * never limits the step: v' = (v + dt F / m) / (1 + dt c), every force (springs included) inside,
 * so a node is at rest (v' = v = 0) exactly where F = 0: the springs carry the full weight. XPBD
 * nodes are copied through. */
__kernel void cloth_explicit_step(const uint n, const float dt, const float t, const float4 g,
                                  __global const float4* x_in, __global const float4* lo_in, __global const float4* v_in,
                                  __global const float* mass, __global const float* drag,
                                  __global const float4* anchor, __global const float4* x_rest,
                                  __global const float4* track, __global const uint* is_xpbd,
                                  __global const uint* row_start, __global const uint* spring,
                                  __global const uint* other, __global const float4* prm,
                                  __global const uint* broken, __global const float4* fext,
                                  __global float4* x_out, __global float4* lo_out, __global float4* v_out) {
  const uint i = get_global_id(0);
  if (i >= n) return;
  const float4 xi4 = x_in[i];
  const float3 xi = xi4.xyz, vi = v_in[i].xyz, loi = lo_in[i].xyz;
  if (is_xpbd[i]) {
    x_out[i] = xi4;
    lo_out[i] = lo_in[i];
    v_out[i] = v_in[i];
    return;
  }
  /* Anchored nodes follow their script. */
  if (xi4.w == 0.0f) {
    x_out[i] = (float4)(cloth_anchor_x(i, xi, t, dt, anchor, x_rest, track), 0.0f);
    lo_out[i] = (float4)(0.0f);
    v_out[i] = (float4)(cloth_anchor_v(i, t + dt, anchor, track), 0.0f);
    return;
  }
  /* Gravity, external (fluid) force, then the springs of row i in table order. */
  float3 f = mass[i] * g.xyz + fext[i].xyz;
  for (uint e = row_start[i]; e < row_start[i + 1]; ++e) {
    const uint s = spring[e];
    if (broken[s]) continue;
    const uint j = other[e];
    const float4 p = prm[s];
    /* x_j - x_i of nearby floats is exact (Sterbenz); the low parts add what rounding left out. */
    const float3 d = (x_in[j].xyz - xi) + (lo_in[j].xyz - loi);
    const float L = length(d);
    if (L <= 0.0f) continue;
    const float3 u = d / L;
    f += (p.y * (L - p.x) + p.z * dot(v_in[j].xyz - vi, u)) * u;
  }
  /* Symplectic Euler. The position is kept as an unevaluated sum hi + lo of two floats (x, lo):
   * hi + (lo + dt v) split again by Knuth's two-sum (exact in round-to-nearest), so the rounding
   * of a float position (6e-8 m at 0.7 m) does not enter the springs: against stretches of 1e-9 m
   * (k = 10^7 N/m) that rounding was noise the stiff springs turned into energy. */
  const float3 v = (vi + dt * xi4.w * f) / (1.0f + dt * drag[i]);
  const float3 b = loi + dt * v;
  const float3 hi = xi + b;
  const float3 bb = hi - xi;
  const float3 lo = (xi - (hi - bb)) + (b - bb);
  x_out[i] = (float4)(hi, xi4.w);
  lo_out[i] = (float4)(lo, 0.0f);
  v_out[i] = (float4)(v, 0.0f);
}

/* XPBD (Macklin, Mueller, Chentanez 2016), Algorithm 1 lines 1-4: predict x*, keep x as prev,
 * clear the multipliers of row i.
 * Air drag, backward Euler on the whole velocity (drag c, constraint force f_c):
 *   m (v' - v) = dt (m g + f_ext + f_c) - dt m c v'  =>  v' = (v + dt (g + f_ext/m) + dt f_c/m) / (1 + dt c)
 * and x' = x + dt v' = x* + dt^2 f_c / (m (1 + dt c)), with x* = x + dt (v + dt (g + f_ext/m)) / (1 + dt c).
 * So the drag divides the external forces in x*, and the constraints act on the effective mass
 * m (1 + dt c): the solve reads x.w = 1 / (m (1 + dt c)) (restored from prev.w = 1/m by
 * cloth_xpbd_velocity). At rest (v' = v = 0) f_c = -m g - f_ext exactly: the springs and anchors
 * carry the full weight. (Dividing only the prediction, with the constraints on m, leaves them
 * m g / (1 + dt c): the bias this replaces.) A free node falls at the exact terminal speed g / c. */
__kernel void cloth_xpbd_predict(const uint n, const float dt, const float t, const float4 g,
                                 __global float4* x, __global const float4* v, __global const float* mass,
                                 __global const float* drag, __global const float4* anchor,
                                 __global const float4* x_rest, __global const float4* track,
                                 __global const uint* is_xpbd, __global const uint* row_start,
                                 __global const float4* fext, __global const float* fict,
                                 __global float4* prev, __global float* lambda) {
  const uint i = get_global_id(0);
  if (i >= n || !is_xpbd[i]) return;
  const float4 x4 = x[i];
  prev[i] = x4;
  for (uint e = row_start[i]; e < row_start[i + 1]; ++e) lambda[e] = 0.0f;
  if (x4.w == 0.0f) {
    x[i] = (float4)(cloth_anchor_x(i, x4.xyz, t, dt, anchor, x_rest, track), 0.0f);
    return;
  }
  const float M = fict[i];
  if (M > 0.0f) {
    /* DFSPH's added mass M of a wet node (Simulation::clothAddedMass): it moves as m + M under its
     * forces, (m + M) (v' - v) / dt = m g + f - m c v', the constraints on m (1 + dt c) + M; the
     * fluid takes the reaction M (v' - v) (cloth_added_mass_impulse) */
    const float m = mass[i];
    const float me = m * (1.0f + dt * drag[i]) + M;
    const float3 vi = ((m + M) * v[i].xyz + dt * (m * g.xyz + fext[i].xyz)) / me;
    x[i] = (float4)(x4.xyz + dt * vi, 1.0f / me);
    return;
  }
  const float damp = 1.0f + dt * drag[i];
  const float3 vi = (v[i].xyz + dt * (g.xyz + x4.w * fext[i].xyz)) / damp;
  x[i] = (float4)(x4.xyz + dt * vi, x4.w / damp);
}

/* XPBD, one colour of one Gauss-Seidel sweep: node i applies the correction of its spring of
 * colour c (if any). Distance constraint C = L - L0, gradient -u at a, +u at b (a < b);
 * eq. 18 with damping (eq. 26): dlambda = (-C - at lambda - gamma dC) / ((1 + gamma)(w_a + w_b) + at)
 * with at = 1 / (k dt^2) (compliance / dt^2), gamma = at bt / dt = c / (k dt), dC = u.((x_b - prev_b) - (x_a - prev_a)).
 * Both ends compute the same dlambda from the same inputs in the same order (a, b), and each keeps
 * its own copy of lambda in its row. Nodes without a spring of this colour are copied through. */
/* One node's update in a colour pass (shared by cloth_xpbd_colour and cloth_xpbd_solve): the
 * position node i takes after its spring of colour c, from x_in. */
inline float4 cloth_xpbd_node(const uint i, const uint n, const float dt, const uint it, const uint c,
                              __global const float4* x_in, __global const float4* prev,
                              __global const uint* is_xpbd, __global const uint* iters,
                              __global const uint* slot, __global const uint* spring,
                              __global const uint* other, __global const float4* prm,
                              __global const uint* broken, __global float* lambda) {
  const float4 x4 = x_in[i];
  const uint e = slot[c * n + i];
  if (!is_xpbd[i] || it >= iters[i] || e == CLOTH_NO_SLOT || broken[spring[e]]) return x4;
  const uint s = spring[e];
  const uint j = other[e];
  const uint a = min(i, j), b = max(i, j);
  const float4 xa = x_in[a], xb = x_in[b];
  const float3 d = xb.xyz - xa.xyz;
  const float L = length(d);
  if (L <= 0.0f) return x4;
  const float3 u = d / L;
  const float4 p = prm[s];
  const float C = L - p.x;
  const float at = 1.0f / (p.y * dt * dt);
  const float gamma = p.z / (p.y * dt);
  const float dC = dot(u, (xb.xyz - prev[b].xyz) - (xa.xyz - prev[a].xyz));
  const float lam = lambda[e];
  const float dlam = (-C - at * lam - gamma * dC) / ((1.0f + gamma) * (xa.w + xb.w) + at);
  lambda[e] = lam + dlam;
  const float side = (i == a) ? -1.0f : 1.0f;
  return (float4)(x4.xyz + side * x4.w * dlam * u, x4.w);
}

/* XPBD, one colour of one Gauss-Seidel sweep: node i applies the correction of its spring of
 * colour c (if any). Distance constraint C = L - L0, gradient -u at a, +u at b (a < b);
 * eq. 18 with damping (eq. 26): dlambda = (-C - at lambda - gamma dC) / ((1 + gamma)(w_a + w_b) + at)
 * with at = 1 / (k dt^2) (compliance / dt^2), gamma = at bt / dt = c / (k dt), dC = u.((x_b - prev_b) - (x_a - prev_a)).
 * Both ends compute the same dlambda from the same inputs in the same order (a, b), and each keeps
 * its own copy of lambda in its row. Nodes without a spring of this colour are copied through. */
__kernel void cloth_xpbd_colour(const uint n, const float dt, const uint it, const uint c,
                                __global const float4* x_in, __global const float4* prev,
                                __global const uint* is_xpbd, __global const uint* iters,
                                __global const uint* slot, __global const uint* spring,
                                __global const uint* other, __global const float4* prm,
                                __global const uint* broken, __global float* lambda, __global float4* x_out) {
  const uint i = get_global_id(0);
  if (i >= n) return;
  x_out[i] = cloth_xpbd_node(i, n, dt, it, c, x_in, prev, is_xpbd, iters, slot, spring, other, prm, broken, lambda);
}

/* One node's projection out of the balls after a sweep (see cloth_sphere_project). */
inline void cloth_sphere_project_node(const uint i, const uint n, const uint n_spheres, __global const float4* sphere,
                                      __global const uint* is_xpbd, __global float4* x, __global float4* shift) {
  if (!is_xpbd[i]) return;
  float4 xi = x[i];
  if (xi.w == 0.0f) return;
  for (uint k = 0; k < n_spheres; ++k) {
    const float4 s = sphere[2 * k];
    const float3 d = xi.xyz - s.xyz;
    const float dist = length(d);
    if (dist < s.w && dist > 0.0f) {
      const float3 moved = (s.w - dist) * (d / dist);
      xi.xyz += moved;
      shift[k * n + i] += (float4)(moved, 0.0f);
    }
  }
  x[i] = xi;
}

/* The whole XPBD solve of a step in one launch (one work-group): the same colour passes as
 * cloth_xpbd_colour, in the same order and ping-ponging the same two buffers (x0 -> x1 -> x0 ...),
 * with a work-group barrier between passes instead of a kernel launch, and the projection out of
 * the balls after every sweep. Bitwise equal to the per-colour launches; it replaces their
 * iterations x colours launches (192 per step for a 16-sweep grid cloth, 12 colours) by one. The
 * work-items stride over the nodes. Used for cloths small enough that one work-group is faster
 * than the launches (ClothSim::kFusedMaxNodes). */
__kernel void cloth_xpbd_solve(const uint n, const float dt, const uint sweeps, const uint n_colours,
                               const uint n_spheres, __global float4* x0, __global float4* x1,
                               __global const float4* prev, __global const uint* is_xpbd,
                               __global const uint* iters, __global const uint* slot,
                               __global const uint* spring, __global const uint* other,
                               __global const float4* prm, __global const uint* broken,
                               __global float* lambda, __global const float4* sphere, __global float4* shift) {
  const uint lid = get_local_id(0), L = get_local_size(0);
  __global float4* src = x0;
  __global float4* dst = x1;
  for (uint it = 0; it < sweeps; ++it) {
    for (uint c = 0; c < n_colours; ++c) {
      for (uint i = lid; i < n; i += L)
        dst[i] = cloth_xpbd_node(i, n, dt, it, c, src, prev, is_xpbd, iters, slot, spring, other, prm, broken, lambda);
      barrier(CLK_GLOBAL_MEM_FENCE);
      __global float4* t = src;
      src = dst;
      dst = t;
    }
    if (n_spheres > 0) {
      for (uint i = lid; i < n; i += L) cloth_sphere_project_node(i, n, n_spheres, sphere, is_xpbd, src, shift);
      barrier(CLK_GLOBAL_MEM_FENCE);
    }
  }
}

/* XPBD, Algorithm 1 line 16: v = (x - prev) / dt; anchored nodes take their scripted velocity.
 * The inverse mass goes back from the solve's effective 1 / (m (1 + dt c)) to 1 / m (prev.w). */
__kernel void cloth_xpbd_velocity(const uint n, const float dt, const float t, __global float4* x,
                                  __global const float4* prev, __global const float4* anchor,
                                  __global const float4* track, __global const uint* is_xpbd, __global float4* v) {
  const uint i = get_global_id(0);
  if (i >= n || !is_xpbd[i]) return;
  const float4 x4 = x[i];
  const float4 p4 = prev[i];
  x[i] = (float4)(x4.xyz, p4.w);
  if (x4.w == 0.0f)
    v[i] = (float4)(cloth_anchor_v(i, t + dt, anchor, track), 0.0f);
  else
    v[i] = (float4)((x4.xyz - p4.xyz) / dt, 0.0f);
}

/* DFSPH's strong coupling (ClothSim::dryVelocityChange): a step's velocity change without the fluid. */
__kernel void cloth_velocity_change(const uint n, __global const float4* v1, __global const float4* v0,
                                    __global float4* dv) {
  const uint i = get_global_id(0);
  if (i >= n) return;
  dv[i] = (float4)(v1[i].xyz - v0[i].xyz, 0.0f);
}

/* DFSPH's added mass: the momentum M (v1 - v0) that node i's added mass took over the whole step adds
 * to what the fluid has yet to take (before the next step's solves, Simulation::clothAddedMass, which
 * clears it; unit: N s). */
__kernel void cloth_added_mass_impulse(const uint n, __global const float* fict, __global const float4* v1,
                                       __global const float4* v0, __global float4* impulse) {
  const uint i = get_global_id(0);
  if (i >= n) return;
  impulse[i] = (float4)(impulse[i].xyz + fict[i] * (v1[i].xyz - v0[i].xyz), 0.0f);
}

/* The domain's closed walls (after either solver's step): a free node past one is put back just
 * inside (margin) and keeps no velocity into the wall, as a fluid particle in integrate.cl. Bit 2a of
 * mask closes the wall at lo[a], bit 2a + 1 the one at hi[a]. Anchored nodes (w = 0) are scripted. */
__kernel void cloth_domain_walls(const uint n, const float4 lo, const float4 hi, const uint mask,
                                 const float margin, __global float4* x, __global float4* v, __global float4* xlo) {
  const uint i = get_global_id(0);
  if (i >= n) return;
  float4 p = x[i];
  if (p.w == 0.0f) return;
  const float4 p0 = p;
  float4 u = v[i];
  if ((mask & 1u) && p.x < lo.x) { p.x = lo.x + margin; u.x = fmax(u.x, 0.0f); }
  if ((mask & 2u) && p.x > hi.x) { p.x = hi.x - margin; u.x = fmin(u.x, 0.0f); }
  if ((mask & 4u) && p.y < lo.y) { p.y = lo.y + margin; u.y = fmax(u.y, 0.0f); }
  if ((mask & 8u) && p.y > hi.y) { p.y = hi.y - margin; u.y = fmin(u.y, 0.0f); }
  if ((mask & 16u) && p.z < lo.z) { p.z = lo.z + margin; u.z = fmax(u.z, 0.0f); }
  if ((mask & 32u) && p.z > hi.z) { p.z = hi.z - margin; u.z = fmin(u.z, 0.0f); }
  /* A node put back is where x says: its low part (explicit solver) goes. */
  if (any(p0 != p)) xlo[i] = (float4)(0.0f);
  x[i] = p;
  v[i] = u;
}

/* Tearing: spring s breaks for good when its strain (L - L0) / L0 exceeds its tear strain. One
 * work-item per spring writes only its own flag. */
__kernel void cloth_tear(const uint ns, __global const float4* x, __global const uint* ends,
                         __global const float4* prm, __global uint* broken) {
  const uint s = get_global_id(0);
  if (s >= ns || broken[s]) return;
  const float4 p = prm[s];
  const float L = length(x[ends[2 * s + 1]].xyz - x[ends[2 * s]].xyz);
  if (L - p.x > p.w * p.x) broken[s] = 1u;
}

/* Coupling with the fluid (stage: cloth_coupling): node k is boundary particle offset + k, like a
 * moving body's particle (rigid.cl): its position and volume ratio into bsrc and its sorted slot
 * in bpos, its velocity into bvel (the fluid's no-slip and Adami wall pressure use it). Its speed
 * joins the step's largest (integer atomic max of the float's bits: exact), which bounds how far
 * the neighbour lists may drift. */
__kernel void cloth_to_boundary(const uint n, const uint offset, __global const float4* x,
                                __global const float4* v, __global const float* volume,
                                __global const uint* slot, __global float4* bsrc, __global float4* bpos,
                                __global float4* bvel, volatile __global uint* max_speed_bits) {
  const uint k = get_global_id(0);
  if (k >= n) return;
  const float4 out = (float4)(x[k].xyz, volume[k]);
  const uint s = slot[offset + k];
  bsrc[offset + k] = out;
  bpos[s] = out;
  bvel[s] = (float4)(v[k].xyz, 0.0f);
  const uint sb = as_uint(length(v[k].xyz));
  if (sb > *max_speed_bits) atomic_max(max_speed_bits, sb);
}

/* Contact with balls (particle coupling, stage: cloth). sphere[2k] = (centre, radius), sphere[2k+1]
 * = (velocity, friction coefficient). A free node inside sphere k goes to its surface along the
 * normal n and loses its velocity into the sphere relative to it (perfectly inelastic: the cloth
 * does not bounce balls off numerically) and, by Coulomb friction, tangential relative velocity up
 * to mu times that (so the nodes do not slide round the ball and let it through). impulse[k n_nodes + i] is what node i gives sphere k,
 * -m dv (unit: N s); the spheres are taken in order. */
__kernel void cloth_sphere_contact(const uint n, const uint n_spheres, __global const float4* sphere,
                                   __global const float* mass, __global const uint* is_xpbd, __global float4* x,
                                   __global float4* v, __global float4* impulse, __global float4* xlo) {
  const uint i = get_global_id(0);
  if (i >= n) return;
  if (is_xpbd[i]) {
    for (uint k = 0; k < n_spheres; ++k) impulse[k * n + i] = (float4)(0.0f);
    return;
  }
  float4 xi = x[i];
  float3 vi = v[i].xyz;
  for (uint k = 0; k < n_spheres; ++k) {
    float3 J = (float3)(0.0f);
    const float4 s = sphere[2 * k];
    const float3 d = xi.xyz - s.xyz;
    const float dist = length(d);
    if (xi.w > 0.0f && dist < s.w && dist > 0.0f) {
      const float3 nrm = d / dist;
      xi.xyz = s.xyz + s.w * nrm;
      xlo[i] = (float4)(0.0f);  /* placed on the surface: no low part */
      const float4 sv = sphere[2 * k + 1];
      const float3 rel = vi - sv.xyz;
      const float vn = dot(rel, nrm);
      if (vn < 0.0f) {
        /* Normal: inelastic. Tangential: Coulomb friction, |dv_t| <= mu |dv_n| (mu = sv.w). */
        const float3 vt = rel - vn * nrm;
        const float st = length(vt);
        const float keep = st > 0.0f ? fmax(0.0f, 1.0f - sv.w * (-vn) / st) : 0.0f;
        const float3 dv = -vn * nrm - (1.0f - keep) * vt;
        vi += dv;
        J = -mass[i] * dv;
      }
    }
    impulse[k * n + i] = (float4)(J, 0.0f);
  }
  x[i] = xi;
  v[i] = (float4)(vi, 0.0f);
}

/* Per sphere k: the impulses of all nodes, summed in node order (deterministic). */
__kernel void cloth_sphere_reduce(const uint n, const uint n_spheres, __global const float4* impulse,
                                  __global float4* out) {
  const uint k = get_global_id(0);
  if (k >= n_spheres) return;
  float3 J = (float3)(0.0f);
  for (uint i = 0; i < n; ++i) J += impulse[k * n + i].xyz;
  out[k] = (float4)(J, 0.0f);
}

/* XPBD contact with balls, inside the solve (Mueller et al. 2007, PBD collision constraints): after
 * each sweep a free node inside sphere k moves to its surface along the normal; the moves add up in
 * shift[k n + i]. Over the step they are the node's impulse from the ball, m (1 + dt c) shift / dt
 * (v = (x - prev) / dt, on the solve's effective mass), so the ball receives its opposite
 * (cloth_sphere_shift_reduce). */
__kernel void cloth_sphere_project(const uint n, const uint n_spheres, __global const float4* sphere,
                                   __global const uint* is_xpbd, __global float4* x, __global float4* shift) {
  const uint i = get_global_id(0);
  if (i >= n) return;
  cloth_sphere_project_node(i, n, n_spheres, sphere, is_xpbd, x, shift);
}

/* Per sphere k: J = -sum_i (m_i (1 + dt c_i) + M_i) shift_i / dt over the nodes in order
 * (deterministic): the projection acts on the effective mass of the solve (cloth_xpbd_predict, M_i
 * DFSPH's added mass of a wet node), so a ball resting on the cloth receives exactly what holds it. */
__kernel void cloth_sphere_shift_reduce(const uint n, const uint n_spheres, const float dt,
                                        __global const float* mass, __global const float* drag,
                                        __global const float* fict, __global const float4* shift,
                                        __global float4* out) {
  const uint k = get_global_id(0);
  if (k >= n_spheres) return;
  float3 J = (float3)(0.0f);
  for (uint i = 0; i < n; ++i) J -= (mass[i] * (1.0f + dt * drag[i]) + fict[i]) * shift[k * n + i].xyz;
  out[k] = (float4)(J / dt, 0.0f);
}

/* Cutting (a rigid body with cutter: true, a scalpel blade). Segment (p, q) against triangle
 * (a, b, c) (Moeller & Trumbore 1997): the segment crosses the triangle when its parameter t of
 * p + t (q - p) is in [0, 1] and the barycentric (u, v) lie in the triangle. */
inline bool cloth_segment_hits_triangle(const float3 p, const float3 d, const float3 a, const float3 b,
                                        const float3 c, const float tmax) {
  const float3 e1 = b - a, e2 = c - a;
  const float3 h = cross(d, e2);
  const float det = dot(e1, h);
  if (fabs(det) < 1e-20f) return false;
  const float f = 1.0f / det;
  const float3 s = p - a;
  const float u = f * dot(s, h);
  if (u < 0.0f || u > 1.0f) return false;
  const float3 qv = cross(s, e1);
  const float v = f * dot(d, qv);
  if (v < 0.0f || u + v > 1.0f) return false;
  const float t = f * dot(e2, qv);
  return t >= 0.0f && t <= tmax;
}

/* Solid angle of triangle (a, b, c) seen from the origin (Van Oosterom & Strackee 1983), signed. */
inline float cloth_solid_angle(const float3 a, const float3 b, const float3 c) {
  const float la = length(a), lb = length(b), lc = length(c);
  const float num = dot(a, cross(b, c));
  const float den = la * lb * lc + dot(a, b) * lc + dot(b, c) * la + dot(c, a) * lb;
  return 2.0f * atan2(num, den);
}

/* Spring s breaks for good when its segment crosses a cutter's surface, or lies inside it (its
 * midpoint's generalised winding number, Jacobson et al. 2013, above 1/2: robust where a parity
 * ray through a mesh edge is not). Cutter k: pose[4k .. 4k+2] = rows of R^T (world -> body),
 * pose[4k+3] = centre of mass (world); range[k] = (first triangle, count); tri[3t .. 3t+2] = the
 * body-frame corners. One work-item per spring writes only its own flag (deterministic). */
__kernel void cloth_cut(const uint ns, const uint n_cutters, __global const float4* x, __global const uint* ends,
                        __global const float4* pose, __global const uint2* range, __global const float4* tri,
                        __global uint* broken) {
  const uint s = get_global_id(0);
  if (s >= ns || broken[s]) return;
  const float3 xa = x[ends[2 * s]].xyz, xb = x[ends[2 * s + 1]].xyz;
  for (uint k = 0; k < n_cutters; ++k) {
    const float3 r0 = pose[4 * k].xyz, r1 = pose[4 * k + 1].xyz, r2 = pose[4 * k + 2].xyz, c = pose[4 * k + 3].xyz;
    /* The spring's ends in the cutter's body frame. */
    const float3 da = xa - c, db = xb - c;
    const float3 p = (float3)(dot(r0, da), dot(r1, da), dot(r2, da));
    const float3 q = (float3)(dot(r0, db), dot(r1, db), dot(r2, db));
    const float3 m = 0.5f * (p + q);
    bool cut = false;
    float omega = 0.0f;
    for (uint t = range[k].x; t < range[k].x + range[k].y && !cut; ++t) {
      const float3 a = tri[3 * t].xyz, b = tri[3 * t + 1].xyz, cc = tri[3 * t + 2].xyz;
      cut = cloth_segment_hits_triangle(p, q - p, a, b, cc, 1.0f);
      omega += cloth_solid_angle(a - m, b - m, cc - m);
    }
    /* Winding number omega / 4 pi: about 1 inside, 0 outside. */
    if (cut || omega > 2.0f * M_PI_F) {
      broken[s] = 1u;
      return;
    }
  }
}

/* DFSPH's strong coupling (dfsph.cl, dfsph_node_accel): how a node answers a force within one step,
 * its springs implicit with the other ends held: M_i = m_i (1 + dt c_air) I + sum over its unbroken
 * springs of K_e (shared/cloth_springs.h: dt c + dt^2 k along the spring, dt^2 max(T, 0) / L across
 * it), so a = M_i^-1 F. A flat sheet's springs do not resist its own normal motion (only the tension
 * does), a sagging one's do. Out: the rows of M_i^-1 (3 float4 per node, unit: 1/kg); zero for
 * anchored nodes. */
__kernel void cloth_node_response(const uint n, const float dt, __global const float4* x, __global const float* mass,
                                  __global const float* drag, __global const uint* row_start,
                                  __global const uint* spring, __global const uint* other,
                                  __global const float4* prm, __global const uint* broken, __global const float* fict,
                                  __global float4* minv) {
  const uint i = get_global_id(0);
  if (i >= n) return;
  const float4 xi = x[i];
  if (xi.w == 0.0f) {
    minv[3 * i] = minv[3 * i + 1] = minv[3 * i + 2] = (float4)(0.0f);
    return;
  }
  const float m0 = mass[i] * (1.0f + dt * drag[i]) + fict[i];
  float a00 = m0, a11 = m0, a22 = m0, a01 = 0.0f, a02 = 0.0f, a12 = 0.0f;
  for (uint e = row_start[i]; e < row_start[i + 1]; ++e) {
    const uint sp = spring[e];
    if (broken[sp]) continue;
    const float3 d = x[other[e]].xyz - xi.xyz;
    const float L = length(d);
    if (L <= 0.0f) continue;
    const float3 u = d / L;
    const float4 q = prm[sp];
    const float2 K = cloth_spring_step_stiffness(q, L, dt); /* along, across (shared/cloth_springs.h) */
    const float ax = K.x, tr = K.y;
    const float c = ax - tr;
    a00 += tr + c * u.x * u.x;
    a11 += tr + c * u.y * u.y;
    a22 += tr + c * u.z * u.z;
    a01 += c * u.x * u.y;
    a02 += c * u.x * u.z;
    a12 += c * u.y * u.z;
  }
  /* the inverse of the symmetric positive definite 3 x 3 by its adjugate */
  const float c00 = a11 * a22 - a12 * a12, c01 = a02 * a12 - a01 * a22, c02 = a01 * a12 - a02 * a11;
  const float c11 = a00 * a22 - a02 * a02, c12 = a01 * a02 - a00 * a12, c22 = a00 * a11 - a01 * a01;
  const float inv = 1.0f / (a00 * c00 + a01 * c01 + a02 * c02);
  /* w of the first row: 1 / (m + M) with a fictitious mass M (dfsph_node_slots), else 0 (it takes 1 / m) */
  minv[3 * i] = (float4)((float3)(c00, c01, c02) * inv, fict[i] > 0.0f ? 1.0f / (mass[i] + fict[i]) : 0.0f);
  minv[3 * i + 1] = (float4)(c01, c11, c12, 0.0f) * inv;
  minv[3 * i + 2] = (float4)(c02, c12, c22, 0.0f) * inv;
}
